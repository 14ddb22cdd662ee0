#!/usr/bin/python3
"""dynamic_reconfigure on the running back-end (servers ~ and ~gnc):
- they start from the yaml (tf_rate 25, gnc/max_gnc_steps 40), not the .cfg
  defaults (20, 30);
- ~gnc/distance reference -> squared: the same 4-sigma loop closure that was
  accepted before (r = 4 < q(0.9) = 6.25) is rejected on arrival after
  (r^2 = 16), as ~pose_graph shows;
- ~tf_rate 25 -> 4: the measured map -> odom rate follows;
- ~paused and the ~pause service agree (~status says which);
- an invalid request (tf_rate 0, schedule "bogus", trust_region_radius above
  max_trust_region_radius) is refused with a warning naming the parameter,
  and every value of it, valid ones included, stays as it was."""
import sys
import time
import unittest

import rospy
import rostest
import dynamic_reconfigure.client
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from std_srvs.srv import SetBool
from tf2_msgs.msg import TFMessage

from agnc_pgo.msg import GraphStatus, LoopClosure, PoseGraph
import agnc_test_utils as u

T0 = 1000.0
POSES = 60


def odometry(i):
    m = Odometry()
    m.header.stamp = rospy.Time(T0 + i)
    m.header.frame_id = "odom"
    m.child_frame_id = "base_link"
    m.pose.pose.position.x = float(i)
    m.pose.pose.orientation.w = 1.0
    return m


def loop(i, j, error):
    """Keyframe i -> keyframe j on the straight line, `error` m off in x
    (x sigma 0.1 m: error 0.4 = 4 sigma)."""
    m = LoopClosure()
    m.from_stamp = rospy.Time(T0 + i)
    m.to_stamp = rospy.Time(T0 + j)
    m.relative_pose.position.x = float(j - i) + error
    m.relative_pose.orientation.w = 1.0
    m.covariance = [0.0] * 36
    m.source = "test"
    return m


