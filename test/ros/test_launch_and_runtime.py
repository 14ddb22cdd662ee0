#!/usr/bin/python3
"""Launch and runtime fixes (standalone back-end started by backend.launch
with test/ros/launch_yaml_3d.yaml): the yaml's dimension 3 reaches the node
(a keyframe keeps its z); ~keyframes announces every keyframe with its
stamp, id and pose; bad loop closures are all counted but their warnings
throttled; an unknown parameter is warned about at start-up; ~initial_graph
loads a graph saved by ~save_graph; ~optimize says it converged."""
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Quaternion
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from std_srvs.srv import Trigger

from agnc_pgo.msg import GraphStatus, Keyframe, LoopClosure
from agnc_pgo.srv import SaveGraph
import agnc_test_utils as u

TIMEOUT = 30.0
POSES = 6


class LaunchAndRuntime(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.keyframes = []
        rospy.Subscriber(u.BACKEND + "/keyframes", Keyframe, cls.keyframes.append, queue_size=100)
        cls.warnings = []
        rospy.Subscriber("/rosout", Log, lambda m: cls.warnings.append(m.msg) if m.level == Log.WARN else None,
                         queue_size=1000)
        cls.status = u.Latest(u.BACKEND + "/status", GraphStatus)
        cls.odom = rospy.Publisher("/test/odom", Odometry, queue_size=100)
        cls.loops = rospy.Publisher("/test/loop_closures", LoopClosure, queue_size=100)
        cls.status.wait(timeout=TIMEOUT, what="back-end status")
        deadline = time.time() + TIMEOUT
        while (cls.odom.get_num_connections() == 0 or cls.loops.get_num_connections() == 0) and \
                time.time() < deadline:
            time.sleep(0.05)
        cls.stamps = [rospy.Time(100 + k) for k in range(POSES)]
        for k, stamp in enumerate(cls.stamps):  # a climbing straight line: z matters in 3D only
            m = Odometry()
            m.header.stamp = stamp
            m.header.frame_id = "odom"
            m.pose.pose.position.x = float(k)
            m.pose.pose.position.z = 0.5 * k
            m.pose.pose.orientation = Quaternion(0, 0, 0, 1)
            cls.odom.publish(m)
            time.sleep(0.02)
        cls.status.wait(lambda s: s.nodes == POSES, TIMEOUT, "%d keyframes" % POSES)

    def test_1_yaml_dimension_reaches_the_node(self):
        self.assertEqual(rospy.get_param(u.BACKEND + "/dimension"), 3)
        deadline = time.time() + TIMEOUT
        while len(self.keyframes) < POSES and time.time() < deadline:
            time.sleep(0.05)
        self.assertAlmostEqual(self.keyframes[-1].pose.position.z, 0.5 * (POSES - 1), places=6)

    def test_2_keyframes_announce_stamp_id_pose(self):
        deadline = time.time() + TIMEOUT
        while len(self.keyframes) < POSES and time.time() < deadline:
            time.sleep(0.05)
        self.assertEqual([k.id for k in self.keyframes], list(range(POSES)))
        self.assertEqual([k.header.stamp for k in self.keyframes], self.stamps)
        self.assertEqual([k.header.frame_id for k in self.keyframes], ["map"] * POSES)
        self.assertEqual([round(k.pose.position.x, 6) for k in self.keyframes], [float(k) for k in range(POSES)])

    def test_3_rejections_counted_warnings_throttled(self):
        before = self.status.msg.rejected_loop_closures
        bad = 40
        for k in range(bad):
            m = LoopClosure()
            m.from_stamp = self.stamps[0]
            m.to_stamp = rospy.Time(100.5)  # between keyframes: matches none
            m.relative_pose.orientation = Quaternion(0, 0, 0, 1)
            self.loops.publish(m)
        s = self.status.wait(lambda s: s.rejected_loop_closures == before + bad, TIMEOUT, "%d rejections" % bad)
        self.assertIn("matches no keyframe", s.last_warning)
        time.sleep(1.0)
        logged = [w for w in self.warnings if "rejected loop closure" in w]
        self.assertGreaterEqual(len(logged), 1)
        self.assertLessEqual(len(logged), 3, logged)

    def test_4_unknown_parameter_warned(self):
        out = self.run_probe("probe_unknown", ["_keyframe_translaton:=0.5"], wait_for="unknown parameter")
        self.assertIn("unknown parameter ~keyframe_translaton", out)

    def test_5_initial_graph_loaded_at_start_up(self):
        rospy.wait_for_service(u.BACKEND + "/save_graph", TIMEOUT)
        directory = tempfile.mkdtemp(prefix="agnc_pgo_initial_")
        self.addCleanup(shutil.rmtree, directory, True)
        filename = os.path.join(directory, "graph.g2o")
        r = rospy.ServiceProxy(u.BACKEND + "/save_graph", SaveGraph)(filename=filename)
        self.assertTrue(r.success, r.message)
        probe = u.Latest("/probe_initial/status", GraphStatus)
        out = self.run_probe("probe_initial", ["_initial_graph:=" + filename, "_dimension:=3"],
                             until=lambda: probe.msg is not None and probe.msg.nodes == POSES)
        self.assertIsNotNone(probe.msg, out)
        self.assertEqual(probe.msg.nodes, POSES, out)
        # A failed load stops start-up cleanly: the node says so and exits 1
        # (it used to crash while the failed nodelet was being destroyed).
        out = self.run_probe("probe_missing", ["_initial_graph:=/nonexistent/graph.g2o"])
        self.assertIn("~initial_graph", out)
        self.assertIn("could not start the back-end", out)
        self.assertEqual(self.probe_returncode, 1, out)

    def test_6_optimize_says_converged(self):
        r = rospy.ServiceProxy(u.BACKEND + "/optimize", Trigger)()
        self.assertTrue(r.success, r.message)
        self.assertIn("converged after", r.message)

    def run_probe(self, name, args, wait_for=None, until=None):
        """Runs a second backend_node with `args` until its output contains
        `wait_for` or `until()` holds (or it exits); returns its output and
        leaves its exit code in self.probe_returncode (negative: a signal,
        e.g. the terminate() here)."""
        log = tempfile.NamedTemporaryFile(prefix="agnc_pgo_probe_", suffix=".log", delete=False)
        self.addCleanup(os.remove, log.name)
        p = subprocess.Popen([u.find_executable("backend_node"), "__name:=" + name] + args,
                             stdout=log, stderr=subprocess.STDOUT)
        deadline = time.time() + TIMEOUT
        out = ""
        while time.time() < deadline:
            time.sleep(0.2)
            with open(log.name, errors="replace") as f:
                out = f.read()
            if (wait_for and wait_for in out) or (until and until()) or p.poll() is not None:
                break
        if p.poll() is None:
            p.terminate()
            p.wait(10)
        self.probe_returncode = p.returncode
        with open(log.name, errors="replace") as f:
            return f.read()


if __name__ == "__main__":
    rospy.init_node("test_launch_and_runtime")
    rostest.rosrun("agnc_pgo", "test_launch_and_runtime", LaunchAndRuntime, sys.argv)
