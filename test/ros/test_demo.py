#!/usr/bin/env python3
"""Checks the headless demo: each registration of each pair in the bag meets its benchmark criterion, and the
campus query is localized in the campus map within the relocalization criterion, unasked, at start-up."""
import os
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from mac_registration.msg import RegistrationResult, RelocalizationAnswer

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from demo_monitor import CRITERIA, RELOCALIZATION_CRITERION, errors, pose_to_transform  # noqa: E402  (the demo's own arithmetic, tested here too)

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

    @classmethod
    def setUpClass(cls):
        # The relocalization answers at start-up, before the registrations are done: listen from the start.
        cls.lock = threading.Lock()
        cls.truth, cls.answers = [], []

        def on_truth(msg):
            with cls.lock:
                cls.truth.append(msg.transform)

        def on_answer(msg):
            with cls.lock:
                cls.answers.append(msg)

        cls.subs = [rospy.Subscriber("/relocalization/ground_truth", TransformStamped, on_truth),
                    rospy.Subscriber("/relocalization/mac_relocalization/result", RelocalizationAnswer, on_answer)]

    def test_the_campus_query_is_localized_at_start(self):
        lock, truth, answers = self.lock, self.truth, self.answers
        deadline = time.time() + 240
        while time.time() < deadline:
            with lock:
                if truth and any(a.success for a in answers):
                    break
            time.sleep(0.1)
        with lock:
            self.assertTrue(truth, "no ground truth for the relocalization query")
            localized = [a for a in answers if a.success]
            self.assertTrue(localized, "not localized: %s" % "; ".join(a.message for a in answers))
            answer = localized[0]
            self.assertEqual(answer.trigger, "start")
            self.assertEqual(answer.pose.header.frame_id, "campus_map")
            re, te = errors(pose_to_transform(answer.pose.pose.pose), truth[0])
            max_re, max_te = RELOCALIZATION_CRITERION
            self.assertLessEqual(re, max_re, "rotation error %.2f deg" % re)
            self.assertLessEqual(te, max_te, "translation error %.3f m" % te)
            self.assertTrue(answer.candidates, "no ranked places")

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
