#!/usr/bin/env python3
"""Checks the headless demo: each registration of each pair in the bag meets its benchmark criterion."""
import os
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from mac_registration.msg import RegistrationResult

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from demo_monitor import CRITERIA, errors  # noqa: E402  (the demo's own arithmetic, tested here too)

RESULTS_PER_PAIR = 3  # cycles written by make_demo_bag


class DemoTest(unittest.TestCase):
    def test_every_pair_is_registered_within_the_criterion(self):
        lock = threading.Lock()
        truth, results = {}, {pair: [] for pair in CRITERIA}

        def on_truth(msg, pair):
            with lock:
                truth[(pair, msg.header.stamp)] = msg.transform

        def on_result(msg, pair):
            with lock:
                results[pair].append(msg)

        subs = []
        for pair in CRITERIA:
            subs.append(rospy.Subscriber("/%s/ground_truth" % pair, TransformStamped, on_truth, pair))
            subs.append(rospy.Subscriber("/%s/mac_registration/result" % pair, RegistrationResult, on_result, pair))
        # Wall clock: simulated time stands still until the bag starts playing.
        deadline = time.time() + 240
        while time.time() < deadline:
            with lock:
                if all(len(r) >= RESULTS_PER_PAIR for r in results.values()):
                    break
            time.sleep(0.1)
        with lock:
            for pair, msgs in results.items():
                self.assertEqual(len(msgs), RESULTS_PER_PAIR, "%s: %d results" % (pair, len(msgs)))
                max_re, max_te = CRITERIA[pair]
                for msg in msgs:
                    self.assertTrue(msg.success, "%s: %s" % (pair, msg.message))
                    self.assertIn((pair, msg.header.stamp), truth, "%s: no ground truth at the result's stamp" % pair)
                    re, te = errors(msg.transform, truth[(pair, msg.header.stamp)])
                    self.assertLessEqual(re, max_re, "%s: rotation error %.2f deg" % (pair, re))
                    self.assertLessEqual(te, max_te, "%s: translation error %.3f m" % (pair, te))

    def test_error_arithmetic(self):
        same = TransformStamped().transform
        same.rotation.w = 1.0
        turned = TransformStamped().transform
        turned.rotation.z, turned.rotation.w = 0.258819, 0.965926  # 30 deg about z
        turned.translation.x = 0.3
        re, te = errors(turned, same)
        self.assertAlmostEqual(re, 30.0, places=3)
        self.assertAlmostEqual(te, 0.3, places=9)


if __name__ == "__main__":
    rospy.init_node("test_demo")
    rostest.rosrun("mac_registration", "demo", DemoTest)
