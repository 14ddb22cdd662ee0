#!/usr/bin/python3
"""~save_graph -> ~reset -> ~load_graph restores an identical graph: same
nodes (stamps), edges, loop-closure states, estimate within 1e-9."""
import os
import shutil
import sys
import tempfile
import unittest
import zlib

import rospy
import rostest
from std_srvs.srv import Trigger

from agnc_pgo.msg import GraphStatus, PoseGraph
from agnc_pgo.srv import LoadGraph, SaveGraph, SaveTrajectory, SetLoopClosureStatus
import agnc_test_utils as u


FORCE_OUTLIER = SetLoopClosureStatus._request_class.FORCE_OUTLIER

# Generous bounds for a loaded machine (2 cores, builds running); on a quiet
# one each wait ends as soon as its condition holds (the test takes ~5 s).
# Every command publishes one ~pose_graph after the service has answered, so
# the waits below look for the graph's content, never for "the next message"
# (which may have arrived before the answer).
START_TIMEOUT = 60.0  # player done, back-end settled
TIMEOUT = 30.0        # services, graphs after a command


def resign(meta):
    """The sidecar text with a valid closing checksum (as a crafted file would have)."""
    body = meta[:meta.rindex(b"checksum ")]
    return body + b"checksum %08x\n" % (zlib.crc32(body) & 0xffffffff)


def replace_field(meta, line_prefix, index, value):
    lines = meta.split(b"\n")
    for k, line in enumerate(lines):
        if line.startswith(line_prefix):
            fields = line.split(b" ")
            fields[index] = value
            lines[k] = b" ".join(fields)
            return resign(b"\n".join(lines))
    raise AssertionError("no line %r" % line_prefix)


def edge_key(e):
    return (e.type, e.from_id, e.to_id, e.loop_index, e.inlier, e.graduating, e.mode, e.source)


def first_loop_forced_outlier(graph):
    loops = u.loop_edges(graph)
    return bool(loops) and loops[0].mode == FORCE_OUTLIER


