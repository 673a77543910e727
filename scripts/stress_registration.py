#!/usr/bin/env python3
"""Stress run of the registration nodelet: replays the malformed-cloud corpus, then streams a real scan at
10 Hz on `source` while other threads call ~register in parallel (valid scans and the corpus mixed), and
reports crashes, drops and latency. Not a test: it measures, and its numbers go to BENCHMARKS.md.

It starts its own roscore (on --port, loopback only), a nodelet manager and the RegistrationNodelet
(--no-bond) with a preset, and stops them when it is done; every loop is bounded by count or time.

    source ../mac_registration_ws/devel/setup.bash
    python3 scripts/stress_registration.py [--duration 60] [--rate 10] [--service-threads 2]
        [--set service_threads=8 ...] [--json FILE]

Every registration of the real scan registers the same pair, so each should give the same transform and
inliers whatever runs beside it: the report counts the results that differ from the most common one.

Exit status: 0 when nothing crashed and every input got its expected answer, 1 otherwise."""
import argparse
import json
import os
import sys
import threading
import time

from collections import Counter

from nodelet_harness import NODE, PACKAGE, Processes, overrides, percentiles

sys.path.insert(0, os.path.join(PACKAGE, "test", "ros"))


def parse_arguments():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="length of the stream phase [s]")
    parser.add_argument("--rate", type=float, default=10.0, help="scans published on `source` [Hz]")
    parser.add_argument("--service-threads", type=int, default=2, help="threads calling ~register in parallel")
    parser.add_argument("--malformed-every", type=int, default=3,
                        help="every Nth parallel service call sends a corpus cloud instead of a valid scan")
    parser.add_argument("--port", type=int, default=11457, help="port of the roscore this run starts")
    parser.add_argument("--preset", default=os.path.join(PACKAGE, "config", "indoor_rgbd.yaml"))
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="a private parameter of the node after the preset, e.g. service_threads=8")
    parser.add_argument("--json", help="also write the report there")
    return parser.parse_args()


