#!/usr/bin/env python3
"""Runs the replay of several engines (commits) side by side on the README's speed inputs.

Each commit's `agnc_pgo_replay` is built in a git worktree under --work (Release, only that
target; a commit already built there is reused). Then every input is replayed --repeat times by
every engine, alternating the order from run to run so that a slow phase of the machine does
not fall on one engine, and the table prints the median runtime (the replay's own update time,
not the outlier-free reference it computes first) and the medians of the slowest update and of
the slowest first estimate, beside precision, recall and the ATE against the outlier-free
optimum of each engine. Needs ../shared (the README's inputs). Example:

    scripts/side_by_side.py 54dab8b 9dd308a HEAD

A commit named "." is the working tree's own build (build/devel/lib/agnc_pgo/agnc_pgo_replay).
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.normpath(os.path.join(REPO, "..", "shared"))
TOOL = os.path.join("build", "devel", "lib", "agnc_pgo", "agnc_pgo_replay")


# Hidden: each worktree is a copy of this package, and roslaunch/rostest
# look for a launch or test file in every directory under the package's but
# hidden ones ("roslaunch agnc_pgo demo.launch" would find several).
DEFAULT_WORK = os.path.join(REPO, "build", ".side_by_side")

def inputs(shared):
    irl = os.path.join(shared, "irl")
    g2o = os.path.join(shared, "datasets")

    def injected(name, percent):
        return ["--input", os.path.join(g2o, name), "--outliers", str(percent), "--seed", "1"]

    return [
        ("`CSAIL_10_random_0.irl`", ["--input", os.path.join(irl, "CSAIL_10_random_0.irl")]),
        ("`INTEL_10_random_0.irl`", ["--input", os.path.join(irl, "INTEL_10_random_0.irl")]),
        ("`MANHATTAN_10_random_0.irl`", ["--input", os.path.join(irl, "MANHATTAN_10_random_0.irl")]),
        ("`MANHATTAN_50_random_0.irl`", ["--input", os.path.join(irl, "MANHATTAN_50_random_0.irl")]),
        ("kitti_00, 10 %", injected("kitti_00.g2o", 10)),
        ("kitti_05, 10 %", injected("kitti_05.g2o", 10)),
        ("M3500 g2o, 10 %", injected("manhattanOlson3500.g2o", 10)),
        ("M3500 g2o, 50 %", injected("manhattanOlson3500.g2o", 50)),
        ("Sphere2500 g2o, 10 %", injected("sphere2500.g2o", 10)),
    ]


def run(command, log):
    with open(log, "w") as out:
        if subprocess.run(command, stdout=out, stderr=subprocess.STDOUT).returncode != 0:
            sys.exit(f"side_by_side: {' '.join(command)} failed; see {log}")


def build(commit, work):
    """The replay binary of `commit`, built in a worktree of its own."""
    if commit == ".":
        tool = os.path.join(REPO, TOOL)
        if not os.access(tool, os.X_OK):
            sys.exit(f"side_by_side: {tool} not built (scripts/setup.sh builds it)")
        return tool
    sha = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", commit], check=True,
                         capture_output=True, text=True).stdout.strip()
    tree = os.path.join(work, sha)
    tool = os.path.join(tree, TOOL)
    if os.access(tool, os.X_OK):
        return tool
    if not os.path.isdir(tree):
        run(["git", "-C", REPO, "worktree", "add", "--detach", "-f", tree, sha], os.path.join(work, sha + ".log"))
    build_dir = os.path.join(tree, "build")
    os.makedirs(build_dir, exist_ok=True)
    print(f"building {commit} ({sha}) in {tree} ...", flush=True)
    run(["cmake", "-S", tree, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
         "-DPYTHON_EXECUTABLE=/usr/bin/python3", "-DPython3_EXECUTABLE=/usr/bin/python3"],
        os.path.join(build_dir, "configure.log"))
    run(["cmake", "--build", build_dir, "-j", str(os.cpu_count() or 2), "--target", "agnc_pgo_replay"],
        os.path.join(build_dir, "build.log"))
    return tool


def replay(tool, arguments):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([tool] + arguments + ["--quiet", "--output", out], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(os.path.join(out, "metrics.json")) as f:
            return json.load(f)


def median(runs, key):
    values = [r[key] for r in runs if isinstance(r.get(key), (int, float))]
    return statistics.median(values) if values else None


def cell(value, unit, digits):
    return "–" if value is None else f"{value:.{digits}f} {unit}"


def run_order(engines, repeat):
    """Every other repeat runs the engines in reverse, so no engine always runs first."""
    return engines if repeat % 2 == 0 else engines[::-1]


def table_row(name, commits, runs):
    """The cells of one input's row: `runs` maps each commit to its runs' metrics.json."""
    runtimes = [median(runs[c], "runtime_s") for c in commits]
    ratios = [f"{runtimes[-1] / r:.2f}" if r and runtimes[-1] is not None else "–" for r in runtimes[:-1]]
    slowest = " / ".join(cell(median(runs[c], "update_ms_max"), "", 0).strip() for c in commits) + " ms"
    last = runs[commits[-1]]
    first = cell(median(last, "first_estimate_ms_max"), "ms", 0)
    quality = f"{last[0]['precision']:.3f} / {last[0]['recall']:.3f}"
    ate = " / ".join(cell(runs[c][0].get("ate_vs_inlier_optimum_m"), "", 4).strip() for c in commits)
    return [name] + [cell(r, "s", 3) for r in runtimes] + ratios + [slowest, first, quality, ate]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("commits", nargs="+", help="commits to compare ('.' = this working tree's build)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per engine and input (default 3)")
    parser.add_argument("--work", default=DEFAULT_WORK,
                        help="worktrees of the commits (default build/.side_by_side/)")
    parser.add_argument("--shared", default=SHARED, help="the shared datasets (default ../shared)")
    parser.add_argument("--filter", default="", help="regular expression on the input names (default: all)")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")
    if not os.path.isdir(args.shared):
        parser.error(f"no shared datasets at {args.shared}")
    os.makedirs(args.work, exist_ok=True)
    engines = [(commit, build(commit, args.work)) for commit in args.commits]

    header = ["input"] + [f"{c} runtime" for c, _ in engines] + [f"÷ {c}" for c, _ in engines[:-1]] + \
             ["slowest update " + " / ".join(c for c, _ in engines), "slowest first estimate", "P / R",
              "ATE vs optimum m"]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for name, arguments in inputs(args.shared):
        if not re.search(args.filter, name):
            continue
        runs = {commit: [] for commit, _ in engines}
        for repeat in range(args.repeat):
            for commit, tool in run_order(engines, repeat):
                runs[commit].append(replay(tool, arguments))
        row = table_row(name, [c for c, _ in engines], runs)
        print("| " + " | ".join(row) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
