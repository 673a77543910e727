#!/usr/bin/env python3
"""Prints each demo registration with its error against the ground truth on <pair>/ground_truth, and the
relocalization of the campus query in the campus map with its error against the query's pose."""
import math
import os

import rospy
from geometry_msgs.msg import Transform, TransformStamped
from mac_registration.msg import RegistrationResult, RelocalizationAnswer

# (rotation [deg], translation [m]) bounds of the benchmark criterion of each preset.
CRITERIA = {"indoor": (15.0, 0.30), "outdoor": (5.0, 0.60)}
# What the <pair>/ground_truth topic holds: the 3DMatch ground truth indoors; outdoors no ground truth
# exists, only another registration's estimate (fast_gicp's), so the demo says so.
TRUTH_KIND = {"indoor": "ground truth", "outdoor": "reference (fast_gicp's estimate)"}
# The relocalization benchmark's criterion (BENCHMARKS.md, "Finding a scan in a map").
RELOCALIZATION_CRITERION = (5.0, 1.0)



def status_name(status):
    """The name of a RegistrationResult.status constant, e.g. "success" or "too few inliers"."""
    for name in dir(RegistrationResult):
        if name.isupper() and getattr(RegistrationResult, name) == status:
            return name.lower().replace("_", " ")
    return "status %d" % status

def quaternion_to_matrix(q):
    x, y, z, w = q.x, q.y, q.z, q.w
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def errors(estimate, truth):
    """Rotation error [deg] (angle of R_truth^T R) and translation error [m]."""
    ra, rb = quaternion_to_matrix(estimate.rotation), quaternion_to_matrix(truth.rotation)
    trace = sum(rb[k][i] * ra[k][i] for i in range(3) for k in range(3))
    angle = math.degrees(math.acos(max(-1.0, min(1.0, (trace - 1.0) / 2.0))))
    ta, tb = estimate.translation, truth.translation
    return angle, math.sqrt((ta.x - tb.x) ** 2 + (ta.y - tb.y) ** 2 + (ta.z - tb.z) ** 2)


def pose_to_transform(pose):
    """A geometry_msgs/Pose as the Transform the helpers above take."""
    t = Transform()
    t.translation.x, t.translation.y, t.translation.z = pose.position.x, pose.position.y, pose.position.z
    t.rotation = pose.orientation
    return t


def matrix_text(t):
    r = quaternion_to_matrix(t.rotation)
    rows = [r[i] + [(t.translation.x, t.translation.y, t.translation.z)[i]] for i in range(3)] + [[0, 0, 0, 1]]
    return "\n".join("    " + " ".join("%10.4f" % v for v in row) for row in rows)


class Monitor:
    def __init__(self):
        self.expected = rospy.get_param("~expected_results", 6)
        self.exit_when_done = rospy.get_param("~exit_when_done", True)
        # Where the summary goes when every registration is reported (scripts/demo.sh prints it last, after
        # roslaunch has shut down); the monitor then exits whatever exit_when_done says.
        self.summary_file = rospy.get_param("~summary_file", "")
        self.summary = []
        self.truth = {}
        self.reported = 0
        self.within = 0
        self.subscribers = []
        for pair in CRITERIA:
            self.subscribers.append(rospy.Subscriber(
                "/%s/ground_truth" % pair, TransformStamped, self.on_truth, callback_args=pair, queue_size=10))
            self.subscribers.append(rospy.Subscriber(
                "/%s/mac_registration/result" % pair, RegistrationResult, self.on_result, callback_args=pair,
                queue_size=10))
        self.subscribers.append(rospy.Subscriber(
            "/relocalization/ground_truth", TransformStamped, self.on_truth, callback_args="relocalization",
            queue_size=10))
        self.subscribers.append(rospy.Subscriber(
            "/relocalization/mac_relocalization/result", RelocalizationAnswer, self.on_relocalization,
            queue_size=10))

    def on_truth(self, msg, pair):
        self.truth[(pair, msg.header.stamp)] = msg.transform

    def on_result(self, msg, pair):
        # The ground truth is published at the same stamp, before the clouds are registered.
        truth = self.truth.get((pair, msg.header.stamp))
        lines = ["[%s] %s <- %s at t=%.1f s: %s" % (pair, msg.header.frame_id, msg.child_frame_id,
                                                    msg.header.stamp.to_sec(), status_name(msg.status))]
        if msg.success:
            lines.append("  T_target_source:\n" + matrix_text(msg.transform))
            if truth is not None:
                re, te = errors(msg.transform, truth)
                max_re, max_te = CRITERIA[pair]
                ok = re <= max_re and te <= max_te
                self.within += ok
                lines.append("  error against %s: rotation %.2f deg, translation %.1f cm -> %s (RE <= %g deg, "
                             "TE <= %g cm)" % (TRUTH_KIND[pair], re, te * 100, "within the criterion" if ok
                                               else "OUTSIDE the criterion", max_re, max_te * 100))
            lines.append("  %d inliers of %d correspondences, confidence %.2f; time %.0f ms (front end %.0f ms, "
                         "MAC %.0f ms)" % (msg.inliers, msg.correspondences, msg.confidence, msg.time_total_ms,
                                           msg.time_front_end_ms, msg.time_total_ms - msg.time_front_end_ms))
        else:
            lines.append("  " + msg.message)
        rospy.loginfo("\n".join(lines))
        self.summary.append(lines[0] + ("" if msg.success else " (%s)" % msg.message))
        self.count_report()

    def on_relocalization(self, msg):
        # The query's pose is the same at every replay: any of its ground-truth messages will do.
        truth = next((t for (pair, _), t in self.truth.items() if pair == "relocalization"), None)
        lines = ["[relocalization] %s in %s (%s): %s" % (msg.query, msg.pose.header.frame_id or "the map",
                                                          msg.trigger, msg.outcome)]
        if msg.success:
            estimate = pose_to_transform(msg.pose.pose.pose)
            lines.append("  T_map_query:\n" + matrix_text(estimate))
            if truth is not None:
                re, te = errors(estimate, truth)
                max_re, max_te = RELOCALIZATION_CRITERION
                ok = re <= max_re and te <= max_te
                self.within += ok
                lines.append("  error against the query's pose: rotation %.2f deg, translation %.2f m -> %s "
                             "(RE <= %g deg, TE <= %g m)" % (re, te, "within the criterion" if ok
                                                             else "OUTSIDE the criterion", max_re, max_te))
            lines.append("  confidence %.2f, %d places ranked; time %.0f ms" % (msg.confidence, len(msg.candidates),
                                                                              msg.time_ms))
        else:
            lines.append("  " + msg.message)
        rospy.loginfo("\n".join(lines))
        self.summary.append(lines[0] + ("" if msg.success else " (%s)" % msg.message))
        self.count_report()

    def count_report(self):
        self.reported += 1
        if self.reported >= self.expected:
            done = "demo: %d results, %d within the benchmark criterion" % (self.reported, self.within)
            rospy.loginfo(done)
            if self.summary_file:
                with open(self.summary_file + ".part", "w") as f:
                    f.write("\n".join(self.summary + [done]) + "\n")
                os.replace(self.summary_file + ".part", self.summary_file)  # whole or not at all
            if self.exit_when_done or self.summary_file:
                rospy.signal_shutdown("demo finished")


if __name__ == "__main__":
    rospy.init_node("demo_monitor")
    Monitor()
    rospy.spin()
