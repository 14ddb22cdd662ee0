#!/usr/bin/python3
"""Soak test of the ROS back-end (a measurement, not a pass/fail test).

Streams KEYFRAMES odometry messages at RATE Hz (every message a keyframe)
along a synthetic circuit (a circle of LAP poses driven round and round,
truth known, noise-free) with a loop closure every 10 keyframes (to the same
place one lap earlier, or 5 poses back during the first lap) through ROS to
backend_node, and prints a summary table: messages sent, drops (rejected or
dropped messages, missing nodes / loop closures), back-end RSS (MB per 1000
keyframes, least-squares), map -> odom gaps (receive times and header stamps
of /tf; the target is no gap above 2 / tf_rate) and latency percentiles from
~status and the worst distance of a final pose from the truth.

  scripts/soak_test.py [--keyframes 20000] [--rate 200] [--port 11473]
(needs a build; source build/devel/setup.bash first).
"""
import argparse
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BACKEND = "/agnc_pgo_backend"
LAP = 500          # poses per lap of the circle
RADIUS = 50.0      # [m]
T0 = 1000.0        # [s] stamp of keyframe 0
TF_RATE = 20.0     # [Hz] config/default.yaml


def parse_arguments():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--keyframes", type=int, default=20000)
    p.add_argument("--rate", type=float, default=200.0)
    p.add_argument("--port", type=int, default=11473)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    a = p.parse_args()
    if a.keyframes < 20 or a.rate <= 0:
        p.error("--keyframes must be >= 20 and --rate > 0")
    return a


def truth(k):
    """Pose k on the circle: x, y, yaw."""
    angle = 2.0 * math.pi * k / LAP
    return RADIUS * math.sin(angle), RADIUS * (1.0 - math.cos(angle)), angle


