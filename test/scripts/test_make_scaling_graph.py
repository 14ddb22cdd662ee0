"""Tests of scripts/make_scaling_graph.py: the graphs are what they claim.

Reads the written files with a parser of its own (not the generator's
helpers) and checks them against their ground truth: the noise matches the
information, loop closures are genuine revisits, the drift world drifts, and
the output is a pure function of the arguments.
"""

import hashlib
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GENERATOR = os.path.join(REPO, "scripts", "make_scaling_graph.py")

# A small drift graph (2500 poses, 3 revisits, 62 loop closures) and its
# defaults as the generator's --help states them.
DRIFT_ARGS = ["--world", "drift", "--poses", "2500", "--seed", "4"]
MIN_GAP, LOOP_RADIUS, LOOP_ANGLE, LOOP_EVERY = 300, 2.0, math.radians(30), 5


def generate(out, args):
    subprocess.run([sys.executable, GENERATOR, "--out", out, *args], check=True, stdout=subprocess.DEVNULL)


def read_g2o(path):
    """({id: (x, y, theta)}, [(i, j, (dx, dy, dtheta), 3x3 information)], tags)."""
    vertices, edges, tags = {}, [], set()
    with open(path) as f:
        for line in f:
            fields = line.split()
            tags.add(fields[0])
            numbers = [float(v) for v in fields[1:]]
            if fields[0] == "VERTEX_SE2":
                vertices[int(numbers[0])] = tuple(numbers[1:4])
            elif fields[0] == "EDGE_SE2":
                a, b, c, d, e, g = numbers[5:11]
                info = np.array([[a, b, c], [b, d, e], [c, e, g]])
                edges.append((int(numbers[0]), int(numbers[1]), tuple(numbers[2:5]), info))
    return vertices, edges, tags


def matrix(x, y, theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def residual(truth, i, j, z):
    """Log-free SE(2) error of measurement z at the true poses (small angles)."""
    error = np.linalg.solve(matrix(*z), np.linalg.solve(matrix(*truth[i]), matrix(*truth[j])))
    return np.array([error[0, 2], error[1, 2], math.atan2(error[1, 0], error[0, 0])])


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class DriftWorld(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        generate(cls.tmp.name, DRIFT_ARGS)
        stem = os.path.join(cls.tmp.name, "drift2d_2500_seed4")
        cls.graph_path, cls.gt_path = stem + ".g2o", stem + "_gt.g2o"
        cls.initial, cls.edges, _ = read_g2o(cls.graph_path)
        cls.truth, gt_edges, cls.gt_tags = read_g2o(cls.gt_path)
        cls.gt_edges = gt_edges
        cls.odometry = [e for e in cls.edges if e[1] == e[0] + 1]
        cls.loops = [e for e in cls.edges if e[1] != e[0] + 1]

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_ground_truth_is_vertices_only_with_the_graphs_ids(self):
        self.assertEqual(self.gt_tags, {"VERTEX_SE2"})
        self.assertEqual(self.gt_edges, [])
        self.assertEqual(sorted(self.truth), list(range(2500)))
        self.assertEqual(sorted(self.initial), sorted(self.truth))

    def test_odometry_is_one_chain(self):
        self.assertEqual([(i, j) for i, j, *_ in self.odometry], [(k, k + 1) for k in range(2499)])

    def test_noise_matches_the_information(self):
        # At the ground truth, r^T I r per degree of freedom averages 1 when
        # the information is the true one (6 000+ dof: 1 +- 0.02 for odometry).
        for edges, tolerance in ((self.odometry, 0.06), (self.loops, 0.35)):
            chi2 = [residual(self.truth, i, j, z) @ info @ residual(self.truth, i, j, z) for i, j, z, info in edges]
            self.assertAlmostEqual(np.mean(chi2) / 3, 1.0, delta=tolerance)

    def test_loop_closures_are_genuine_revisits_after_long_excursions(self):
        self.assertEqual(len(self.loops), 62)
        newer = []
        for j, i, _, _ in self.loops:
            self.assertGreaterEqual(i - j, MIN_GAP)
            a, b = self.truth[j], self.truth[i]
            self.assertLess(math.hypot(a[0] - b[0], a[1] - b[1]), LOOP_RADIUS)
            self.assertLess(abs((a[2] - b[2] + math.pi) % (2 * math.pi) - math.pi), LOOP_ANGLE)
            newer.append(i)
        self.assertTrue(all(b - a >= LOOP_EVERY for a, b in zip(newer, newer[1:])))
        self.assertGreater(np.median([i - j for j, i, *_ in self.loops]), 1000)

    def test_odometry_drifts_metres_before_the_revisits(self):
        def drift(k):
            return math.hypot(self.initial[k][0] - self.truth[k][0], self.initial[k][1] - self.truth[k][1])
        self.assertGreater(max(drift(i) for _, i, *_ in self.loops), 10.0)

    def test_poses_follow_the_car(self):
        # Forward motion of 0.6-1.0 m per pose, no sideways jump, smooth turns.
        for k in range(2499):
            dx, dy, dtheta = residual(self.truth, k, k + 1, (0.0, 0.0, 0.0))
            self.assertTrue(0.59 < dx < 1.01 and abs(dy) < 0.1 and abs(dtheta) < 0.2, (k, dx, dy, dtheta))

    def test_same_seed_same_files_other_seed_other_graph(self):
        with tempfile.TemporaryDirectory() as again:
            generate(again, DRIFT_ARGS)
            self.assertEqual(digest(os.path.join(again, "drift2d_2500_seed4.g2o")), digest(self.graph_path))
            self.assertEqual(digest(os.path.join(again, "drift2d_2500_seed4_gt.g2o")), digest(self.gt_path))
            generate(again, DRIFT_ARGS[:-1] + ["5"])
            self.assertNotEqual(digest(os.path.join(again, "drift2d_2500_seed5.g2o")), digest(self.graph_path))

    def test_rejects_3d_and_impossible_turns(self):
        for args in (["--dim", "3"], ["--turn-radius", "60"], ["--lane", "9"], ["--loop-every", "0"]):
            with tempfile.TemporaryDirectory() as out:
                proc = subprocess.run([sys.executable, GENERATOR, "--out", out, *DRIFT_ARGS, *args],
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                self.assertEqual(proc.returncode, 2, args)
                self.assertIn("error:", proc.stderr)
                self.assertEqual(os.listdir(out), [])


class GridWorld(unittest.TestCase):
    def test_grid_graph_is_unchanged(self):
        # Golden digests of the grid world the scaling benchmark uses (as
        # written before the drift world existed): its numbers stay comparable.
        with tempfile.TemporaryDirectory() as out:
            generate(out, ["--poses", "500", "--seed", "1"])
            self.assertEqual(digest(os.path.join(out, "grid2d_500_seed1.g2o"))[:16], "f4e90e413df9a2a0")
            self.assertEqual(digest(os.path.join(out, "grid2d_500_seed1_gt.g2o"))[:16], "f74b81af7e54d9b9")


if __name__ == "__main__":
    unittest.main()
