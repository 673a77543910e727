#!/usr/bin/env python3
"""Does the registration nodelet keep up with a live lidar? Latches one scan of a bag as the target, then
plays the bag's scans looped at their native rate on `source` for --duration seconds, and reports what the
node made of them: scans published and received, results (success, unverified, other failures), drops,
latency (a scan's stamp to its ~result) and the time of each stage, from ~result and /diagnostics. Not a
test: it measures, and its numbers go to BENCHMARKS.md ("The node under stress").

It starts its own roscore (on --port, loopback only), a nodelet manager and the RegistrationNodelet
(--no-bond) with a preset, and stops them when it is done. Each scan is stamped with the time it is sent
(what a driver does), so latency is measured in one clock; the bag's own stamps are years old.

    source ../mac_registration_ws/devel/setup.bash
    python3 scripts/measure_stream.py [--duration 60] [--preset config/outdoor_lidar.yaml]
        [--set features/voxel_size=0.5 ...] [--json FILE]

Exit status: 0 when the manager ran throughout and at least one scan was registered, 1 otherwise."""
import argparse
import json
import os
import sys
import threading
import time

from nodelet_harness import NODE, PACKAGE, Processes, overrides, percentiles

DEFAULT_BAG = os.path.join(PACKAGE, "test", "data", "luminar_5_scans.bag")
DEFAULT_REFERENCE = os.path.join(PACKAGE, "test", "data", "luminar_5_scans_reference.tsv")
TARGET_TOPIC = "/registration_target"
SOURCE_TOPIC = "/registration_source"
# The lidar criterion of the benchmarks (KITTI convention): a result this close to the reference is right.
MAX_ROTATION_ERROR_DEG, MAX_TRANSLATION_ERROR = 5.0, 0.6
STAGES = ["front_end", "graph", "second_order", "clique_search", "selection", "hypotheses", "evaluation",
          "refinement", "verification", "total"]


def parse_arguments():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bag", default=DEFAULT_BAG)
    parser.add_argument("--topic", default="/luminar_pointcloud", help="the bag's PointCloud2 topic")
    parser.add_argument("--target-index", type=int, default=0, help="which scan of the bag is the target")
    parser.add_argument("--reference", default=DEFAULT_REFERENCE,
                        help="alignments of scan j into scan 0 (rows: j, 4x4 row-major); '' = no check")
    parser.add_argument("--duration", type=float, default=60.0, help="length of the stream [s]")
    parser.add_argument("--rate-factor", type=float, default=1.0, help="1 = the bag's native rate")
    parser.add_argument("--port", type=int, default=11459, help="port of the roscore this run starts")
    parser.add_argument("--preset", default=os.path.join(PACKAGE, "config", "outdoor_lidar.yaml"))
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="a private parameter of the node after the preset, e.g. features/voxel_size=0.5")
    parser.add_argument("--watch-outputs", action="store_true",
                        help="subscribe to ~aligned and ~correspondence_markers too (the node builds them only "
                             "for a subscriber)")
    parser.add_argument("--json", help="also write the report there")
    return parser.parse_args()


def read_scans(bag_path, topic):
    """The bag's clouds on `topic` and the seconds between consecutive ones (by their header stamps)."""
    import rosbag

    with rosbag.Bag(bag_path) as bag:
        scans = [msg for _, msg, _ in bag.read_messages(topics=[topic])]
    if len(scans) < 2:
        sys.exit("measure_stream: %s holds %d clouds on %s; at least 2 are needed" % (bag_path, len(scans), topic))
    gaps = [(b.header.stamp - a.header.stamp).to_sec() for a, b in zip(scans, scans[1:])]
    if min(gaps) <= 0:
        sys.exit("measure_stream: the stamps on %s in %s do not increase" % (topic, bag_path))
    # Looping, the first scan follows the last after one mean gap.
    return scans, gaps + [sum(gaps) / len(gaps)]


def cpu_seconds(pid):
    """User + system CPU time of a process so far [s] (Linux /proc), or None."""
    try:
        with open("/proc/%d/stat" % pid) as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return None


