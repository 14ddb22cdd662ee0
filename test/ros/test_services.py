#!/usr/bin/python3
"""Services and parameters: ~pause holds solves (messages still enter the
graph) until resumed; forcing a loop closure to be an outlier changes its
classification and the estimate, auto restores it; ~optimize,
~save_trajectory; bad requests fail cleanly; invalid parameters stop start-up."""
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

import rospy
import rostest
from std_srvs.srv import SetBool, Trigger

from agnc_pgo.msg import GraphStatus, LoopClosure, PoseGraph
from agnc_pgo.srv import SaveTrajectory, SetLoopClosureStatus
import agnc_test_utils as u

MODE = SetLoopClosureStatus._request_class
START_TIMEOUT = 60.0  # player done, back-end settled (generous: loaded machines)
TIMEOUT = 30.0        # services, messages after a command


def max_pose_change(a, b):
    return max(u.pose_distance(x.pose, y.pose) for x, y in zip(a.nodes, b.nodes))


class Services(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.status = u.Latest(u.BACKEND + "/status", GraphStatus)
        cls.graph = u.Latest(u.BACKEND + "/pose_graph", PoseGraph)
        u.wait_for_player(START_TIMEOUT)
        u.wait_until_settled(cls.status, START_TIMEOUT)
        for name in ("pause", "set_loop_closure_status", "optimize", "save_trajectory"):
            rospy.wait_for_service(u.BACKEND + "/" + name, TIMEOUT)
        cls.pause = rospy.ServiceProxy(u.BACKEND + "/pause", SetBool)
        cls.override = rospy.ServiceProxy(u.BACKEND + "/set_loop_closure_status", SetLoopClosureStatus)
        cls.optimize = rospy.ServiceProxy(u.BACKEND + "/optimize", Trigger)
        cls.trajectory = rospy.ServiceProxy(u.BACKEND + "/save_trajectory", SaveTrajectory)
        cls.loops = rospy.Publisher("/dataset_player/loop_closures", LoopClosure, queue_size=10)

    def test_1_pause_resume(self):
        # Settled, idle refinement included: the estimate no longer moves by itself.
        u.wait_until_settled(self.status, TIMEOUT, quiet=0.5)
        before = self.graph.wait(lambda m: not any(e.graduating for e in u.loop_edges(m)), TIMEOUT)
        r = self.pause(data=True)
        self.assertTrue(r.success, r.message)
        self.status.wait(lambda s: s.paused, TIMEOUT, "paused status")
        # A loop closure duplicating a true one (node 433 -> 0 style): enters, is not solved.
        true_loop = next(e for e in u.loop_edges(before) if e.source == "true")
        m = LoopClosure()
        m.from_stamp = before.nodes[true_loop.from_id].stamp
        m.to_stamp = before.nodes[true_loop.to_id].stamp
        m.relative_pose = true_loop.relative_pose
        m.relative_pose.position.x += 0.3  # slightly different: the estimate must move when solved
        m.covariance = true_loop.covariance
        m.source = "test"
        deadline = time.time() + TIMEOUT
        while self.loops.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)
        n = len(u.loop_edges(before))
        self.loops.publish(m)
        s = self.status.wait(lambda s: s.loop_closures == n + 1, TIMEOUT, "loop added while paused")
        self.assertEqual(s.graduating, 1)
        time.sleep(0.5)
        paused_graph = self.graph.wait(lambda g: len(u.loop_edges(g)) == n + 1, TIMEOUT)
        self.assertLess(max_pose_change(before, paused_graph), 1e-12)
        r = self.pause(data=False)
        self.assertTrue(r.success, r.message)
        s = self.status.wait(lambda s: not s.paused and s.graduating == 0, TIMEOUT, "resumed")
        resumed = self.graph.wait(lambda g: not any(e.graduating for e in u.loop_edges(g)), TIMEOUT)
        self.assertGreater(max_pose_change(before, resumed), 1e-6)

    def test_2_force_outlier_and_back(self):
        before = self.graph.wait(lambda m: not any(e.graduating for e in u.loop_edges(m)), TIMEOUT)
        target = next(e for e in u.loop_edges(before) if e.inlier and e.source == "true")
        r = self.override(index=target.loop_index, mode=MODE.FORCE_OUTLIER)
        self.assertTrue(r.success, r.message)
        # Each command publishes its graph after answering: wait for the content,
        # not for "the next message" (it may have arrived before the answer).
        forced = self.graph.wait(lambda g: u.loop_edges(g)[target.loop_index].mode == MODE.FORCE_OUTLIER,
                                 TIMEOUT, "graph with the loop closure forced outlier")
        e = u.loop_edges(forced)[target.loop_index]
        self.assertFalse(e.inlier)
        self.assertEqual(e.mode, MODE.FORCE_OUTLIER)
        self.assertGreater(max_pose_change(before, forced), 1e-6)
        s = self.status.wait(lambda s: s.outliers == sum(1 for x in u.loop_edges(forced) if not x.inlier), TIMEOUT)
        r = self.override(index=target.loop_index, mode=MODE.AUTO)
        self.assertTrue(r.success, r.message)
        back = self.graph.wait(lambda g: u.loop_edges(g)[target.loop_index].mode == MODE.AUTO,
                               TIMEOUT, "graph with the loop closure back to auto")
        self.assertTrue(u.loop_edges(back)[target.loop_index].inlier)
        self.assertEqual(u.loop_edges(back)[target.loop_index].mode, MODE.AUTO)
        # Bad requests fail without harm.
        self.assertFalse(self.override(index=100000, mode=MODE.FORCE_OUTLIER).success)
        self.assertFalse(self.override(index=0, mode=7).success)

    def test_3_optimize_and_trajectory(self):
        r = self.optimize()
        self.assertTrue(r.success, r.message)
        directory = tempfile.mkdtemp(prefix="agnc_pgo_test_")
        self.addCleanup(shutil.rmtree, directory, True)
        filename = os.path.join(directory, "trajectory.tum")
        r = self.trajectory(filename=filename)
        self.assertTrue(r.success, r.message)
        with open(filename) as f:
            lines = [l for l in f if l.strip() and not l.startswith("#")]
        self.assertEqual(len(lines), self.status.msg.nodes)
        self.assertEqual(len(lines[0].split()), 8)
        self.assertFalse(self.trajectory(filename="/nonexistent/dir/t.tum").success)

    def test_4_invalid_parameters_stop_start_up(self):
        # The binary of this build's devel space, not rosrun's search (it skips
        # everything below <package>/build/, where scripts/test.sh builds).
        backend_node = u.find_executable("backend_node")
        env = dict(os.environ)
        p = subprocess.run([backend_node, "__name:=bad_backend", "_dimension:=4"],
                           env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=30)
        out = p.stdout.decode(errors="replace")
        self.assertNotEqual(p.returncode, 0, out)
        self.assertIn("~dimension", out)
        p = subprocess.run([backend_node, "__name:=bad_backend2",
                            "_odometry_sigmas:=[1, 2]"],
                           env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=30)
        out = p.stdout.decode(errors="replace")
        self.assertNotEqual(p.returncode, 0, out)
        self.assertIn("~odometry_sigmas", out)


if __name__ == "__main__":
    rospy.init_node("test_services")
    rostest.rosrun("agnc_pgo", "test_services", Services, sys.argv)
