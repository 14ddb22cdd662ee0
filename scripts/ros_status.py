#!/usr/bin/python3
"""Waits for the dataset player to finish and the agnc_pgo back-end to settle,
then prints the final status table (counts, classification against the
player's labels, per-loop-closure latency). Used by demo.sh.
Exits non-zero when the back-end never reported, the player did not finish
in time, or the graph has no loop closure (an empty demo is no success).
usage: ros_status.py [--timeout SECONDS] [--backend /agnc_pgo_backend]"""
import argparse
import sys
import time

import rospy
from std_msgs.msg import Bool

from agnc_pgo.msg import GraphStatus, PoseGraph

state = {"done": False, "status": None, "graph": None}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--timeout", type=float, default=170.0)
    parser.add_argument("--backend", default="/agnc_pgo_backend")
    parser.add_argument("--status-timeout", type=float, default=60.0,
                        help="fail if the back-end has not reported within this many seconds")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("agnc_pgo_status", anonymous=True)
    rospy.Subscriber("/dataset_player/done", Bool, lambda m: state.update(done=m.data))
    rospy.Subscriber(args.backend + "/status", GraphStatus, lambda m: state.update(status=m))
    rospy.Subscriber(args.backend + "/pose_graph", PoseGraph, lambda m: state.update(graph=m), queue_size=1)
    start = time.time()
    last_key, since, progress = None, time.time(), 0.0
    while not rospy.is_shutdown() and time.time() - start < args.timeout:
        s, g = state["status"], state["graph"]
        if s is None and time.time() - start > args.status_timeout:
            break
        if s is not None and time.time() - progress > 10:
            progress = time.time()
            print("  [%3.0f s] %d nodes, %d loop closures (%d graduating)" %
                  (time.time() - start, s.nodes, s.loop_closures, s.graduating), flush=True)
        if state["done"] and s is not None and g is not None:
            key = (s.nodes, s.loop_closures, s.inliers, s.outliers, s.loop_closure_messages)
            settled = (s.graduating == 0 and s.held_loop_closures == 0 and not s.refining and
                       s.loop_closures + s.rejected_loop_closures == s.loop_closure_messages and
                       len(g.nodes) == s.nodes and sum(1 for e in g.edges if e.type == e.LOOP_CLOSURE) == s.loop_closures)
            if key != last_key:
                last_key, since = key, time.time()
            elif settled and time.time() - since > 1.5:
                break
        time.sleep(0.1)
    s, g = state["status"], state["graph"]
    if s is None:
        print("no status from the back-end")
        return 1
    loops = [e for e in g.edges if e.type == e.LOOP_CLOSURE] if g else []
    tp = sum(1 for e in loops if e.inlier and e.source == "true")
    fp = sum(1 for e in loops if e.inlier and e.source == "outlier")
    fn = sum(1 for e in loops if not e.inlier and e.source == "true")
    injected = sum(1 for e in loops if e.source == "outlier")
    rows = [
        ("keyframes (nodes)", s.nodes),
        ("odometry edges", s.odometry_edges),
        ("loop closures", "%d (%d injected outliers)" % (s.loop_closures, injected)),
        ("inliers / outliers", "%d / %d" % (s.inliers, s.outliers)),
        ("graduating / held", "%d / %d" % (s.graduating, s.held_loop_closures)),
        ("precision", "%.4f (TP %d, FP %d)" % (tp / float(max(tp + fp, 1)), tp, fp)),
        ("recall", "%.4f (FN %d)" % (tp / float(max(tp + fn, 1)), fn)),
        ("rejected odom / loops", "%d / %d (dropped %d)" % (s.rejected_odometry, s.rejected_loop_closures,
                                                            s.dropped_loop_closures)),
        ("GNC steps / GN iterations", "%d / %d" % (s.total_gnc_steps, s.total_iterations)),
        ("failed updates", s.failed_updates),
        ("latency p50/p95/max", "%.1f / %.1f / %.1f ms (LoopClosure receive -> estimate publish)" %
         (s.latency_ms_p50, s.latency_ms_p95, s.latency_ms_max)),
        ("first estimate p50/p95/max", "%.1f / %.1f / %.1f ms (anytime: before the whole graph follows or far loop closures are judged; %d updates)" %
         (s.first_estimate_latency_ms_p50, s.first_estimate_latency_ms_p95, s.first_estimate_latency_ms_max,
          s.first_estimates)),
        ("idle refinements", "%d%s (whole graph converged while nothing was queued)" %
         (s.idle_refinements, ", one under way" if s.refining else "")),
        ("last update", "%.1f ms solver time" % s.last_update_ms),
    ]
    print("\nagnc_pgo back-end status")
    print("-" * 78)
    for k, v in rows:
        print("%-28s %s" % (k, v))
    print("-" * 78, flush=True)
    if not state["done"]:
        print("the dataset player did not finish within %.0f s" % args.timeout)
        return 1
    if s.loop_closures == 0:
        print("the graph has no loop closure")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
