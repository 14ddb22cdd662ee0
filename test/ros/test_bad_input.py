#!/usr/bin/python3
"""Loop closures with NaN, a zero quaternion, a non-PD covariance, unknown
stamps, a NaN score, a 1e308 translation or a 1e-300 covariance, and odometry
whose stamp goes backwards, at x = 1e308 or jumping 495 m, are rejected and counted;
the back-end keeps running and the graph is unchanged."""
import math
import sys
import time
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry

from agnc_pgo.msg import GraphStatus, LoopClosure, PoseGraph
import agnc_test_utils as u

T0 = 1000.0


def odometry(i, x, stamp=None):
    m = Odometry()
    m.header.stamp = rospy.Time(stamp if stamp is not None else T0 + i)
    m.header.frame_id = "odom"
    m.child_frame_id = "base_link"
    m.pose.pose.position.x = x
    m.pose.pose.orientation.w = 1.0
    return m


def loop(i, j, dx, cov=None):
    m = LoopClosure()
    m.from_stamp = rospy.Time(T0 + i)
    m.to_stamp = rospy.Time(T0 + j)
    m.relative_pose.position.x = dx
    m.relative_pose.orientation.w = 1.0
    m.covariance = cov if cov is not None else [0.0] * 36
    m.source = "test"
    return m


class BadInput(unittest.TestCase):
    def setUp(self):
        self.odom = rospy.Publisher("/test/odom", Odometry, queue_size=100)
        self.loops = rospy.Publisher("/test/loop_closures", LoopClosure, queue_size=100)
        self.status = u.Latest(u.BACKEND + "/status", GraphStatus)
        self.graph = u.Latest(u.BACKEND + "/pose_graph", PoseGraph)
        deadline = time.time() + 20
        while time.time() < deadline and (self.odom.get_num_connections() == 0 or
                                          self.loops.get_num_connections() == 0):
            time.sleep(0.05)
        self.assertGreater(self.odom.get_num_connections(), 0)

    def test_rejected_and_counted(self):
        # A valid graph: 6 keyframes 1 m apart and one consistent loop closure.
        for i in range(6):
            self.odom.publish(odometry(i, float(i)))
        time.sleep(0.3)
        self.loops.publish(loop(5, 0, -5.0))
        s = self.status.wait(lambda m: m.nodes == 6 and m.loop_closures == 1 and m.graduating == 0, 15, "valid graph")
        before = self.graph.wait(lambda m: len(m.nodes) == 6 and len(u.loop_edges(m)) == 1, 10, "graph")
        self.assertEqual(s.rejected_loop_closures, 0)
        self.assertEqual(s.rejected_odometry, 0)

        nan = loop(5, 1, float("nan"))
        zero_q = loop(5, 1, -4.0)
        zero_q.relative_pose.orientation.w = 0.0
        non_pd = [0.0] * 36
        for k in range(6):
            non_pd[7 * k] = 0.01
        non_pd[7 * 5] = -0.01  # negative yaw variance
        bad_cov = loop(5, 1, -4.0, non_pd)
        between = loop(5, 0, -5.0)
        between.from_stamp = rospy.Time(T0 + 2.5)  # between keyframes: unknown
        future = loop(9, 0, -9.0)                  # newer than every keyframe: held, then dropped
        nan_score = loop(5, 1, -4.0)
        nan_score.score = float("nan")     # would make every later save unloadable
        huge = loop(5, 1, 1e308)           # finite, but cancels every other digit of the map
        tiny = [0.0] * 36
        for k in range(6):
            tiny[7 * k] = 1e-300           # information 1e300
        tiny_cov = loop(5, 1, -4.0, tiny)
        for m in (nan, zero_q, bad_cov, between, future, nan_score, huge, tiny_cov):
            self.loops.publish(m)
        self.odom.publish(odometry(6, 6.0, stamp=T0 + 3.0))  # stamp going backwards
        nan_odom = odometry(7, 0.0, stamp=T0 + 20)
        nan_odom.pose.pose.position.y = float("inf")
        self.odom.publish(nan_odom)
        zero_odom = odometry(8, 0.0, stamp=T0 + 21)
        zero_odom.pose.pose.orientation.w = 0.0
        self.odom.publish(zero_odom)
        self.odom.publish(odometry(9, 1e308, stamp=T0 + 22))  # beyond ~max_position
        self.odom.publish(odometry(10, 500.0, stamp=T0 + 23))  # jumps 495 m (~max_odometry_jump 100)

        s = self.status.wait(lambda m: m.rejected_loop_closures == 8 and m.dropped_loop_closures == 1 and
                             m.rejected_odometry == 5, 10, "rejections counted")
        self.assertEqual(s.nodes, 6)
        self.assertEqual(s.loop_closures, 1)
        self.assertEqual(s.held_loop_closures, 0)
        self.assertEqual(s.loop_closure_messages, 9)
        self.assertEqual(s.odometry_messages, 11)
        self.assertEqual(s.failed_updates, 0)
        self.assertNotEqual(s.last_warning, "")

        # Graph unchanged (a full publication happens after every command/update).
        after = self.graph.msg
        self.assertEqual(len(after.nodes), len(before.nodes))
        self.assertEqual(len(after.edges), len(before.edges))
        for a, b in zip(before.nodes, after.nodes):
            self.assertEqual(a.stamp, b.stamp)
            self.assertLess(u.pose_distance(a.pose, b.pose), 1e-12)

        # Still alive and accepting: a new keyframe and a loop closure to it.
        self.odom.publish(odometry(6, 6.0))
        time.sleep(0.2)
        self.loops.publish(loop(6, 1, -5.0))
        s = self.status.wait(lambda m: m.nodes == 7 and m.loop_closures == 2 and m.graduating == 0, 10,
                             "accepting after bad input")
        self.assertEqual(s.inliers, 2)


if __name__ == "__main__":
    rospy.init_node("test_bad_input")
    rostest.rosrun("agnc_pgo", "test_bad_input", BadInput, sys.argv)