class Run:
    def __init__(self, args, processes):
        import rospy
        from mac_registration.msg import RegistrationResult
        from mac_registration.srv import Register
        from malformed_clouds import CORPUS, read_pcd_xyz, xyz_cloud
        from sensor_msgs.msg import PointCloud2
        from diagnostic_msgs.msg import DiagnosticArray

        self.rospy, self.Register, self.CORPUS, self.xyz_cloud = rospy, Register, CORPUS, xyz_cloud
        self.Result = RegistrationResult
        self.args, self.processes = args, processes
        data = os.path.join(PACKAGE, "data", "redkitchen_4_0")
        self.source_points = read_pcd_xyz(os.path.join(data, "source_cloud_bin_4.pcd"))
        self.target = xyz_cloud(read_pcd_xyz(os.path.join(data, "target_cloud_bin_0.pcd")), "fragment_0")
        self.lock = threading.Lock()
        self.stream_sent, self.stream_latency_ms, self.stream_results = {}, [], {}
        # The transform and inliers of every successful registration of the real pair, by who asked.
        self.outcomes = {"stream": [], "service": []}
        self.diagnostics = []
        rospy.Subscriber(NODE + "/result", RegistrationResult, self.on_result, queue_size=100)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=10)
        self.source_pub = rospy.Publisher("/source", PointCloud2, queue_size=1)
        self.target_pub = rospy.Publisher("/target", PointCloud2, queue_size=1, latch=True)
        # The machine's load, for reading the latencies: other work on it slows every stage.
        self.report = {"command": " ".join(sys.argv), "crashes": [], "unexpected": [],
                       "load_average_start": os.getloadavg()[0], "cpus": os.cpu_count()}

    def on_result(self, msg):
        now = time.time()
        with self.lock:
            sent = self.stream_sent.get(msg.child_frame_id)
            if sent is not None and msg.child_frame_id not in self.stream_results:
                self.stream_results[msg.child_frame_id] = (msg.success, msg.message)
                self.stream_latency_ms.append(1000.0 * (now - sent))
                if msg.success and msg.child_frame_id.startswith("stream_"):
                    self.outcomes["stream"].append(outcome(msg))

    def on_diagnostics(self, msg):
        for status in msg.status:
            if "registration" in status.name:
                values = {kv.key: kv.value for kv in status.values}
                with self.lock:
                    self.diagnostics.append(values)

    def diagnostic(self, word):
        """The latest value of the /diagnostics key containing `word`, or None."""
        with self.lock:
            for values in reversed(self.diagnostics):
                for key, value in values.items():
                    if word in key:
                        return int(float(value))
        return None

    def check_alive(self, phase):
        status = self.processes.manager_status()
        if status is not None and not self.report["crashes"]:  # the first phase that saw it
            self.report["crashes"].append({"phase": phase, "manager_exit_code": status})
        return status is None

    def call(self, proxy, source, target=None):
        start = time.time()
        request_target = target if target is not None else self.xyz_cloud([], "")
        result = proxy(source=source, target=request_target).result
        return result, 1000.0 * (time.time() - start)

    def expect_refused(self, phase, case, reason, result):
        if result.success or reason not in result.message:
            self.report["unexpected"].append({"phase": phase, "case": case, "message": result.message})
            return False
        return True

    def replay_corpus(self):
        proxy = self.rospy.ServiceProxy(NODE + "/register", self.Register)
        refused, latency, service_errors = 0, [], 0
        source = self.xyz_cloud(self.source_points, "corpus_good_source")
        for i, (case, build, reason) in enumerate(self.CORPUS):
            for role in ("source", "target"):
                bad = build("corpus_%s_%d" % (role, i))
                if role == "target" and bad.width * bad.height == 0:
                    continue  # an empty target means "the latest on `target`"
                try:
                    result, ms = self.call(proxy, bad, self.target) if role == "source" else self.call(
                        proxy, source, bad)
                    latency.append(ms)
                    refused += self.expect_refused("corpus", "%s as %s" % (case, role), reason, result)
                except self.rospy.ServiceException as e:
                    service_errors += 1
                    self.report["unexpected"].append({"phase": "corpus", "case": case, "message": str(e)})
                if not self.check_alive("corpus"):
                    break
        topic_answered, topic_refused = 0, 0
        self.hold_target()
        for i, (case, build, reason) in enumerate(self.CORPUS):
            if not self.check_alive("corpus"):
                break
            frame = "corpus_topic_%d" % i
            with self.lock:
                self.stream_sent[frame] = time.time()
            self.source_pub.publish(build(frame))  # one at a time: the node keeps only the newest input
            deadline = time.time() + 10
            while time.time() < deadline and frame not in self.stream_results:
                time.sleep(0.01)
            with self.lock:
                answer = self.stream_results.get(frame)
            if answer is None:
                self.report["unexpected"].append(
                    {"phase": "corpus", "case": case + " on source", "message": "no result"})
                continue
            topic_answered += 1
            topic_refused += self.expect_refused("corpus", case + " on source", reason,
                                                 self.Result(success=answer[0], message=answer[1]))
        with self.lock:
            for frame in [f for f in self.stream_sent if f.startswith("corpus_topic_")]:
                self.stream_sent.pop(frame)
                self.stream_results.pop(frame, None)
            self.stream_latency_ms.clear()
        self.check_alive("corpus")
        self.report["corpus"] = {
            "cases": len(self.CORPUS), "service_calls": len(latency) + service_errors,
            "refused_with_reason": refused, "service_errors": service_errors,
            "service_latency": percentiles(latency),
            "topic_inputs": len(self.CORPUS), "topic_results": topic_answered, "topic_refused": topic_refused,
        }

    def hold_target(self):
        """Publishes the target once both topics are connected, and gives the node a moment to take it."""
        deadline = time.time() + 20
        while time.time() < deadline and (self.source_pub.get_num_connections() == 0
                                          or self.target_pub.get_num_connections() == 0):
            time.sleep(0.05)
        self.target_pub.publish(self.target)
        time.sleep(1.0)

    def service_worker(self, index, stop, stats):
        proxy = self.rospy.ServiceProxy(NODE + "/register", self.Register)
        source = self.xyz_cloud(self.source_points, "")
        calls = 0
        while not stop.is_set() and calls < 100000:
            calls += 1
            malformed = self.args.malformed_every > 0 and calls % self.args.malformed_every == 0
            try:
                if malformed:
                    case, build, reason = self.CORPUS[(calls // self.args.malformed_every) % len(self.CORPUS)]
                    result, ms = self.call(proxy, build("service_%d_%d" % (index, calls)), self.target)
                    ok = self.expect_refused("stream", "parallel " + case, reason, result)
                    with self.lock:
                        stats["malformed_ms"].append(ms)
                        stats["malformed_refused"] += ok
                else:
                    source.header.frame_id = "service_%d_%d" % (index, calls)
                    result, ms = self.call(proxy, source)  # empty target: the latest on `target`
                    with self.lock:
                        stats["valid_ms"].append(ms)
                        stats["valid_success"] += result.success
                        if result.success:
                            self.outcomes["service"].append(outcome(result))
                        if not result.success:
                            self.report["unexpected"].append(
                                {"phase": "stream", "case": "parallel valid scan", "message": result.message})
            except self.rospy.ServiceException as e:
                with self.lock:
                    stats["service_errors"] += 1
                if not self.check_alive("stream"):
                    return
                time.sleep(0.1)

    def stream(self):
        self.hold_target()
        dropped_before = self.diagnostic("dropped") or 0
        stop = threading.Event()
        stats = {"valid_ms": [], "malformed_ms": [], "valid_success": 0, "malformed_refused": 0,
                 "service_errors": 0}
        workers = [threading.Thread(target=self.service_worker, args=(i, stop, stats))
                   for i in range(self.args.service_threads)]
        for w in workers:
            w.start()
        period, published = 1.0 / self.args.rate, 0
        start = time.time()
        end = start + self.args.duration
        msg = self.xyz_cloud(self.source_points, "")  # publish() serializes at once: one message, reused
        while time.time() < end and self.check_alive("stream"):
            frame = "stream_%d" % published
            msg.header.frame_id = frame
            msg.header.stamp = self.rospy.Time.now()
            with self.lock:
                self.stream_sent[frame] = time.time()
            self.source_pub.publish(msg)
            published += 1
            time.sleep(max(0.0, start + published * period - time.time()))
        stop.set()
        for w in workers:
            w.join(timeout=120)
        time.sleep(3.0)  # the last result, and a diagnostics update after it
        with self.lock:
            answered = len(self.stream_results)
            succeeded = sum(success for success, _ in self.stream_results.values())
            latency = list(self.stream_latency_ms)
        dropped = self.diagnostic("dropped")
        uncounted = None if dropped is None else published - answered - (dropped - dropped_before)
        self.report["stream"] = {
            "duration_s": self.args.duration, "rate_hz": self.args.rate, "published": published,
            "results": answered, "succeeded": succeeded, "no_result": published - answered,
            "dropped_per_diagnostics": None if dropped is None else dropped - dropped_before,
            # Scans that got no result and that the worker's one-slot queue did not count either: lost
            # before it (the subscriber's own queue of 1 while the nodelet's callbacks are busy).
            "lost_uncounted": uncounted,
            "diagnostics_last": self.diagnostics[-1] if self.diagnostics else None,
            "result_latency": percentiles(latency),
        }
        self.report["parallel_service"] = {
            "threads": self.args.service_threads,
            "valid_calls": len(stats["valid_ms"]), "valid_succeeded": stats["valid_success"],
            "valid_latency": percentiles(stats["valid_ms"]),
            "malformed_calls": len(stats["malformed_ms"]), "malformed_refused": stats["malformed_refused"],
            "malformed_latency": percentiles(stats["malformed_ms"]),
            "service_errors": stats["service_errors"],
        }
        self.report["agreement"] = agreement(self.outcomes)

    def final_check(self):
        self.report["load_average_end"] = os.getloadavg()[0]
        proxy = self.rospy.ServiceProxy(NODE + "/register", self.Register)
        try:
            result, ms = self.call(proxy, self.xyz_cloud(self.source_points, "final"), self.target)
            self.report["final_registration"] = {"success": result.success, "message": result.message, "ms": ms}
        except self.rospy.ServiceException as e:
            self.report["final_registration"] = {"success": False, "message": str(e)}
        self.check_alive("final")


def outcome(result):
    """What two registrations of the same pair must share: the inliers and the transform, bit for bit."""
    t, q = result.transform.translation, result.transform.rotation
    return (result.inliers, t.x, t.y, t.z, q.x, q.y, q.z, q.w)


def agreement(outcomes):
    """How many successful registrations of the real pair differ from the most common result."""
    everything = outcomes["stream"] + outcomes["service"]
    if not everything:
        return {"successes": 0}
    common, count = Counter(everything).most_common(1)[0]
    return {"successes": len(everything), "most_common_inliers": common[0], "agreeing": count,
            "differing_stream": sum(o != common for o in outcomes["stream"]),
            "differing_service": sum(o != common for o in outcomes["service"]),
            "inliers_seen": sorted(set(o[0] for o in everything))}


def describe(latency):
    if latency.get("n", 0) == 0:
        return "none"
    return "p50 %.0f ms, p90 %.0f ms, max %.0f ms (n = %d)" % (
        latency["p50_ms"], latency["p90_ms"], latency["max_ms"], latency["n"])


def print_report(r):
    c, s, p = r["corpus"], r["stream"], r["parallel_service"]
    print("stress_registration: %s (%d cpus, 1-min load average %.1f at the start, %.1f at the end)"
          % (r["command"], r["cpus"], r["load_average_start"], r["load_average_end"]))
    print("crashes: %s" % (", ".join("%s (manager exit code %s)" % (x["phase"], x["manager_exit_code"])
                                     for x in r["crashes"]) or "none"))
    print("corpus: %d cases, %d ~register calls, %d refused with their reason, %d service errors; latency %s"
          % (c["cases"], c["service_calls"], c["refused_with_reason"], c["service_errors"],
             describe(c["service_latency"])))
    print("corpus on `source`: %d published, %d results, %d refused with their reason" % (
        c["topic_inputs"], c["topic_results"], c["topic_refused"]))
    print("stream: %d scans at %.0f Hz for %.0f s; %d results (%d succeeded), %d without a result: %s dropped "
          "per /diagnostics, %s uncounted; stamp-to-result latency %s"
          % (s["published"], s["rate_hz"], s["duration_s"], s["results"], s["succeeded"], s["no_result"],
             s["dropped_per_diagnostics"], s["lost_uncounted"], describe(s["result_latency"])))
    print("parallel ~register (%d threads): %d valid calls, %d succeeded, latency %s" % (
        p["threads"], p["valid_calls"], p["valid_succeeded"], describe(p["valid_latency"])))
    print("parallel ~register malformed: %d calls, %d refused with their reason, latency %s; %d service errors"
          % (p["malformed_calls"], p["malformed_refused"], describe(p["malformed_latency"]), p["service_errors"]))
    a = r["agreement"]
    if a["successes"]:
        print("same pair, same answer? %d successes: %d give the most common result (%d inliers), %d differ "
              "(%d on the stream, %d ~register); inliers seen: %s"
              % (a["successes"], a["agreeing"], a["most_common_inliers"],
                 a["differing_stream"] + a["differing_service"], a["differing_stream"], a["differing_service"],
                 ", ".join(str(i) for i in a["inliers_seen"])))
    f = r["final_registration"]
    print("final registration: %s%s" % ("success" if f["success"] else "FAILED: " + f["message"],
                                       " (%.0f ms)" % f["ms"] if "ms" in f else ""))
    for u in r["unexpected"][:10]:
        print("unexpected: %s / %s: %s" % (u["phase"], u["case"], u["message"]))
    if len(r["unexpected"]) > 10:
        print("unexpected: ... %d more" % (len(r["unexpected"]) - 10))


def main():
    args = parse_arguments()
    processes = Processes(args.port, args.preset, name="stress_registration",
                          params=overrides(args.set, "stress_registration"))
    try:
        processes.bring_up()
        import rospy

        rospy.init_node("stress_registration", disable_signals=True)
        rospy.wait_for_service(NODE + "/register", timeout=60)
        run = Run(args, processes)
        run.replay_corpus()
        run.stream()
        run.final_check()
    finally:
        processes.stop()
    print_report(run.report)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(run.report, f, indent=2)
    report = run.report
    healthy = not report["crashes"] and not report["unexpected"] and report["final_registration"]["success"]
    return 0 if healthy else 1


if __name__ == "__main__":
    sys.exit(main())
