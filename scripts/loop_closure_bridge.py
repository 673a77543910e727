#!/usr/bin/env python3
"""Loop closures for a SLAM stack, checked by the registration node's ~register_candidates.

Keeps a keyframe each ~keyframe_distance metres of the stack's odometry (its scan, taken into the sensor's
frame), and for each new one asks the registration node about the earlier keyframes within ~search_radius
of it and older than ~min_time_gap (nearest first, ~max_candidates of them, the new scan described once).
Each candidate is asked twice: its keyframe alone, and its submap (the keyframes within ~submap_keyframes of
it in the order they were kept, none younger than ~min_time_gap, joined in its frame by the odometry and
thinned to one point per ~submap_voxel), as LIO-SAM closes a loop: a single sparse keyframe shares little
with one 10-30 m away, its neighbourhood more. The checks run on a thread of their own, one at a time: a
keyframe still waiting when a newer one has candidates is not checked (logged). A verified candidate is a
loop closure:
  - `loop_closure_detection` (std_msgs/Float64MultiArray [stamp of the new keyframe, stamp of the old one]),
    the shape of LIO-SAM's external loop input (remap it to lio_loop/loop_closure_detection): the stack
    then closes the loop between the two keyframes itself;
  - `~loop` (mac_registration/RegistrationResult): the relative pose T_old_new of the two sensor frames with
    its covariance (the fine alignment's), for a back end that adds the factor itself.

Inputs: `cloud` (sensor_msgs/PointCloud2, the scan in the odometry's frame, as LIO-SAM's
lio_sam/mapping/cloud_registered) and `odometry` (nav_msgs/Odometry, the sensor's pose in that frame,
lio_sam/mapping/odometry), paired by stamp.
"""
import math
import threading

import message_filters
import numpy as np
import rospy
from mac_registration.msg import RegistrationResult
from mac_registration.srv import RegisterCandidates, RegisterCandidatesRequest
from nav_msgs.msg import Odometry
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Float64MultiArray, Header


def pose_matrix(pose):
    """4x4 of a geometry_msgs/Pose."""
    q, p = pose.orientation, pose.position
    x, y, z, w = q.x, q.y, q.z, q.w
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = [p.x, p.y, p.z]
    return m


class Keyframe:
    def __init__(self, stamp, pose, points, index=0):
        self.stamp = stamp  # rospy.Time
        self.pose = pose  # 4x4, the sensor in the odometry frame
        self.points = points  # N x 3, in the sensor's frame
        self.index = index  # its place in the order keyframes were kept


def in_sensor_frame(cloud, pose):
    """The points of `cloud` (odometry frame) in the sensor frame at `pose`, N x 3."""
    points = np.array(list(point_cloud2.read_points(cloud, ("x", "y", "z"), skip_nans=True)), dtype=np.float64)
    if points.size == 0:
        points = np.zeros((0, 3))
    inverse = np.linalg.inv(pose)
    return points @ inverse[:3, :3].T + inverse[:3, 3]


def submap(keyframes, centre, current, submap_keyframes, min_time_gap, voxel):
    """The keyframes within `submap_keyframes` of keyframes[centre] (old enough for a loop with `current`)
    joined in its sensor frame, one point per `voxel` [m] cell; None where no neighbour joins it."""
    centre_keyframe = keyframes[centre]
    to_centre = np.linalg.inv(centre_keyframe.pose)
    parts = []
    for k in keyframes[max(0, centre - submap_keyframes):centre + submap_keyframes + 1]:
        if (current.stamp - k.stamp).to_sec() < min_time_gap:
            continue
        relative = to_centre @ k.pose
        parts.append(k.points @ relative[:3, :3].T + relative[:3, 3])
    if len(parts) < 2:
        return None
    points = np.concatenate(parts)
    _, first = np.unique(np.floor(points / voxel).astype(np.int64), axis=0, return_index=True)
    return points[np.sort(first)]


def far_enough(keyframes, pose, keyframe_distance):
    """Whether a scan at `pose` is a new keyframe: the first, or `keyframe_distance` [m] from the last one."""
    return not keyframes or np.linalg.norm(pose[:3, 3] - keyframes[-1].pose[:3, 3]) >= keyframe_distance


def candidates(keyframes, current, search_radius, min_time_gap, max_candidates):
    """The earlier keyframes a loop may close with: within the radius, old enough, nearest first."""
    near = []
    for k in keyframes:
        if (current.stamp - k.stamp).to_sec() < min_time_gap:
            continue
        distance = float(np.linalg.norm(k.pose[:3, 3] - current.pose[:3, 3]))
        if distance <= search_radius:
            near.append((distance, k))
    near.sort(key=lambda pair: pair[0])
    return [k for _, k in near[:max_candidates]]


class NewestOnly:
    """A slot for one waiting item: a newer one replaces it (counted) rather than queueing behind it."""

    def __init__(self):
        self.item = None
        self.replaced = 0
        self.changed = threading.Condition()

    def put(self, item):
        """Leaves `item` waiting; returns the one it replaced, or None."""
        with self.changed:
            older, self.item = self.item, item
            if older is not None:
                self.replaced += 1
            self.changed.notify()
            return older

    def take(self, timeout):
        """The waiting item, or None after `timeout` [s] without one."""
        with self.changed:
            if self.item is None:
                self.changed.wait(timeout)
            item, self.item = self.item, None
            return item


