#!/usr/bin/env python3
"""The malformed-cloud corpus against a real nodelet manager (test/ros/malformed_clouds.test): every bad
cloud on `source`, on `target` and through ~register gets a failed result with its reason, and afterwards
the manager is still up, still lists the nodelet and still registers a real scan pair."""
import math
import os
import sys
import threading
import time
import unittest

import rospy
import rostest
from mac_registration.msg import RegistrationResult
from mac_registration.srv import Register, RegisterCorrespondences
from nodelet.srv import NodeletList
from sensor_msgs.msg import PointCloud2

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from malformed_clouds import CORPUS, has_points, read_pcd_xyz, xyz_cloud  # noqa: E402

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data", "redkitchen_4_0")
NODE = "/mac_registration"
MANAGER = "/mac_registration_manager"


def real_cloud(name, frame, big_endian=False):
    msg = xyz_cloud(read_pcd_xyz(os.path.join(DATA, name)), frame, big_endian=big_endian)
    msg.header.stamp = rospy.Time.now()
    return msg


def read_transform(path):
    with open(path) as f:
        return [[float(v) for v in line.split()] for line in f if line.strip()]


def rotation_and_translation_error(transform_msg, truth):
    """Rotation error [deg] and translation error [m] of a geometry_msgs/Transform against a 4x4 matrix."""
    q, t = transform_msg.rotation, transform_msg.translation
    w, x, y, z = q.w, q.x, q.y, q.z
    r = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    trace = sum(r[i][j] * truth[i][j] for i in range(3) for j in range(3))  # trace(R^T R_truth)
    angle = math.degrees(math.acos(max(-1.0, min(1.0, (trace - 1) / 2))))
    te = math.sqrt(sum((v - truth[i][3]) ** 2 for i, v in enumerate((t.x, t.y, t.z))))
    return angle, te


class MalformedCloudsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.wait_for_service(NODE + "/register", timeout=60)
        cls.register = rospy.ServiceProxy(NODE + "/register", Register)
        cls.source = real_cloud("source_cloud_bin_4.pcd", "fragment_4")
        cls.target = real_cloud("target_cloud_bin_0.pcd", "fragment_0")
        cls.truth = read_transform(os.path.join(DATA, "T_target_source_gt.txt"))
        cls.lock = threading.Lock()
        cls.results = {}  # child_frame_id -> the latest RegistrationResult
        cls.result_sub = rospy.Subscriber(NODE + "/result", RegistrationResult, cls.on_result)
        cls.source_pub = rospy.Publisher("/source", PointCloud2, queue_size=1)
        cls.target_pub = rospy.Publisher("/target", PointCloud2, queue_size=1, latch=True)
        deadline = time.time() + 20
        while time.time() < deadline and (
            cls.source_pub.get_num_connections() == 0 or cls.target_pub.get_num_connections() == 0
        ):
            time.sleep(0.05)

    @classmethod
    def on_result(cls, msg):
        with cls.lock:
            cls.results[msg.child_frame_id] = msg

    def expect_refused(self, result, reason, case):
        self.assertFalse(result.success, "%s: accepted (%s)" % (case, result.message))
        self.assertEqual(result.status, RegistrationResult.INVALID_INPUT, "%s: %s" % (case, result.message))
        self.assertIn(reason, result.message, case)

    def wait_for_result(self, frame, timeout=10.0):
        deadline = time.time() + timeout
        while time.time() < deadline:
            with self.lock:
                if frame in self.results:
                    return self.results.pop(frame)
            time.sleep(0.02)
        return None

    def expect_alive_and_registering(self):
        rospy.wait_for_service(MANAGER + "/list", timeout=10)
        loaded = rospy.ServiceProxy(MANAGER + "/list", NodeletList)().nodelets
        self.assertIn(NODE, loaded)
        result = self.register(source=self.source, target=self.target).result
        self.assertTrue(result.success, result.message)
        re, te = rotation_and_translation_error(result.transform, self.truth)
        self.assertLessEqual(re, 15.0)  # the 3DMatch criterion
        self.assertLessEqual(te, 0.30)

    def test_1_register_service_refuses_each_bad_source_and_target(self):
        for i, (case, build, reason) in enumerate(CORPUS):
            frame = "service_source_%d" % i
            result = self.register(source=build(frame), target=self.target).result
            self.expect_refused(result, reason, "source " + case)
            self.assertIn("source cloud", result.message, case)
            self.assertEqual(result.child_frame_id, frame, case)
            bad_target = build("service_target_%d" % i)
            if has_points(bad_target):
                result = self.register(source=self.source, target=bad_target).result
                self.expect_refused(result, reason, "target " + case)
                self.assertIn("target cloud", result.message, case)
        self.expect_alive_and_registering()

    def hold_target(self, target):
        """Publishes `target` and waits until the node registers against it (the two topics race)."""
        self.target_pub.publish(target)
        probe = xyz_cloud([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)], "")
        for attempt in range(30):
            probe.header.frame_id = "hold_%d" % attempt
            self.source_pub.publish(probe)
            result = self.wait_for_result(probe.header.frame_id, timeout=2.0)
            if result is not None and result.header.frame_id == target.header.frame_id:
                return
            time.sleep(0.1)
        self.fail("the node never took the target on /target")

    def test_2_source_topic_publishes_a_failed_result_for_each_bad_cloud(self):
        self.hold_target(self.target)
        for i, (case, build, reason) in enumerate(CORPUS):
            frame = "topic_source_%d" % i
            # One at a time: the node keeps only the newest input while it works.
            self.source_pub.publish(build(frame))
            result = self.wait_for_result(frame)
            self.assertIsNotNone(result, "%s: no result on %s/result" % (case, NODE))
            self.expect_refused(result, reason, "source topic " + case)
        self.expect_alive_and_registering()

    def test_3_target_topic_failures_name_the_target(self):
        probe = xyz_cloud([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)], "probe")
        for i, (case, build, reason) in enumerate(CORPUS):
            bad = build("topic_target_%d" % i)
            if not has_points(bad):
                continue
            self.target_pub.publish(bad)
            # The target and the probing source travel on two topics: probe until the bad target is the
            # one the node holds (the source's reason would come first, so a valid 3-point probe is used).
            result = None
            for attempt in range(20):
                frame = "probe_%d_%d" % (i, attempt)
                probe.header.frame_id = frame
                self.source_pub.publish(probe)
                result = self.wait_for_result(frame)
                self.assertIsNotNone(result, "%s: no result for the probe" % case)
                if reason in result.message:
                    break
                time.sleep(0.1)
            self.expect_refused(result, reason, "target topic " + case)
            self.assertIn("target cloud", result.message, case)
        self.hold_target(self.target)
        self.expect_alive_and_registering()

    def test_4_a_big_endian_scan_is_read_in_its_byte_order(self):
        source = real_cloud("source_cloud_bin_4.pcd", "fragment_4_big_endian", big_endian=True)
        result = self.register(source=source, target=self.target).result
        self.assertTrue(result.success, result.message)
        self.assertEqual(result.source_points, self.source.width)
        re, te = rotation_and_translation_error(result.transform, self.truth)
        self.assertLessEqual(re, 15.0)
        self.assertLessEqual(te, 0.30)


if __name__ == "__main__":
    rospy.init_node("test_malformed_clouds")
    rostest.rosrun("mac_registration", "malformed_clouds", MalformedCloudsTest)