def relative(a, b):
    """Pose of b in the frame of a (SE(2))."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    return c * dx + s * dy, -s * dx + c * dy, b[2] - a[2]


def rss_mb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def fit_slope(points):
    n = len(points)
    if n < 2:
        return float("nan")
    mx = sum(x for x, _ in points) / n
    my = sum(y for _, y in points) / n
    sxx = sum((x - mx) ** 2 for x, _ in points)
    return sum((x - mx) * (y - my) for x, y in points) / sxx if sxx > 0 else float("nan")


class TfWatch(object):
    """Receive times and header stamps of every map -> odom transform."""

    def __init__(self):
        import rospy
        from tf2_msgs.msg import TFMessage
        self.receipts, self.stamps = [], []
        self.lock = threading.Lock()
        self.sub = rospy.Subscriber("/tf", TFMessage, self.callback, queue_size=1000)

    def callback(self, message):
        now = time.time()
        for t in message.transforms:
            if t.header.frame_id == "map" and t.child_frame_id == "odom":
                with self.lock:
                    self.receipts.append(now)
                    self.stamps.append(t.header.stamp.to_sec())

    @staticmethod
    def max_gap(times):
        return max((b - a for a, b in zip(times, times[1:])), default=float("nan"))


def wait_for_master(timeout):
    """roscore takes seconds to come up on a loaded machine."""
    import rosgraph
    deadline = time.time() + timeout
    while not rosgraph.Master("/agnc_pgo_probe").is_online():
        if time.time() > deadline:
            raise RuntimeError("roscore did not come up within %.0f s" % timeout)
        time.sleep(0.2)


def main():
    a = parse_arguments()
    os.environ["ROS_MASTER_URI"] = "http://localhost:%d" % a.port
    os.environ.setdefault("ROS_HOME", os.path.join(a.build, "ros_home"))
    log = open(os.path.join(tempfile.gettempdir(), "agnc_pgo_soak_backend.log"), "wb")
    core = subprocess.Popen(["roscore", "-p", str(a.port)], stdout=log, stderr=log)
    backend = None
    import rospy
    try:
        wait_for_master(60.0)
        subprocess.check_call(["rosparam", "load", os.path.join(ROOT, "config", "default.yaml"), BACKEND])
        for name, value in (("keyframe_translation", "0.0"), ("keyframe_rotation", "0.0"),
                            ("keyframe_interval", "0.0"), ("stamp_tolerance", "0.001"),
                            ("visualization_rate", "0.5")):
            subprocess.check_call(["rosparam", "set", BACKEND + "/" + name, value])
        executable = os.path.join(a.build, "devel", "lib", "agnc_pgo", "backend_node")
        backend = subprocess.Popen([executable, "__name:=agnc_pgo_backend", "~odom:=/soak/odom",
                                    "~loop_closures:=/soak/loop_closures"], stdout=log, stderr=log)
        rospy.init_node("agnc_pgo_soak_test", anonymous=True, disable_signals=True)
        from nav_msgs.msg import Odometry
        from agnc_pgo.msg import GraphStatus, LoopClosure
        odom_pub = rospy.Publisher("/soak/odom", Odometry, queue_size=10000)
        loop_pub = rospy.Publisher("/soak/loop_closures", LoopClosure, queue_size=10000)
        statuses = []
        rospy.Subscriber(BACKEND + "/status", GraphStatus, statuses.append, queue_size=100)
        tf = TfWatch()
        deadline = time.time() + 60
        while time.time() < deadline and (odom_pub.get_num_connections() == 0 or
                                          loop_pub.get_num_connections() == 0 or not statuses):
            time.sleep(0.1)
        if odom_pub.get_num_connections() == 0:
            raise RuntimeError("the back-end did not subscribe")
        time.sleep(1.0)

        rss = []
        loops_sent = 0
        start = time.time()
        period = 1.0 / a.rate
        next_sample = start
        for k in range(a.keyframes):
            target = start + k * period
            delay = target - time.time()
            if delay > 0:
                time.sleep(delay)
            x, y, yaw = truth(k)
            m = Odometry()
            m.header.stamp = rospy.Time(T0 + k * 0.005)
            m.header.frame_id = "odom"
            m.pose.pose.position.x, m.pose.pose.position.y = x, y
            m.pose.pose.orientation.z, m.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            odom_pub.publish(m)
            if k >= 10 and k % 10 == 0:
                j = k - LAP if k >= LAP else k - 5
                dx, dy, dyaw = relative(truth(j), truth(k))
                l = LoopClosure()
                l.from_stamp = rospy.Time(T0 + j * 0.005)
                l.to_stamp = rospy.Time(T0 + k * 0.005)
                l.relative_pose.position.x, l.relative_pose.position.y = dx, dy
                l.relative_pose.orientation.z, l.relative_pose.orientation.w = math.sin(dyaw / 2), math.cos(dyaw / 2)
                l.source = "soak"
                l.score = 1.0
                loop_pub.publish(l)
                loops_sent += 1
            if time.time() >= next_sample:
                nodes = statuses[-1].nodes if statuses else 0
                rss.append((nodes, rss_mb(backend.pid)))
                next_sample += 1.0
        send_seconds = time.time() - start
        # Wait until the back-end has every keyframe and loop closure and is quiet.
        deadline = time.time() + 120
        while time.time() < deadline:
            s = statuses[-1]
            if s.nodes + s.rejected_odometry >= a.keyframes and \
                    s.loop_closures + s.rejected_loop_closures >= loops_sent and s.graduating == 0:
                break
            time.sleep(0.5)
        time.sleep(2.0)
        s = statuses[-1]
        rss.append((s.nodes, rss_mb(backend.pid)))
        with tf.lock:
            receipts = [t for t in tf.receipts if t >= start]
            stamps = tf.stamps[len(tf.receipts) - len(receipts):]
        slope = fit_slope([(n / 1000.0, mb) for n, mb in rss if n > 0])
        drops = (s.rejected_odometry + s.rejected_loop_closures + s.dropped_loop_closures +
                 (a.keyframes - s.nodes) + (loops_sent - s.loop_closures))
        rows = [
            ("keyframes sent / in graph", "%d / %d" % (a.keyframes, s.nodes)),
            ("loop closures sent / in graph", "%d / %d (inliers %d, outliers %d)" %
             (loops_sent, s.loop_closures, s.inliers, s.outliers)),
            ("send rate", "%.1f Hz over %.1f s" % (a.keyframes / send_seconds, send_seconds)),
            ("drops (rejected, dropped, missing)", "%d" % drops),
            ("failed updates", "%d" % s.failed_updates),
            ("back-end RSS start / end", "%.1f MB / %.1f MB" % (rss[0][1], rss[-1][1])),
            ("RSS growth", "%.2f MB per 1000 keyframes" % slope),
            ("map->odom max gap (receipt / stamp)", "%.3f s / %.3f s (target <= %.3f s; %d transforms)" %
             (TfWatch.max_gap(receipts), TfWatch.max_gap(stamps), 2.0 / TF_RATE, len(receipts))),
            ("latency p50 / p95 / max", "%.2f / %.2f / %.1f ms" % (s.latency_ms_p50, s.latency_ms_p95,
                                                                 s.latency_ms_max)),
            ("total GNC steps / iterations", "%d / %d" % (s.total_gnc_steps, s.total_iterations)),
        ]
        width = max(len(r[0]) for r in rows)
        print("| %-*s | %s |" % (width, "soak (%d keyframes at %.0f Hz)" % (a.keyframes, a.rate), "value"))
        print("|%s|---|" % ("-" * (width + 2)))
        for name, value in rows:
            print("| %-*s | %s |" % (width, name, value))
        return 0
    finally:
        rospy.signal_shutdown("done")
        for p in (backend, core):
            if p is not None and p.poll() is None:
                p.send_signal(signal.SIGINT)
                try:
                    p.wait(20)
                except subprocess.TimeoutExpired:
                    p.kill()
        log.close()


if __name__ == "__main__":
    sys.exit(main())
