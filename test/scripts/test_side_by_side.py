"""Tests of scripts/side_by_side.py: the table says what the runs measured.

The rows are computed from metrics.json dictionaries as the replay writes them, so the tests
feed such dictionaries directly; building and replaying commits is what the script's users run.
"""

import contextlib
import importlib.util
import io
import os
import tempfile
import unittest

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(REPO, "scripts", "side_by_side.py")

spec = importlib.util.spec_from_file_location("side_by_side", SCRIPT)
side_by_side = importlib.util.module_from_spec(spec)
spec.loader.exec_module(side_by_side)


def metrics(runtime, slowest, first=None, precision=1.0, recall=1.0, ate=0.01):
    m = {"runtime_s": runtime, "update_ms_max": slowest, "precision": precision, "recall": recall,
         "ate_vs_inlier_optimum_m": ate}
    if first is not None:  # engines before the anytime estimate do not write it
        m["first_estimate_ms_max"] = first
    return m


class TableRow(unittest.TestCase):
    def test_medians_and_ratios_of_the_last_engine_to_each_earlier_one(self):
        runs = {
            "old": [metrics(4.0, 70), metrics(2.0, 50), metrics(3.0, 60)],
            "new": [metrics(1.0, 40, first=30, recall=0.97, ate=0.05), metrics(1.5, 20, first=10),
                    metrics(9.0, 90, first=80)],
        }
        row = side_by_side.table_row("M3500 g2o, 10 %", ["old", "new"], runs)
        self.assertEqual(row, ["M3500 g2o, 10 %", "3.000 s", "1.500 s", "0.50", "60 / 40 ms", "30 ms",
                               "1.000 / 0.970", "0.0100 / 0.0500"])

    def test_a_metric_an_engine_did_not_write_is_a_dash(self):
        runs = {"old": [metrics(2.0, 10)], "new": [metrics(1.0, 5)]}
        runs["new"][0]["ate_vs_inlier_optimum_m"] = None  # the replay writes a non-finite value as null
        row = side_by_side.table_row("kitti_00, 10 %", ["old", "new"], runs)
        self.assertEqual(row[4:], ["10 / 5 ms", "–", "1.000 / 1.000", "0.0100 / –"])

    def test_the_order_alternates_so_no_engine_always_runs_first(self):
        engines = [("a", "tool_a"), ("b", "tool_b"), ("c", "tool_c")]
        self.assertEqual([c for c, _ in side_by_side.run_order(engines, 0)], ["a", "b", "c"])
        self.assertEqual([c for c, _ in side_by_side.run_order(engines, 1)], ["c", "b", "a"])
        self.assertEqual([c for c, _ in side_by_side.run_order(engines, 2)], ["a", "b", "c"])


class Worktrees(unittest.TestCase):
    def test_the_default_worktrees_are_hidden_from_roslaunch(self):
        # roslaunch and rostest resolve "agnc_pgo demo.launch" by walking every
        # directory under the package except hidden ones: a visible worktree
        # (a copy of the package) made `scripts/demo.sh` fail with "multiple
        # files named [demo.launch]".
        relative = os.path.relpath(side_by_side.DEFAULT_WORK, REPO)
        self.assertFalse(relative.startswith(".."), relative)
        self.assertTrue(any(part.startswith(".") for part in relative.split(os.sep)), relative)


class Arguments(unittest.TestCase):
    def refused(self, argv):
        with contextlib.redirect_stderr(io.StringIO()) as err, self.assertRaises(SystemExit) as exit_:
            side_by_side.main(argv)
        self.assertEqual(exit_.exception.code, 2)
        return err.getvalue()

    def test_a_repeat_below_one_is_refused_before_anything_is_built(self):
        with tempfile.TemporaryDirectory() as work:
            self.assertIn("--repeat must be at least 1", self.refused(["HEAD", "--repeat", "0", "--work", work]))
            self.assertEqual(os.listdir(work), [])

    def test_missing_shared_datasets_are_named(self):
        with tempfile.TemporaryDirectory() as work:
            missing = os.path.join(work, "no_shared_here")
            self.assertIn(f"no shared datasets at {missing}",
                          self.refused(["HEAD", "--shared", missing, "--work", work]))

    def test_every_input_names_a_file_under_the_shared_directory(self):
        shared = os.path.join("..", "shared")
        for name, arguments in side_by_side.inputs(shared):
            path = arguments[arguments.index("--input") + 1]
            self.assertTrue(path.startswith(shared + os.sep), name)


if __name__ == "__main__":
    unittest.main()