class Reconfigure(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.status = u.Latest(u.BACKEND + "/status", GraphStatus)
        cls.graph = u.Latest(u.BACKEND + "/pose_graph", PoseGraph)
        cls.warnings = []
        cls.rosout = rospy.Subscriber("/rosout", Log, cls._log, queue_size=100)
        cls.tf_count = 0
        cls.tf = rospy.Subscriber("/tf", TFMessage, cls._tf, queue_size=100)
        cls.backend = dynamic_reconfigure.client.Client(u.BACKEND, timeout=30)
        cls.gnc = dynamic_reconfigure.client.Client(u.BACKEND + "/gnc", timeout=30)
        rospy.wait_for_service(u.BACKEND + "/pause", 30)
        cls.pause = rospy.ServiceProxy(u.BACKEND + "/pause", SetBool)
        cls.odom = rospy.Publisher("/test/odom", Odometry, queue_size=100)
        cls.loops = rospy.Publisher("/test/loop_closures", LoopClosure, queue_size=100)
        deadline = time.time() + 20
        while time.time() < deadline and (cls.odom.get_num_connections() == 0 or
                                          cls.loops.get_num_connections() == 0):
            time.sleep(0.05)

    @classmethod
    def _log(cls, msg):
        if msg.level >= Log.WARN:
            cls.warnings.append(msg.msg)

    @classmethod
    def _tf(cls, msg):
        cls.tf_count += sum(1 for t in msg.transforms if t.child_frame_id == "odom")

    def tf_rate(self, seconds=1.5):
        start = self.tf_count
        time.sleep(seconds)
        return (self.tf_count - start) / seconds

    def refused(self, client, request, parameter):
        """Sends `request`; expects it refused with a warning naming
        `parameter` and every value of the server as before."""
        before = client.get_configuration(timeout=10)
        seen = len(self.warnings)
        returned = client.update_configuration(request)
        for name in request:
            self.assertEqual(returned[name], before[name], "%s: %s" % (name, request))
        now = client.get_configuration(timeout=10)
        for name in request:
            self.assertEqual(now[name], before[name], name)
        deadline = time.time() + 5
        while time.time() < deadline and not any(parameter in w for w in self.warnings[seen:]):
            time.sleep(0.05)
        self.assertTrue(any("refused" in w and parameter in w for w in self.warnings[seen:]),
                        "no warning naming %s in %s" % (parameter, self.warnings[seen:]))

    def test_1_servers_start_from_the_yaml(self):
        self.assertEqual(self.backend.get_configuration(timeout=10)["tf_rate"], 25.0)
        g = self.gnc.get_configuration(timeout=10)
        self.assertEqual(g["max_gnc_steps"], 40)
        self.assertEqual(g["schedule"], "agnc")
        self.assertEqual(g["distance"], "reference")

    def test_2_distance_convention_decides_the_next_loop_closure(self):
        self.assertEqual(self.gnc.get_configuration(timeout=10)["distance"], "reference")
        for i in range(POSES):
            self.odom.publish(odometry(i))
        self.status.wait(lambda s: s.nodes == POSES, 15, "%d keyframes" % POSES)
        self.loops.publish(loop(25, 0, 0.4))
        g = self.graph.wait(lambda g: len(u.loop_edges(g)) == 1 and not u.loop_edges(g)[0].graduating,
                            15, "first loop closure decided")
        first = u.loop_edges(g)[0]
        self.assertTrue(first.inlier, first)

        self.assertEqual(self.gnc.update_configuration({"distance": "squared"})["distance"], "squared")
        # The same 4-sigma error, on a stretch the first one did not bend.
        self.loops.publish(loop(59, 35, 0.4))
        g = self.graph.wait(lambda g: len(u.loop_edges(g)) == 2 and not u.loop_edges(g)[1].graduating,
                            15, "second loop closure decided")
        second = u.loop_edges(g)[1]
        self.assertFalse(second.inlier, second)
        self.assertAlmostEqual(second.test_distance, 16.0, places=3)  # r^2, rejected without a solve
        self.assertGreater(second.test_distance, second.threshold)
        self.assertTrue(second.uncorroborated)
        self.assertTrue(u.loop_edges(g)[0].inlier)
        self.gnc.update_configuration({"distance": "reference"})

    def test_3_tf_rate(self):
        before = self.tf_rate()
        self.assertGreater(before, 12.0)  # 25 Hz from the yaml
        self.assertEqual(self.backend.update_configuration({"tf_rate": 4.0})["tf_rate"], 4.0)
        time.sleep(0.5)
        after = self.tf_rate(2.0)
        self.assertLess(after, 6.5)
        self.assertGreater(after, 2.0)
        self.backend.update_configuration({"tf_rate": 25.0})

    def test_4_paused_and_pause_agree(self):
        self.backend.update_configuration({"paused": True})
        self.status.wait(lambda s: s.paused, 10, "paused in ~status")
        self.assertTrue(self.pause(False).success)
        self.status.wait(lambda s: not s.paused, 10, "resumed in ~status")
        # The client learns the server's new values from a topic: wait for them.
        deadline = time.time() + 10
        while time.time() < deadline and self.backend.get_configuration(timeout=10)["paused"]:
            time.sleep(0.05)
        self.assertFalse(self.backend.get_configuration(timeout=10)["paused"])

    def test_5_invalid_requests_are_refused(self):
        self.refused(self.backend, {"tf_rate": 0.0, "visualization_rate": 3.0}, "~tf_rate")
        self.refused(self.gnc, {"schedule": "bogus"}, "~gnc/schedule")
        self.refused(self.gnc, {"trust_region_radius": 5000.0}, "~gnc/max_trust_region_radius")
        # Still running at the old rate.
        self.assertGreater(self.tf_rate(1.0), 12.0)


if __name__ == "__main__":
    rospy.init_node("test_reconfigure")
    rostest.rosrun("agnc_pgo", "test_reconfigure", Reconfigure, sys.argv)