class LoopClosureBridge:
    def __init__(self):
        self.keyframe_distance = rospy.get_param("~keyframe_distance", 1.0)  # [m]
        self.search_radius = rospy.get_param("~search_radius", 15.0)  # [m]
        self.min_time_gap = rospy.get_param("~min_time_gap", 30.0)  # [s]
        self.max_candidates = rospy.get_param("~max_candidates", 3)
        self.submap_keyframes = rospy.get_param("~submap_keyframes", 25)  # each side; 0: keyframes alone
        self.submap_voxel = rospy.get_param("~submap_voxel", 0.2)  # [m]
        self.sensor_frame = rospy.get_param("~sensor_frame", "keyframe")
        service = rospy.get_param("~service", "mac_registration/register_candidates")
        for name, value in (("keyframe_distance", self.keyframe_distance), ("search_radius", self.search_radius),
                            ("min_time_gap", self.min_time_gap), ("max_candidates", self.max_candidates),
                            ("submap_voxel", self.submap_voxel)):
            if not value > 0:
                raise ValueError("~%s must be > 0, got %r" % (name, value))
        if not (isinstance(self.submap_keyframes, int) and self.submap_keyframes >= 0):
            raise ValueError("~submap_keyframes must be an integer >= 0, got %r" % (self.submap_keyframes,))
        rospy.loginfo("loop_closure_bridge: waiting for %s", rospy.resolve_name(service))
        rospy.wait_for_service(service)
        self.register = rospy.ServiceProxy(service, RegisterCandidates)
        self.keyframes = []
        self.lock = threading.Lock()
        # The newest keyframe with candidates, for the worker: a check takes up to a second with submaps.
        self.pending = NewestOnly()
        self.detection_pub = rospy.Publisher("loop_closure_detection", Float64MultiArray, queue_size=10)
        self.loop_pub = rospy.Publisher("~loop", RegistrationResult, queue_size=10)
        cloud = message_filters.Subscriber("cloud", PointCloud2)
        odometry = message_filters.Subscriber("odometry", Odometry)
        self.sync = message_filters.ApproximateTimeSynchronizer([cloud, odometry], 10, 0.05)
        self.sync.registerCallback(self.on_scan)
        threading.Thread(target=self.work, daemon=True).start()

    def on_scan(self, cloud, odometry):
        pose = pose_matrix(odometry.pose.pose)
        with self.lock:
            if not far_enough(self.keyframes, pose, self.keyframe_distance):
                return
            current = Keyframe(cloud.header.stamp, pose, in_sensor_frame(cloud, pose), len(self.keyframes))
            earlier = candidates(self.keyframes, current, self.search_radius, self.min_time_gap,
                                 self.max_candidates)
            self.keyframes.append(current)
        if earlier:
            older = self.pending.put((current, earlier))
            if older is not None:
                rospy.loginfo("loop_closure_bridge: keyframe t=%.2f s not checked, a newer one replaced it while a "
                              "check ran (%d so far)", older[0].stamp.to_sec(), self.pending.replaced)

    def work(self):
        while not rospy.is_shutdown():
            waiting = self.pending.take(0.5)
            if waiting is None:
                continue
            current, earlier = waiting
            with self.lock:
                keyframes = list(self.keyframes)
            self.check(current, self.targets(keyframes, current, earlier))

    def targets(self, keyframes, current, earlier):
        """(keyframe, what, points) for each cloud to ask about: each candidate alone, then its submap."""
        asked = []
        for k in earlier:
            asked.append((k, "keyframe", k.points))
            if self.submap_keyframes > 0:
                joined = submap(keyframes, k.index, current, self.submap_keyframes, self.min_time_gap,
                                self.submap_voxel)
                if joined is not None:
                    asked.append((k, "submap", joined))
        return asked

    def cloud(self, stamp, points):
        return point_cloud2.create_cloud_xyz32(Header(stamp=stamp, frame_id=self.sensor_frame), points.tolist())

    def check(self, current, asked):
        request = RegisterCandidatesRequest(source=self.cloud(current.stamp, current.points),
                                            targets=[self.cloud(k.stamp, p) for k, _, p in asked])
        try:
            response = self.register(request)
        except rospy.ServiceException as e:
            rospy.logwarn("loop_closure_bridge: %s", e)
            return
        if not response.results or not response.results[0].success:
            reason = response.results[0].message if response.results else response.message
            rospy.loginfo("loop_closure_bridge: t=%.2f s, %d candidate clouds, none verified: %s",
                          current.stamp.to_sec(), len(asked), reason)
            return
        best = response.results[0]
        old, what, _ = asked[response.candidates[0]]
        self.detection_pub.publish(Float64MultiArray(data=[current.stamp.to_sec(), old.stamp.to_sec()]))
        self.loop_pub.publish(best)
        t = best.transform.translation
        rospy.loginfo("loop_closure_bridge: loop t=%.2f s -> t=%.2f s verified against its %s (confidence "
                      "%.2f): T_old_new translation (%.2f, %.2f, %.2f) m, %.1f m apart by odometry",
                      current.stamp.to_sec(), old.stamp.to_sec(), what, best.confidence, t.x, t.y, t.z,
                      math.dist(current.pose[:3, 3], old.pose[:3, 3]))


if __name__ == "__main__":
    rospy.init_node("loop_closure_bridge")
    try:
        LoopClosureBridge()
    except ValueError as e:
        rospy.logfatal("loop_closure_bridge: %s", e)
        raise SystemExit(2)
    rospy.spin()
