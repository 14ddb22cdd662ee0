#!/usr/bin/python3
"""End to end: dataset_player (Intel, 30 % outliers, fixed seed) -> back-end.
Checks map -> odom tf, ~path (one pose per keyframe), loop-closure
classification against the player's ground-truth labels (~pose_graph),
the outlier markers and ~status."""
import sys
import time
import unittest

import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Path
from visualization_msgs.msg import MarkerArray

from agnc_pgo.msg import GraphStatus, PoseGraph
import agnc_test_utils as u


class EndToEnd(unittest.TestCase):
    def test_intel_with_outliers(self):
        status = u.Latest(u.BACKEND + "/status", GraphStatus)
        graph = u.Latest(u.BACKEND + "/pose_graph", PoseGraph)
        path = u.Latest(u.BACKEND + "/path", Path)
        markers = u.Latest(u.BACKEND + "/markers", MarkerArray)
        tf_buffer = tf2_ros.Buffer()
        tf2_ros.TransformListener(tf_buffer)

        u.wait_for_player(timeout=40)
        s = u.wait_until_settled(status, timeout=40)
        g = graph.wait(lambda m: len(m.nodes) == s.nodes and len(u.loop_edges(m)) == s.loop_closures and
                       not any(e.graduating for e in u.loop_edges(m)), 15, "final pose graph")
        p = path.wait(lambda m: len(m.poses) == s.nodes, 10, "final path")

        # Every dataset pose became a keyframe, nothing was rejected.
        self.assertEqual(s.nodes, 943)
        self.assertEqual(s.odometry_messages, 943)
        self.assertEqual(s.rejected_odometry, 0)
        self.assertEqual(s.rejected_loop_closures, 0)
        self.assertEqual(len(p.poses), s.nodes)
        self.assertEqual([ps.header.stamp for ps in p.poses], [n.stamp for n in g.nodes])

        # Classification vs the player's labels (LoopClosure.source).
        loops = u.loop_edges(g)
        injected = sum(1 for e in loops if e.source == "outlier")
        self.assertGreater(injected, 300)  # 30 % of Intel's 895 true loops: floor(0.3*895/0.7) = 383
        tp = sum(1 for e in loops if e.inlier and e.source == "true")
        fp = sum(1 for e in loops if e.inlier and e.source == "outlier")
        fn = sum(1 for e in loops if not e.inlier and e.source == "true")
        precision = tp / float(tp + fp)
        recall = tp / float(tp + fn)
        rospy.loginfo("intel 30%%: %d loops, %d injected, TP %d FP %d FN %d, precision %.4f recall %.4f",
                      len(loops), injected, tp, fp, fn, precision, recall)
        self.assertGreaterEqual(precision, 0.99)
        self.assertGreaterEqual(recall, 0.98)

        # Status agrees with the graph.
        self.assertEqual(s.loop_closures, len(loops))
        self.assertEqual(s.inliers, sum(1 for e in loops if e.inlier))
        self.assertEqual(s.outliers, sum(1 for e in loops if not e.inlier))
        self.assertEqual(s.odometry_edges, sum(1 for e in g.edges if e.type == e.ODOMETRY))
        # Intel states its noise right (the replay keeps a scale of 1 on it).
        self.assertEqual((s.noise_scale_translation, s.noise_scale_rotation), (1.0, 1.0))

        # Outlier markers: one red line (2 points) per outlier, green per inlier.
        m = markers.wait(lambda a: any(k.ns == "loop_outliers" and len(k.points) == 2 * s.outliers
                                       for k in a.markers), 10, "final markers")
        by_ns = dict((k.ns, k) for k in m.markers)
        self.assertEqual(len(by_ns["loop_outliers"].points) // 2, s.outliers)
        self.assertEqual(len(by_ns["loop_inliers"].points) // 2, s.inliers)
        self.assertGreater(by_ns["loop_outliers"].color.r, 0.9)
        self.assertGreater(by_ns["loop_inliers"].color.g, 0.5)
        self.assertEqual(len(by_ns["nodes"].points), s.nodes)

        # map -> odom is broadcast (future-dated) and the status counts GNC work.
        t = tf_buffer.lookup_transform("map", "odom", rospy.Time(0), rospy.Duration(5.0))
        self.assertEqual(t.child_frame_id, "odom")
        self.assertGreater(s.total_gnc_steps, 0)
        self.assertGreater(s.latency_ms_max, 0.0)
        # Anytime: no loop closure waits longer for its first estimate than
        # for the finished update.
        self.assertGreater(s.first_estimates, 0)  # Intel's corrections call for whole-graph refinements
        self.assertGreater(s.idle_refinements, 0)  # at the latest once the player has finished
        self.assertGreater(s.first_estimate_latency_ms_max, 0.0)
        self.assertLessEqual(s.first_estimate_latency_ms_max, s.latency_ms_max)
        self.assertLessEqual(s.first_estimate_latency_ms_p95, s.latency_ms_p95)
        # map -> base_link through the player's odom -> base_link.
        tf_buffer.lookup_transform("map", "base_link", rospy.Time(0), rospy.Duration(5.0))


if __name__ == "__main__":
    rospy.init_node("test_end_to_end")
    rostest.rosrun("agnc_pgo", "test_end_to_end", EndToEnd, sys.argv)
