#!/usr/bin/python3
"""Durability of ~save_graph under SIGKILL.

The back-end (backend_node) holds a 3500-node graph (M3500) and saves it over
FILE, which holds the previous save (a smaller graph, Intel). It is killed
with SIGKILL at a random moment of the save, TRIALS times. After every kill:

  * FILE and FILE.meta are, byte for byte, the previous save or the new one
    (or the new g2o with the new sidecar still staged in FILE.meta.saving: a
    kill between the two renames), never a mixture or a prefix;
  * a fresh back-end loads FILE completely (the node count of one of the two
    graphs), and every file the save left behind (FILE.saving) either loads
    completely or is refused; nothing loads partially.

Exits non-zero if any trial destroys the previous save. Usage:
  scripts/durability_test.py [--trials N] [--port P] [--seed S]
(needs a build: source build/devel/setup.bash first; scripts/test.sh runs it).
"""
import argparse
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BACKEND = "/agnc_pgo_backend"


def free_port():
    """A port nothing listens on now, so that two probes (two clones) never share a master."""
    import socket
    with socket.socket() as probe:
        probe.bind(("localhost", 0))
        return probe.getsockname()[1]


def parse_arguments():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--trials", type=int, default=24)
    p.add_argument("--port", type=int, default=0, help="roscore port (default: a free one)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    a = p.parse_args()
    if a.port == 0:
        a.port = free_port()
    if a.trials < 1:
        p.error("--trials must be >= 1")
    return a


class Backend(object):
    """One backend_node process with its service proxies."""

    def __init__(self, executable, log):
        self.process = subprocess.Popen([executable, "__name:=agnc_pgo_backend"], stdout=log, stderr=log)
        import rospy
        from std_srvs.srv import SetBool
        from agnc_pgo.srv import LoadGraph, SaveGraph
        for name in ("load_graph", "save_graph", "pause"):
            rospy.wait_for_service(BACKEND + "/" + name, 60.0)
        self.load = rospy.ServiceProxy(BACKEND + "/load_graph", LoadGraph)
        self.save = rospy.ServiceProxy(BACKEND + "/save_graph", SaveGraph)
        self.pause = rospy.ServiceProxy(BACKEND + "/pause", SetBool)

    def kill(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGKILL)
        self.process.wait()

    def stop(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.kill()


def read(path):
    try:
        with open(path, "rb") as f:
            return f.read()
    except IOError:
        return None


def nodes_of(message):
    # "loaded N nodes and M loop closures from ..."
    return int(message.split()[1])


def make_pair(backend, dataset, path):
    """Saves `dataset` (paused: no solve, the g2o's own estimate) as a back-end pair at path."""
    r = backend.load(filename=dataset)
    assert r.success, r.message
    nodes = nodes_of(r.message)
    r = backend.save(filename=path)
    assert r.success, r.message
    return (read(path), read(path + ".meta")), nodes


def classify(path, old, new):
    """Which save FILE holds now: 'old', 'new', 'new (sidecar staged)', or None (destroyed)."""
    g2o, meta, staged = read(path), read(path + ".meta"), read(path + ".meta.saving")
    if (g2o, meta) == old:
        return "old"
    if (g2o, meta) == new:
        return "new"
    if g2o == new[0] and staged == new[1]:
        return "new (sidecar staged)"
    return None


def graphs(work):
    """The two graphs saved over each other: Intel and M3500 from ../shared when it is there,
    otherwise two worlds of the repository's own generator (1000 and 3500 poses)."""
    datasets = os.path.join(ROOT, "..", "shared", "datasets")
    if os.path.isdir(datasets):
        return os.path.join(datasets, "intel.g2o"), os.path.join(datasets, "manhattanOlson3500.g2o")
    paths = []
    for poses in (1000, 3500):
        name = "grid2d_%d_seed1" % poses
        subprocess.check_call([sys.executable, os.path.join(ROOT, "scripts", "make_scaling_graph.py"),
                               "--poses", str(poses), "--seed", "1", "--out", work, "--name", name],
                              stdout=subprocess.DEVNULL)
        paths.append(os.path.join(work, name + ".g2o"))
    return paths[0], paths[1]


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
    executable = os.path.join(a.build, "devel", "lib", "agnc_pgo", "backend_node")
    work = tempfile.mkdtemp(prefix="agnc_pgo_durability_")
    log = open(os.path.join(work, "backend.log"), "wb")
    core = subprocess.Popen(["roscore", "-p", str(a.port)], stdout=log, stderr=log)
    import rospy
    try:
        wait_for_master(60.0)
        subprocess.check_call(["rosparam", "load", os.path.join(ROOT, "config", "default.yaml"), BACKEND])
        rospy.init_node("agnc_pgo_durability_test", anonymous=True, disable_signals=True)
        old_graph, new_graph = graphs(work)
        backend = Backend(executable, log)
        backend.pause(data=True)
        old, old_nodes = make_pair(backend, old_graph, os.path.join(work, "old.g2o"))
        new, new_nodes = make_pair(backend, new_graph, os.path.join(work, "new.g2o"))
        start = time.time()
        backend.save(filename=os.path.join(work, "timing.g2o"))
        save_seconds = time.time() - start
        backend.stop()
        print("[durability] a save of the 3500-node graph takes %.3f s; killing at uniform random moments "
              "in [0, %.3f] s after the call" % (save_seconds, 1.5 * save_seconds))

        rng = random.Random(a.seed)
        path = os.path.join(work, "map.g2o")
        destroyed, outcomes, killed_during = 0, {}, 0
        for trial in range(a.trials):
            for suffix, content in (("", old[0]), (".meta", old[1])):
                with open(path + suffix, "wb") as f:
                    f.write(content)
            for leftover in (path + ".saving", path + ".meta.saving"):
                if os.path.exists(leftover):
                    os.unlink(leftover)
            backend = Backend(executable, log)
            backend.pause(data=True)
            r = backend.load(filename=os.path.join(work, "new.g2o"))
            assert r.success, r.message
            answered = []
            caller = threading.Thread(target=lambda: answered.append(call_quietly(backend.save, path)))
            delay = rng.uniform(0.0, 1.5 * save_seconds)
            caller.start()
            time.sleep(delay)
            backend.kill()
            caller.join(30)
            if not answered or not answered[0]:
                killed_during += 1
            state = classify(path, old, new)
            outcomes[state] = outcomes.get(state, 0) + 1
            # Whatever is left loads completely or is refused.
            checker = Backend(executable, log)
            r = checker.load(filename=path)
            ok = state is not None and r.success and nodes_of(r.message) in (old_nodes, new_nodes)
            partial = []
            if os.path.exists(path + ".saving"):
                staged = checker.load(filename=path + ".saving")
                if staged.success and nodes_of(staged.message) != new_nodes:
                    partial.append(staged.message)
            checker.stop()
            if not ok or partial:
                destroyed += 1
            print("[durability] trial %2d: kill after %.3f s -> %s; load: %s%s" %
                  (trial + 1, delay, state or "DESTROYED", r.message if not r.success else "ok (%d nodes)" %
                   nodes_of(r.message), "; PARTIAL LOAD of leftovers: %s" % partial if partial else ""))
        print("[durability] %d trials, %d killed while the save was running, outcomes %s: "
              "%d destroyed the previous save" % (a.trials, killed_during, outcomes, destroyed))
        return 1 if destroyed else 0
    finally:
        rospy.signal_shutdown("done")
        core.send_signal(signal.SIGINT)
        try:
            core.wait(15)
        except subprocess.TimeoutExpired:
            core.kill()
        log.close()
        shutil.rmtree(work, ignore_errors=True)


def call_quietly(save, path):
    """True if the save answered success; False if it failed or the back-end died."""
    try:
        return save(filename=path).success
    except Exception:  # the back-end was killed mid-call
        return False


if __name__ == "__main__":
    sys.exit(main())
