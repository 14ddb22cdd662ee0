#!/usr/bin/python3
"""~set_loop_closure_status by (from_stamp, to_stamp): forcing the injected
outliers to be inliers bends the map and knocks true loop closures out;
putting them back to AUTO (again by stamps) makes those graduate again, so
every loop closure ends with the decision it had before the overrides.
~pose_graph edges say why: test distance against the threshold, uncorroborated,
dormant, the update that last decided them."""
import sys
import time
import unittest

import rospy
import rostest

from agnc_pgo.msg import GraphStatus, PoseGraph
from agnc_pgo.srv import SetLoopClosureStatus
import agnc_test_utils as u

MODE = SetLoopClosureStatus._request_class
TIMEOUT = 60.0


class Overrides(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.status = u.Latest(u.BACKEND + "/status", GraphStatus)
        cls.graph = u.Latest(u.BACKEND + "/pose_graph", PoseGraph)
        u.wait_for_player(TIMEOUT)
        u.wait_until_settled(cls.status, TIMEOUT)
        rospy.wait_for_service(u.BACKEND + "/set_loop_closure_status", TIMEOUT)
        cls.override = rospy.ServiceProxy(u.BACKEND + "/set_loop_closure_status", SetLoopClosureStatus)

    def stamps_of(self, graph, edge):
        return graph.nodes[edge.from_id].stamp, graph.nodes[edge.to_id].stamp

    def settled_graph(self, predicate, what):
        u.wait_until_settled(self.status, TIMEOUT)
        return self.graph.wait(predicate, TIMEOUT, what)

    def test_edges_say_why(self):
        g = self.graph.wait(lambda g: len(u.loop_edges(g)) == self.status.msg.loop_closures, TIMEOUT)
        loops = u.loop_edges(g)
        threshold = loops[0].threshold
        self.assertGreater(threshold, 0.0)
        for e in loops:
            self.assertEqual(e.threshold, threshold)
            if e.mode == MODE.AUTO:
                self.assertEqual(e.inlier, e.test_distance < threshold, e)
            self.assertGreater(e.decided_in_update, 0, e)
            if e.dormant:
                self.assertFalse(e.inlier, e)
        self.assertTrue(any(e.dormant for e in loops if e.source == "outlier"))
        self.assertTrue(any(e.uncorroborated for e in loops if e.source == "outlier"))
        odometry = [e for e in g.edges if e.type == e.ODOMETRY]
        self.assertTrue(all(e.threshold == 0 and e.decided_in_update == 0 for e in odometry))

    def test_unknown_stamps_fail(self):
        r = self.override(from_stamp=rospy.Time(1), to_stamp=rospy.Time(2), mode=MODE.FORCE_OUTLIER)
        self.assertFalse(r.success)
        self.assertIn("no loop closure", r.message)

    def test_undo_restores_the_disturbed_decisions(self):
        before = self.graph.wait(lambda g: len(u.loop_edges(g)) == self.status.msg.loop_closures, TIMEOUT)
        decisions = [e.inlier for e in u.loop_edges(before)]
        self.assertTrue(all(e.inlier for e in u.loop_edges(before) if e.source == "true"))
        outliers = [e for e in u.loop_edges(before) if e.source == "outlier" and not e.inlier][:5]
        self.assertEqual(len(outliers), 5)
        for e in outliers:
            a, b = self.stamps_of(before, e)
            r = self.override(from_stamp=b, to_stamp=a, mode=MODE.FORCE_INLIER)  # either order
            self.assertTrue(r.success, r.message)
        forced_indices = [e.loop_index for e in outliers]
        forced = self.settled_graph(
            lambda g: all(u.loop_edges(g)[k].mode == MODE.FORCE_INLIER for k in forced_indices), "forced")
        knocked_out = [e.loop_index for e in u.loop_edges(forced) if e.source == "true" and not e.inlier]
        rospy.loginfo("forcing %d outliers knocked out %d true loop closures", len(outliers), len(knocked_out))
        self.assertGreater(len(knocked_out), 0, "the forced outliers disturbed nothing: the test proves nothing")
        messages = []
        for e in outliers:
            a, b = self.stamps_of(before, e)
            r = self.override(from_stamp=a, to_stamp=b, mode=MODE.AUTO)
            self.assertTrue(r.success, r.message)
            messages.append(r.message)
        self.assertTrue(any("graduated again" in m for m in messages), messages)
        after = self.settled_graph(lambda g: all(u.loop_edges(g)[k].mode == MODE.AUTO for k in forced_indices),
                                   "back to auto")
        changed = [(e.loop_index, e.source, e.inlier, e.mu, e.distance) for e in u.loop_edges(after)
                   if e.inlier != decisions[e.loop_index]]
        self.assertEqual(changed, [], "knocked out: %s; messages: %s" % (knocked_out, messages))


if __name__ == "__main__":
    rospy.init_node("test_overrides")
    rostest.rosrun("agnc_pgo", "test_overrides", Overrides, sys.argv)
