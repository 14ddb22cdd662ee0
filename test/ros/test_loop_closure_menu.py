#!/usr/bin/python3
"""loop_closure_menu: every loop closure has an interactive marker with the
three-entry menu; a MENU_SELECT feedback for "Force outlier" on a true
inlier (what rviz sends on a right-click choice) makes ~pose_graph show it
forced and rejected; "Automatic" hands it back."""
import sys
import time
import unittest

import rospy
import rostest
from visualization_msgs.msg import InteractiveMarkerFeedback, InteractiveMarkerInit

from agnc_pgo.msg import GraphStatus, PoseGraph
import agnc_test_utils as u

TIMEOUT = 60.0
FORCE_OUTLIER, AUTOMATIC = 2, 3  # menu entry ids


class LoopClosureMenu(unittest.TestCase):
    def test_menu_forces_and_releases(self):
        status = u.Latest(u.BACKEND + "/status", GraphStatus)
        graph = u.Latest(u.BACKEND + "/pose_graph", PoseGraph)
        init = u.Latest("/loop_closure_menu/update_full", InteractiveMarkerInit)
        u.wait_for_player(TIMEOUT)
        s = u.wait_until_settled(status, TIMEOUT)
        g = graph.wait(lambda g: len(u.loop_edges(g)) == s.loop_closures, TIMEOUT)
        m = init.wait(lambda m: len(m.markers) == s.loop_closures, TIMEOUT, "a marker per loop closure")
        titles = [e.title for e in m.markers[0].menu_entries]
        self.assertEqual(titles, ["Force inlier", "Force outlier", "Automatic (GNC decides)"])

        target = next(e for e in u.loop_edges(g) if e.inlier and e.source == "true")
        feedback = rospy.Publisher("/loop_closure_menu/feedback", InteractiveMarkerFeedback, queue_size=10)
        deadline = time.time() + TIMEOUT
        while feedback.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)

        def select(entry):
            f = InteractiveMarkerFeedback()
            f.client_id = "test"
            f.marker_name = "loop_closure_%d" % target.loop_index
            f.control_name = "menu"
            f.event_type = InteractiveMarkerFeedback.MENU_SELECT
            f.menu_entry_id = entry
            feedback.publish(f)

        select(FORCE_OUTLIER)
        forced = graph.wait(lambda g: u.loop_edges(g)[target.loop_index].mode == 2, TIMEOUT, "forced outlier")
        self.assertFalse(u.loop_edges(forced)[target.loop_index].inlier)
        select(AUTOMATIC)
        back = graph.wait(lambda g: u.loop_edges(g)[target.loop_index].mode == 0, TIMEOUT, "automatic")
        u.wait_until_settled(status, TIMEOUT)
        back = graph.wait(lambda g: u.loop_edges(g)[target.loop_index].inlier, TIMEOUT, "inlier again")
        self.assertTrue(u.loop_edges(back)[target.loop_index].inlier)


if __name__ == "__main__":
    rospy.init_node("test_loop_closure_menu")
    rostest.rosrun("agnc_pgo", "test_loop_closure_menu", LoopClosureMenu, sys.argv)