def read_reference(path):
    import numpy

    reference = {0: numpy.eye(4)}
    if not path:
        return None
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                values = line.split()
                reference[int(values[0])] = numpy.array([float(v) for v in values[1:17]]).reshape(4, 4)
    return reference


def transform_matrix(t):
    import numpy

    x, y, z, w = t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w
    T = numpy.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = [t.translation.x, t.translation.y, t.translation.z]
    return T


def pose_errors(T, truth):
    """Rotation [deg] and translation [m] errors of T against truth."""
    import numpy

    delta = numpy.linalg.inv(truth) @ T
    cos = max(-1.0, min(1.0, (numpy.trace(delta[:3, :3]) - 1.0) / 2.0))
    return numpy.degrees(numpy.arccos(cos)), float(numpy.linalg.norm(T[:3, 3] - truth[:3, 3]))


class Stream:
    def __init__(self, args, processes, scans, gaps):
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray
        from mac_registration.msg import RegistrationResult
        from sensor_msgs.msg import PointCloud2

        self.rospy, self.Result = rospy, RegistrationResult
        self.args, self.processes, self.scans, self.gaps = args, processes, scans, gaps
        self.lock = threading.Lock()
        self.sent = {}  # stamp (nanoseconds) -> (scan index, wall time sent)
        self.results = {}  # stamp -> (result, wall time received)
        self.diagnostics = []  # (wall time, {key: value})
        rospy.Subscriber(NODE + "/result", RegistrationResult, self.on_result, queue_size=100)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=10)
        self.outputs_seen = {"aligned": 0, "correspondence_markers": 0}
        if args.watch_outputs:
            from visualization_msgs.msg import MarkerArray

            rospy.Subscriber(NODE + "/aligned", PointCloud2, self.count_output, "aligned", queue_size=2)
            rospy.Subscriber(NODE + "/correspondence_markers", MarkerArray, self.count_output,
                             "correspondence_markers", queue_size=2)
        self.source_pub = rospy.Publisher(SOURCE_TOPIC, PointCloud2, queue_size=2)
        self.target_pub = rospy.Publisher(TARGET_TOPIC, PointCloud2, queue_size=1, latch=True)
        reference = read_reference(args.reference)
        self.reference = None
        if reference is not None and args.target_index in reference:
            import numpy

            # Scan j into the target scan k: T_k_j = inv(T_0_k) T_0_j.
            T_0k_inv = numpy.linalg.inv(reference[args.target_index])
            self.reference = {j: T_0k_inv @ T for j, T in reference.items()}
        self.report = {"command": " ".join(sys.argv), "cpus": os.cpu_count(), "bag": args.bag,
                       "scans_in_bag": len(scans), "points": [s.width * s.height for s in scans],
                       "target_index": args.target_index, "preset": args.preset,
                       "overrides": processes.params, "load_average_start": os.getloadavg()[0]}

    def on_result(self, msg):
        now = time.time()
        with self.lock:
            self.results.setdefault(msg.header.stamp.to_nsec(), (msg, now))

    def count_output(self, _, name):
        with self.lock:
            self.outputs_seen[name] += 1

    def on_diagnostics(self, msg):
        for status in msg.status:
            if "registration" in status.name:
                with self.lock:
                    self.diagnostics.append((time.time(), {kv.key: kv.value for kv in status.values}))

    def latest_diagnostics(self):
        with self.lock:
            return dict(self.diagnostics[-1][1]) if self.diagnostics else {}

    def wait_for_diagnostics(self, accept, timeout=5.0):
        """The first diagnostics values (newest first) that `accept` takes, waiting up to timeout."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            with self.lock:
                if self.diagnostics and accept(*self.diagnostics[-1]):
                    return dict(self.diagnostics[-1][1])
            time.sleep(0.05)
        return self.latest_diagnostics()

    def publish_scan(self, index):
        msg = self.scans[index]
        msg.header.stamp = self.rospy.Time.now()
        with self.lock:
            self.sent[msg.header.stamp.to_nsec()] = (index, time.time())
        self.source_pub.publish(msg)
        return msg.header.stamp.to_nsec()

    def latch_target(self):
        deadline = time.time() + 30
        while time.time() < deadline and (self.source_pub.get_num_connections() == 0
                                          or self.target_pub.get_num_connections() == 0):
            time.sleep(0.05)
        if self.source_pub.get_num_connections() == 0:
            sys.exit("measure_stream: the node did not subscribe to %s" % SOURCE_TOPIC)
        target = self.scans[self.args.target_index]
        target.header.frame_id = "registration_target"  # its own frame: tf refuses a transform to itself
        target.header.stamp = self.rospy.Time.now()
        self.target_pub.publish(target)
        time.sleep(0.5)

    def warm_up(self):
        """One scan before the clock starts: the target is described during its registration."""
        stamp = self.publish_scan((self.args.target_index + 1) % len(self.scans))
        deadline = time.time() + 60
        while time.time() < deadline:
            with self.lock:
                if stamp in self.results:
                    msg, _ = self.results.pop(stamp)
                    self.sent.pop(stamp)
                    self.report["warm_up"] = {"success": msg.success, "message": msg.message,
                                              "front_end_ms": msg.time_front_end_ms,
                                              "total_ms": msg.time_total_ms}
                    return
            time.sleep(0.02)
        sys.exit("measure_stream: no result for the first scan within 60 s")

    def stream(self):
        # The counters to start from: a diagnostics update (1 Hz) that counts the warm-up's result.
        before = self.wait_for_diagnostics(lambda _, values: float(values.get("registrations", 0)) >= 1)
        cpu_before = cpu_seconds(self.processes.manager.pid)
        start = time.time()
        next_at, index, published = start, 0, 0
        while next_at < start + self.args.duration and self.processes.manager_status() is None:
            time.sleep(max(0.0, next_at - time.time()))
            self.publish_scan(index)
            published += 1
            next_at += self.gaps[index] / self.args.rate_factor
            index = (index + 1) % len(self.scans)
        elapsed = time.time() - start
        cpu_after = cpu_seconds(self.processes.manager.pid)
        if cpu_before is not None and cpu_after is not None:
            # How many cores the nodelet manager kept busy: near os.cpu_count(), the work is already parallel.
            self.report["manager_cores_busy"] = (cpu_after - cpu_before) / elapsed
        time.sleep(3.0)  # the last result
        now = time.time()
        after = self.wait_for_diagnostics(lambda received, _: received > now)
        self.summarize(published, elapsed, before, after)

    def summarize(self, published, elapsed, before, after):
        with self.lock:
            matched = [(self.sent[s][0], msg, received - self.sent[s][1])
                       for s, (msg, received) in self.results.items() if s in self.sent]
        statuses = {}
        for _, msg, _ in matched:
            statuses[msg.status] = statuses.get(msg.status, 0) + 1
        latency = [1000.0 * seconds for _, _, seconds in matched]
        stage_ms = {stage: [getattr(msg, "time_%s_ms" % stage) for _, msg, _ in matched] for stage in STAGES}
        right = None
        if self.reference is not None:
            right = 0
            for index, msg, _ in matched:
                if msg.success and index in self.reference:
                    rotation, translation = pose_errors(transform_matrix(msg.transform), self.reference[index])
                    right += rotation <= MAX_ROTATION_ERROR_DEG and translation <= MAX_TRANSLATION_ERROR

        def counter_delta(word):
            for key, value in after.items():
                if word in key and key in before:
                    return int(float(value)) - int(float(before[key]))
            return None

        self.report.update({
            "load_average_end": os.getloadavg()[0], "manager_exit_code": self.processes.manager_status(),
            "duration_s": elapsed, "published": published, "rate_hz": published / elapsed,
            "received_per_diagnostics": counter_delta("received"), "results": len(matched),
            "registered_fraction": len(matched) / published if published else 0.0,
            "succeeded": statuses.get(self.Result.SUCCESS, 0),
            "unverified": statuses.get(self.Result.UNVERIFIED, 0),
            "other_failures": len(matched) - statuses.get(self.Result.SUCCESS, 0)
            - statuses.get(self.Result.UNVERIFIED, 0),
            "within_reference_criterion": right,
            "dropped_per_diagnostics": counter_delta("dropped"),
            "target_descriptions_per_diagnostics": counter_delta("target descriptions"),
            "latency": percentiles(latency, (0.5, 0.95)),
            "stage_mean_ms": {s: sum(v) / len(v) if v else None for s, v in stage_ms.items()},
            "stage_p50_ms": {s: percentiles(v).get("p50_ms") for s, v in stage_ms.items()},
            "diagnostics_last": after,
            "outputs_seen": dict(self.outputs_seen) if self.args.watch_outputs else None,
        })


def describe_latency(latency):
    if latency.get("n", 0) == 0:
        return "none"
    return "p50 %.0f ms, p95 %.0f ms, max %.0f ms" % (latency["p50_ms"], latency["p95_ms"], latency["max_ms"])


def print_report(r):
    print("measure_stream: %s" % r["command"])
    print("  %d cpus, 1-min load average %.1f at the start, %.1f at the end; bag %s (%d scans, %s points), "
          "target scan %d; preset %s %s" % (r["cpus"], r["load_average_start"], r["load_average_end"], r["bag"],
                                           r["scans_in_bag"], "/".join(map(str, r["points"])), r["target_index"],
                                           os.path.basename(r["preset"]), r["overrides"] or ""))
    w = r["warm_up"]
    print("  first scan (the target described with it): %s, front end %.0f ms, total %.0f ms" % (
        "success" if w["success"] else "failed: " + w["message"], w["front_end_ms"], w["total_ms"]))
    print("  stream: %d scans in %.1f s (%.1f Hz); node received %s; %d results (%.0f %%): %d succeeded, "
          "%d unverified, %d other failures; %s within %.0f deg / %.1f m of the reference; dropped %s "
          "(/diagnostics); target descriptions during the stream %s" % (
              r["published"], r["duration_s"], r["rate_hz"], r["received_per_diagnostics"], r["results"],
              100.0 * r["registered_fraction"], r["succeeded"], r["unverified"], r["other_failures"],
              r["within_reference_criterion"], MAX_ROTATION_ERROR_DEG, MAX_TRANSLATION_ERROR,
              r["dropped_per_diagnostics"], r["target_descriptions_per_diagnostics"]))
    print("  stamp -> ~result latency: %s; the nodelet manager kept %s cores busy" % (
        describe_latency(r["latency"]), "%.2f" % r["manager_cores_busy"] if "manager_cores_busy" in r else "?"))
    print("  stage means [ms] (~result): " + ", ".join(
        "%s %.1f" % (s, v) for s, v in r["stage_mean_ms"].items() if v is not None))
    if r["outputs_seen"] is not None:
        print("  outputs watched: %s" % ", ".join("%d on ~%s" % (n, name) for name, n in r["outputs_seen"].items()))
    print("  /diagnostics at the end: " + "; ".join("%s: %s" % kv for kv in r["diagnostics_last"].items()))
    if r["manager_exit_code"] is not None:
        print("  the nodelet manager exited with %s" % r["manager_exit_code"])


def main():
    args = parse_arguments()
    scans, gaps = read_scans(args.bag, args.topic)
    if not 0 <= args.target_index < len(scans):
        sys.exit("measure_stream: --target-index %d, but the bag holds %d scans" % (args.target_index, len(scans)))
    params = overrides(args.set, "measure_stream")
    processes = Processes(args.port, args.preset, name="measure_stream", params=params,
                          remaps={"source": SOURCE_TOPIC, "target": TARGET_TOPIC})
    try:
        processes.bring_up()
        import rospy

        rospy.init_node("measure_stream", disable_signals=True)
        rospy.wait_for_service(NODE + "/register", timeout=60)
        run = Stream(args, processes, scans, gaps)
        run.latch_target()
        run.warm_up()
        run.stream()
    finally:
        processes.stop()
    print_report(run.report)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(run.report, f, indent=2)
    return 0 if run.report["manager_exit_code"] is None and run.report["results"] > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
