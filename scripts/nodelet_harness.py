"""What the node's measurement scripts share: a roscore of their own, a nodelet manager with the
registration nodelet, and percentiles. Imported by stress_registration.py and measure_stream.py."""
import os
import signal
import subprocess
import sys
import time

PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NODE = "/mac_registration"
MANAGER = "mac_registration_manager"


class Processes:
    """roscore, the nodelet manager and the nodelet loader, started and stopped by this run only.

    `params` are set on the node's private namespace after the preset and the node's configuration are
    loaded (a name relative to it, e.g. "features/voxel_size", and a value); `remaps` rename its topics
    (e.g. {"source": "/scans"})."""

    def __init__(self, port, preset, name="measurement", params=None, remaps=None):
        self.env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % port, ROS_HOSTNAME="localhost")
        self.started = []
        self.port = port
        self.preset = preset
        self.name = name
        self.params = params or {}
        self.remaps = remaps or {}

    def start(self, *command):
        process = subprocess.Popen(command, env=self.env, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
        self.started.append(process)
        return process

    def bring_up(self):
        import rosgraph

        os.environ.update(self.env)
        master = rosgraph.Master("/" + self.name)
        if master.is_online():
            sys.exit("%s: a ROS master already runs on port %d; pick another --port" % (self.name, self.port))
        self.core = self.start("roscore", "-p", str(self.port))
        for _ in range(300):
            if master.is_online():
                break
            time.sleep(0.1)
        else:
            sys.exit("%s: roscore did not start on port %d" % (self.name, self.port))
        for config in (self.preset, os.path.join(PACKAGE, "config", "registration_node.yaml")):
            subprocess.run(["rosparam", "load", config, NODE], env=self.env, check=True)
        for key, value in self.params.items():
            master.setParam(NODE + "/" + key, value)
        self.manager = self.start("rosrun", "nodelet", "nodelet", "manager", "__name:=" + MANAGER)
        self.loader = self.start("rosrun", "nodelet", "nodelet", "load", "mac_registration/RegistrationNodelet",
                                 MANAGER, "--no-bond", "__name:=" + NODE.strip("/"),
                                 *["%s:=%s" % kv for kv in self.remaps.items()])

    def manager_status(self):
        """None while the manager runs, else its exit code (negative: killed by that signal)."""
        return self.manager.poll()

    def stop(self):
        for process in reversed(self.started):
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()


def overrides(assignments, script):
    """The node's private parameters from NAME=VALUE assignments (--set): a name relative to the node, dots
    or slashes (features.voxel_size, features/voxel_size), a YAML value."""
    import yaml

    params = {}
    for assignment in assignments:
        name, sep, text = assignment.partition("=")
        if not sep or not name:
            sys.exit("%s: --set wants NAME=VALUE, got %r" % (script, assignment))
        params[name.strip().replace(".", "/")] = yaml.safe_load(text)
    return params


def percentiles(values, quantiles=(0.5, 0.9)):
    """{"n", "p50_ms", "p90_ms", ..., "max_ms"} of values in milliseconds (nearest rank)."""
    if not values:
        return {"n": 0}
    ordered = sorted(values)
    summary = {"n": len(ordered)}
    for q in quantiles:
        summary["p%d_ms" % round(100 * q)] = ordered[min(len(ordered) - 1, int(q * len(ordered)))]
    summary["max_ms"] = ordered[-1]
    return summary
