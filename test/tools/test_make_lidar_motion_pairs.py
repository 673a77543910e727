#!/usr/bin/env python3
"""The motion set's composed references: the turned source's points must land where the reference puts
the original source's points, and the PCD it writes must read back the same points."""

import math
import os
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import make_lidar_motion_pairs as motion  # noqa: E402


def random_pose(rng):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = rng.uniform(-10, 10, size=3)
    return T


def apply(T, points):
    return points @ T[:3, :3].T + T[:3, 3]


class ComposedReference(unittest.TestCase):
    def test_turned_source_lands_on_the_original_image(self):
        rng = np.random.default_rng(7)
        points = rng.uniform(-50, 50, size=(1000, 3))
        for yaw_deg in (30, 90, 135, 180, 270, -45):
            T = random_pose(rng)
            yaw = math.radians(yaw_deg)
            turned = motion.turn_points(points, yaw)
            moved = np.abs(apply(motion.compose_turned_source(T, yaw), turned) - apply(T, points)).max()
            self.assertLess(moved, 1e-9, "yaw %g deg" % yaw_deg)

    def test_turn_is_about_z_and_keeps_heights(self):
        turned = motion.turn_points(np.array([[1.0, 0.0, 2.0]]), math.radians(90))
        np.testing.assert_allclose(turned, [[0.0, 1.0, 2.0]], atol=1e-12)

    def test_a_wrong_composition_is_caught(self):
        # Rz instead of Rz^-1 moves the points: the check above can fail.
        rng = np.random.default_rng(3)
        points = rng.uniform(-50, 50, size=(100, 3))
        T, yaw = random_pose(rng), math.radians(60)
        wrong = T @ motion.rz(yaw)
        self.assertGreater(np.abs(apply(wrong, motion.turn_points(points, yaw)) - apply(T, points)).max(), 1.0)

    def test_pcd_round_trip(self):
        points = np.random.default_rng(1).uniform(-80, 80, size=(257, 3)).astype(np.float32)
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "cloud.pcd")
            motion.write_pcd(path, points)
            np.testing.assert_array_equal(motion.read_pcd(path), points.astype(np.float64))


if __name__ == "__main__":
    unittest.main()
