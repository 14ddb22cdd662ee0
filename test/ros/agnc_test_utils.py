"""Helpers shared by the agnc_pgo rostest nodes (imported from the same directory)."""
import math
import os
import time

import rospy
from std_msgs.msg import Bool

from agnc_pgo.msg import GraphStatus, PoseGraph

BACKEND = "/agnc_pgo_backend"


class Latest(object):
    """Keeps the latest message of a topic and counts arrivals."""

    def __init__(self, topic, msg_type):
        self.msg = None
        self.count = 0
        self.sub = rospy.Subscriber(topic, msg_type, self._callback, queue_size=5)

    def _callback(self, msg):
        self.msg = msg
        self.count += 1

    def wait(self, predicate=lambda m: True, timeout=30.0, what="message"):
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            m = self.msg
            if m is not None and predicate(m):
                return m
            time.sleep(0.05)
        raise AssertionError("timed out after %.0f s waiting for %s (last: %s)" % (timeout, what, _short(self.msg)))

    def wait_new(self, timeout=30.0, predicate=lambda m: True, what="new message"):
        start = self.count
        return self.wait(lambda m: self.count > start and predicate(m), timeout, what)


def _short(msg):
    if msg is None:
        return None
    if isinstance(msg, GraphStatus):
        return "nodes %d loops %d inliers %d outliers %d graduating %d held %d msgs %d/%d" % (
            msg.nodes, msg.loop_closures, msg.inliers, msg.outliers, msg.graduating,
            msg.held_loop_closures, msg.odometry_messages, msg.loop_closure_messages)
    return str(msg)[:200]


def wait_for_player(timeout=60.0):
    done = Latest("/dataset_player/done", Bool)
    done.wait(lambda m: m.data, timeout, "dataset_player done")


def wait_until_settled(status, timeout=60.0, quiet=1.0, predicate=lambda s: True):
    """Waits until every received message is in the graph, nothing graduates,
    no idle refinement is under way, `predicate(status)` holds and the
    status has not changed for `quiet` seconds."""
    deadline = time.time() + timeout
    last_key, since = None, time.time()
    while time.time() < deadline and not rospy.is_shutdown():
        s = status.msg
        if s is not None:
            key = (s.nodes, s.loop_closures, s.loop_closure_messages, s.odometry_messages,
                   s.rejected_loop_closures, s.inliers, s.outliers, s.idle_refinements)
            ready = (s.graduating == 0 and s.held_loop_closures == 0 and not s.refining and
                     s.loop_closures + s.rejected_loop_closures == s.loop_closure_messages and
                     predicate(s))
            if key != last_key:
                last_key, since = key, time.time()
            elif ready and time.time() - since >= quiet:
                return s
        time.sleep(0.05)
    raise AssertionError("back-end did not settle: %s" % _short(status.msg))


def loop_edges(graph):
    return [e for e in graph.edges if e.type == e.LOOP_CLOSURE]


def pose_distance(a, b):
    """Translation + quaternion distance (q and -q are the same rotation)."""
    dt = (a.position.x - b.position.x) ** 2 + (a.position.y - b.position.y) ** 2 + (a.position.z - b.position.z) ** 2
    qa = (a.orientation.x, a.orientation.y, a.orientation.z, a.orientation.w)
    qb = (b.orientation.x, b.orientation.y, b.orientation.z, b.orientation.w)
    dq = min(sum((x - y) ** 2 for x, y in zip(qa, qb)), sum((x + y) ** 2 for x, y in zip(qa, qb)))
    return math.sqrt(dt + dq)


def find_executable(name, package="agnc_pgo"):
    """Absolute path of `package`'s executable `name` (lib/<package>/<name>)
    in the devel/install spaces of the environment (CMAKE_PREFIX_PATH, first
    match wins, as `catkin_find --libexec --first-only`). Not `rosrun`: it
    skips everything below <package source>/build/, where scripts/test.sh
    builds."""
    candidates = []
    try:
        from catkin.find_in_workspaces import find_in_workspaces
        candidates += find_in_workspaces(["libexec"], project=package, path=name)
    except ImportError:
        pass
    for prefix in os.environ.get("CMAKE_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            candidates.append(os.path.join(prefix, "lib", package, name))
    for path in candidates:
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    raise AssertionError("executable %s/%s not found in CMAKE_PREFIX_PATH=%s (looked at: %s)" % (
        package, name, os.environ.get("CMAKE_PREFIX_PATH"), candidates))
