#!/usr/bin/python3
"""For scripts/menu_screenshot.sh: reads the settled back-end's ~pose_graph,
picks a rejected loop closure near the middle of the map (the one whose
right-click menu the screenshot opens), writes an rviz config whose top-down
view frames the whole graph, and prints the loop closure's index and the
map coordinates of its interactive marker (the midpoint of its endpoints):
"INDEX X Y SCALE CENTER_X CENTER_Y".
usage: menu_view.py --rviz-in FILE --rviz-out FILE [--width PX --height PX]
       [--backend /agnc_pgo_backend]"""
import argparse
import os
import re
import sys

import rospy

from agnc_pgo.msg import PoseGraph


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--rviz-in", required=True)
    parser.add_argument("--rviz-out", required=True)
    parser.add_argument("--backend", default="/agnc_pgo_backend")
    parser.add_argument("--width", type=float, default=700.0, help="[px] of the 3-D view to fill")
    parser.add_argument("--height", type=float, default=560.0)
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node("agnc_pgo_menu_view", anonymous=True)
    graph = rospy.wait_for_message(args.backend + "/pose_graph", PoseGraph, timeout=30)
    xs = [n.pose.position.x for n in graph.nodes]
    ys = [n.pose.position.y for n in graph.nodes]
    cx, cy = 0.5 * (min(xs) + max(xs)), 0.5 * (min(ys) + max(ys))
    # 10 % margin around the graph.
    scale = 0.9 * min(args.width / max(max(xs) - min(xs), 1e-3), args.height / max(max(ys) - min(ys), 1e-3))

    def midpoint(e):
        a, b = graph.nodes[e.from_id].pose.position, graph.nodes[e.to_id].pose.position
        return 0.5 * (a.x + b.x), 0.5 * (a.y + b.y)

    rejected = [e for e in graph.edges if e.type == e.LOOP_CLOSURE and not e.inlier and not e.graduating]
    if not rejected:
        sys.exit("menu_view.py: no rejected loop closure in ~pose_graph")
    # Left of and above the centre, so that the menu (it opens to the lower
    # right of the pointer) stays over the graph.
    target = (cx - 0.15 * args.width / scale, cy + 0.1 * args.height / scale)
    chosen = min(rejected, key=lambda e: (midpoint(e)[0] - target[0]) ** 2 + (midpoint(e)[1] - target[1]) ** 2)
    x, y = midpoint(chosen)

    text = open(args.rviz_in).read()
    views = text.index("  Views:")
    head, tail = text[:views], text[views:]
    tail = re.sub(r"(\n      Scale: )[-0-9.e]+", r"\g<1>%.4f" % scale, tail, count=1)
    tail = re.sub(r"(\n      X: )[-0-9.e]+", r"\g<1>%.4f" % cx, tail, count=1)
    tail = re.sub(r"(\n      Y: )[-0-9.e]+", r"\g<1>%.4f" % cy, tail, count=1)
    temporary = args.rviz_out + ".tmp"  # atomically: a reader sees the old file or the new one
    with open(temporary, "w") as f:
        f.write(head + tail)
    os.replace(temporary, args.rviz_out)
    print("%d %.4f %.4f %.4f %.4f %.4f" % (chosen.loop_index, x, y, scale, cx, cy))


if __name__ == "__main__":
    main()