class SaveLoad(unittest.TestCase):
    def test_round_trip(self):
        status = u.Latest(u.BACKEND + "/status", GraphStatus)
        graph = u.Latest(u.BACKEND + "/pose_graph", PoseGraph)
        u.wait_for_player(START_TIMEOUT)
        # Every odometry message is a keyframe here (config/dataset_player.yaml):
        # settled = all of them are in the graph, not only the loop closures.
        s = u.wait_until_settled(status, START_TIMEOUT, quiet=1.5,
                                 predicate=lambda m: m.nodes + m.rejected_odometry == m.odometry_messages)
        self.assertGreater(s.nodes, 0)
        self.assertGreater(s.loop_closures, 0)
        for name in ("save_graph", "load_graph", "reset", "set_loop_closure_status"):
            rospy.wait_for_service(u.BACKEND + "/" + name, TIMEOUT)
        save = rospy.ServiceProxy(u.BACKEND + "/save_graph", SaveGraph)
        load = rospy.ServiceProxy(u.BACKEND + "/load_graph", LoadGraph)
        reset = rospy.ServiceProxy(u.BACKEND + "/reset", Trigger)
        override = rospy.ServiceProxy(u.BACKEND + "/set_loop_closure_status", SetLoopClosureStatus)

        # One manual override, so that the modes round-trip too.
        r = override(index=0, mode=FORCE_OUTLIER)
        self.assertTrue(r.success, r.message)
        graph.wait(first_loop_forced_outlier, TIMEOUT, "graph with loop closure 0 forced outlier")
        # The override's update is followed by an idle refinement: save what it converged to.
        u.wait_until_settled(status, TIMEOUT, quiet=0.5)
        before = graph.wait(first_loop_forced_outlier, TIMEOUT, "settled graph with loop closure 0 forced outlier")
        self.assertEqual(len(before.nodes), s.nodes)
        self.assertEqual(len(u.loop_edges(before)), s.loop_closures)
        self.assertFalse(any(e.graduating for e in u.loop_edges(before)))

        directory = tempfile.mkdtemp(prefix="agnc_pgo_test_")
        self.addCleanup(shutil.rmtree, directory, True)
        filename = os.path.join(directory, "graph.g2o")
        r = save(filename=filename)
        self.assertTrue(r.success, r.message)
        self.assertTrue(os.path.exists(filename) and os.path.exists(filename + ".meta"))

        r = reset()
        self.assertTrue(r.success, r.message)
        empty = graph.wait(lambda m: len(m.nodes) == 0, TIMEOUT, "empty graph after reset")
        self.assertEqual(len(empty.edges), 0)
        self.assertEqual(status.wait(lambda m: m.nodes == 0, TIMEOUT, "status after reset").loop_closures, 0)

        # A bad file fails and leaves the (empty) graph alone.
        r = load(filename=os.path.join(directory, "missing.g2o"))
        self.assertFalse(r.success)
        self.assertTrue(r.message)

        r = load(filename=filename)
        self.assertTrue(r.success, r.message)
        after = graph.wait(lambda m: len(m.nodes) > 0, TIMEOUT, "graph after load")
        self.assertEqual(len(after.nodes), len(before.nodes))

        self.assertEqual(after.dimension, before.dimension)
        self.assertEqual(len(after.edges), len(before.edges))
        for a, b in zip(before.nodes, after.nodes):
            self.assertEqual(a.stamp, b.stamp)
            self.assertLess(u.pose_distance(a.pose, b.pose), 1e-9)
            self.assertLess(u.pose_distance(a.odom_pose, b.odom_pose), 1e-9)
        for a, b in zip(before.edges, after.edges):
            self.assertEqual(edge_key(a), edge_key(b))
            self.assertLess(u.pose_distance(a.relative_pose, b.relative_pose), 1e-9)
            self.assertAlmostEqual(a.mu, b.mu, delta=1e-12)
            self.assertAlmostEqual(a.weight, b.weight, delta=1e-9)
            for x, y in zip(a.covariance, b.covariance):
                self.assertAlmostEqual(x, y, delta=1e-9 * max(1.0, abs(x)))
        loops = u.loop_edges(after)
        self.assertEqual(loops[0].mode, FORCE_OUTLIER)
        self.assertFalse(loops[0].inlier)
        st = status.wait(lambda m: m.nodes > 0, TIMEOUT, "status after load")
        self.assertEqual(st.nodes, len(before.nodes))
        self.assertEqual(st.loop_closures, s.loop_closures)

        # save -> load -> save is byte-identical (g2o and sidecar).
        again = os.path.join(directory, "again.g2o")
        r = save(filename=again)
        self.assertTrue(r.success, r.message)
        for suffix in ("", ".meta"):
            with open(filename + suffix, "rb") as a, open(again + suffix, "rb") as b:
                self.assertEqual(a.read(), b.read(), "file%s changed on save -> load -> save" % suffix)
        self.check_hostile_files(directory, filename, load, status, graph, st)

        # A write error is an error (the stream is checked after its last flush).
        save_trajectory = rospy.ServiceProxy(u.BACKEND + "/save_trajectory", SaveTrajectory)
        r = save_trajectory(filename="/dev/full")
        self.assertFalse(r.success, r.message)
        self.assertIn("No space left on device", r.message)
        r = save(filename="/dev/full")
        self.assertFalse(r.success, r.message)

    def check_hostile_files(self, directory, good, load, status, graph, loaded_status):
        """Each damaged, mismatched or out-of-domain pair: success false, graph unchanged."""
        with open(good, "rb") as f:
            g2o = f.read()
        with open(good + ".meta", "rb") as f:
            meta = f.read()
        cut = g2o[:g2o.rindex(b"EDGE_SE2")]  # cut at a line end in the loop-closure section
        cases = [
            ("truncated g2o + sidecar", cut, meta, "truncated"),
            ("truncated g2o alone", cut, None, "truncated"),
            ("truncated sidecar", g2o, meta[:-20], "truncated"),
            ("count wrap-around", g2o, replace_field(meta, b"odometry_edges", 1, b"-1"), "outside"),
            ("mu = 7", g2o, replace_field(meta, b"LOOP 0 ", 5, b"7"), "mu 7"),
            ("step = INT_MAX", g2o, replace_field(meta, b"LOOP 0 ", 6, b"2147483647"), "step 2147483647"),
            ("zero quaternion", g2o, replace_field(replace_field(replace_field(replace_field(
                meta, b"NODE 1 ", 7, b"0"), b"NODE 1 ", 8, b"0"), b"NODE 1 ", 9, b"0"), b"NODE 1 ", 10, b"0"),
             "not unit length"),
            ("huge source", g2o, replace_field(meta, b"LOOP 0 ", 22, b"=" + b"x" * 100000), "source is longer"),
            ("NaN score", g2o, replace_field(meta, b"LOOP 0 ", 20, b"nan"), "non-finite"),
            ("sidecar of another g2o", g2o.replace(b"VERTEX_SE2 1 ", b"VERTEX_SE2 1  ", 1), meta, "does not belong"),
        ]
        for k, (what, g2o_bytes, meta_bytes, reason) in enumerate(cases):
            path = os.path.join(directory, "hostile%d.g2o" % k)
            with open(path, "wb") as f:
                f.write(g2o_bytes)
            if meta_bytes is not None:
                with open(path + ".meta", "wb") as f:
                    f.write(meta_bytes)
            r = load(filename=path)
            self.assertFalse(r.success, what + ": " + r.message)
            self.assertIn(reason, r.message, what)
            self.assertIn("graph unchanged", r.message, what)
            self.assertLess(len(r.message), 1000, what)
        st = status.wait(lambda m: m.nodes > 0, TIMEOUT, "status after hostile loads")
        self.assertEqual(st.nodes, loaded_status.nodes)
        self.assertEqual(st.loop_closures, loaded_status.loop_closures)
        self.assertEqual(len(graph.msg.nodes), loaded_status.nodes)


if __name__ == "__main__":
    rospy.init_node("test_save_load")
    rostest.rosrun("agnc_pgo", "test_save_load", SaveLoad, sys.argv)
