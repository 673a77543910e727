#!/usr/bin/env python3
"""The loop-closure bridge with a real registration node: a drive passes a place, goes elsewhere and comes
back; the loop is reported on the stack's topic with both stamps and as a verified relative pose, found in
the submap of the nearest earlier keyframe."""
import os
import sys
import threading
import time
import unittest

import numpy as np
import open3d as o3d
import rospy
import rostest
from mac_registration.msg import RegistrationResult
from geometry_msgs.msg import Quaternion, Transform
from nav_msgs.msg import Odometry
from sensor_msgs import point_cloud2
from std_msgs.msg import Float64MultiArray, Header

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from demo_monitor import errors  # noqa: E402
from loop_closure_bridge import candidates, Keyframe, NewestOnly, submap  # noqa: E402

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data")


def points(name):
    return np.asarray(o3d.io.read_point_cloud(os.path.join(DATA, name)).points)


def transform_file(name):
    return np.loadtxt(os.path.join(DATA, name))


def yaw_pose(x, y, yaw):
    m = np.eye(4)
    m[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    m[:2, 3] = [x, y]
    return m


def quaternion(m):
    """The rotation of a 4x4 (turned by less than 180 degrees) as a geometry_msgs/Quaternion."""
    w = np.sqrt(max(0.0, 1.0 + np.trace(m[:3, :3]))) / 2.0
    return Quaternion(x=(m[2, 1] - m[1, 2]) / (4 * w), y=(m[0, 2] - m[2, 0]) / (4 * w),
                      z=(m[1, 0] - m[0, 1]) / (4 * w), w=w)


def odometry_msg(stamp, pose):
    msg = Odometry()
    msg.header = Header(stamp=stamp, frame_id="odom")
    msg.pose.pose.orientation = quaternion(pose)
    p = msg.pose.pose.position
    p.x, p.y, p.z = pose[:3, 3]
    return msg


class LoopClosureTest(unittest.TestCase):
    def test_candidates_are_near_old_enough_and_nearest_first(self):
        t = rospy.Time
        kf = [Keyframe(t(0), yaw_pose(0, 0, 0), None), Keyframe(t(10), yaw_pose(5, 0, 0), None),
              Keyframe(t(20), yaw_pose(40, 0, 0), None), Keyframe(t(98), yaw_pose(1, 0, 0), None)]
        current = Keyframe(t(100), yaw_pose(4, 0, 0), None)
        chosen = candidates(kf, current, 15.0, 30.0, 3)
        self.assertEqual([k.stamp.to_sec() for k in chosen], [10.0, 0.0])

    def test_a_submap_joins_the_old_enough_neighbours_in_the_candidates_frame(self):
        t = rospy.Time
        one = np.array([[1.1, 0.1, 0.1], [1.15, 0.05, 0.15]])  # two points in one 0.2 m cell
        kf = [Keyframe(t(10 * i), yaw_pose(2.0 * i, 0, np.pi / 2), one, i) for i in range(6)]
        current = Keyframe(t(100), yaw_pose(4, 0, 0), None, 6)
        # Keyframes 1-3 around keyframe 2; 3 is too young with a gap of 75 s; each gives one point, at its
        # origin's offset from keyframe 2 along keyframe 2's y axis (the drive's x turned by 90 degrees).
        joined = submap(kf, 2, current, 1, 75.0, 0.2)
        np.testing.assert_allclose(joined, [[1.1, 2.1, 0.1], [1.1, 0.1, 0.1]], atol=1e-9)
        self.assertIsNone(submap(kf, 5, current, 1, 75.0, 0.2))  # its one neighbour too young, itself too

    def test_a_newer_keyframe_replaces_one_still_waiting(self):
        slot = NewestOnly()
        self.assertIsNone(slot.put("first"))
        self.assertEqual(slot.put("second"), "first")
        self.assertEqual(slot.replaced, 1)
        self.assertEqual(slot.take(0.01), "second")
        self.assertIsNone(slot.take(0.01))

    def test_a_revisit_is_reported_as_a_loop(self):
        lock = threading.Lock()
        detections, loops = [], []
        rospy.Subscriber("/stack/loop_closure_detection", Float64MultiArray,
                         lambda m: (lock.acquire(), detections.append(m), lock.release()))
        rospy.Subscriber("/loop_closure_bridge/loop", RegistrationResult,
                         lambda m: (lock.acquire(), loops.append(m), lock.release()))
        cloud_pub = rospy.Publisher("/stack/cloud_registered", point_cloud2.PointCloud2, queue_size=10)
        odom_pub = rospy.Publisher("/stack/odometry", Odometry, queue_size=10)
        time.sleep(2.0)  # the bridge (waiting for the node's service) subscribes

        # The shipped outdoor pair: the target scan first, the source scan on the way back. The source's
        # odometry pose follows the pair's reference, so the scans agree in the odometry frame. The keyframe
        # kept just after the target scan, nearest to where the source comes back, holds only clutter: the
        # one candidate asked (max_candidates 1) fails alone and is closed against its submap, which joins
        # the target scan.
        target, source = points("lidar/lidar_target_251370668.pcd"), points("lidar/lidar_source_251371071.pcd")
        reference = transform_file("lidar/lidar_T_target_source_reference.txt")
        first = yaw_pose(10.0, -4.0, 0.3)
        back = first @ reference
        beside = back @ yaw_pose(0.1, 0.0, 0.0)
        drive = [(first, target), (beside, None)]
        drive += [(yaw_pose(10.0 + 30.0 * k, 200.0, 0.0), None) for k in range(1, 4)]
        drive.append((back, source))
        stamps = []
        for pose, scan in drive:
            stamp = rospy.Time.now()
            stamps.append(stamp)
            local = scan if scan is not None else np.random.default_rng(len(stamps)).uniform(-20, 20, (500, 3))
            world = local @ pose[:3, :3].T + pose[:3, 3]
            cloud_pub.publish(point_cloud2.create_cloud_xyz32(Header(stamp=stamp, frame_id="odom"), world.tolist()))
            odom_pub.publish(odometry_msg(stamp, pose))
            time.sleep(1.5)

        deadline = time.time() + 60
        while time.time() < deadline:
            with lock:
                if detections and loops:
                    break
            time.sleep(0.1)
        with lock:
            self.assertEqual(len(detections), 1, "loops reported: %s" % [list(d.data) for d in detections])
            self.assertAlmostEqual(detections[0].data[0], stamps[-1].to_sec(), places=6)
            self.assertAlmostEqual(detections[0].data[1], stamps[1].to_sec(), places=6)
            loop = loops[0]
            self.assertTrue(loop.success, loop.message)
            old_new = np.linalg.inv(beside) @ back  # the pose is of the source in the candidate's frame
            truth = Transform(rotation=quaternion(old_new))
            truth.translation.x, truth.translation.y, truth.translation.z = old_new[:3, 3]
            re, te = errors(loop.transform, truth)
            self.assertLessEqual(re, 5.0)
            self.assertLessEqual(te, 0.6)
            self.assertTrue(np.isfinite(loop.covariance[0]) and loop.covariance[0] > 0.0)


if __name__ == "__main__":
    rospy.init_node("test_loop_closure")
    rostest.rosrun("mac_registration", "loop_closure", LoopClosureTest)
