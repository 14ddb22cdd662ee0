#!/usr/bin/python3
"""Benchmark agnc_pgo with the replay tool (protocol: ../shared/ALGORITHM.md §5).

Runs build/devel/lib/agnc_pgo/agnc_pgo_replay over a set of cells -- an input
(riSAM .irl log, or g2o dataset with injected outliers), a seed and a
schedule -- and writes doc/benchmark.md (machine, commit, command, results
table, agnc/risam ratios) and PNG plots next to it:

  benchmark_latency.png   per-update latency against graph size, per dataset
  benchmark_runtime.png   total runtime per dataset, input and schedule
  scaling_latency.png     (--scaling) latency against size on large synthetic
                          grid graphs made by make_scaling_graph.py, with a
                          linear fit

Cells: every ../shared/irl/*.irl log (dataset and outlier rate from the name
in its first line) and the g2o datasets csail, intel, manhattanOlson3500,
sphere2500, kitti_00, kitti_05 and M3500b (Manhattan and M3500b with the
manhattanOlson3500_gt ground truth, Sphere2500 with its own) at 10/30/50 %
outliers for each --seeds value, and outlier-free where there is ground truth
and on the three drift graphs, times each --schedules value. Sphere2500 cells
run only with --sphere (about 9 minutes each). --quick keeps only the CSAIL
and Intel logs. The raw output of every run (metrics.json, latency.csv,
estimate.g2o, ...) stays in --work (default build/benchmark/).

--peers runs GTSAM beside agnc_pgo on the final graph of every input
(scripts/gtsam_peer.py, in a venv the benchmark makes with pip, default
build/peer_venv/, and a process of its own): batch GNC (GncLMOptimizer, TLS)
with its precision, recall, ATE and CPU time, and with --peers gnc,isam2 also
iSAM2 fed only the true loop closures (the speed floor of an exact
incremental solver). GTSAM is never a dependency of agnc_pgo itself.

Timings need a quiet machine: keep --jobs 1 for numbers you publish.
Needs only Python 3 with numpy and matplotlib (Debian's python3-matplotlib);
where perf stat can count (Debian's linux-perf, installed by benchmark.sh),
every run's user-space instructions are counted too: unlike the runtime, they
do not drift with the speed of a virtual machine.
"""

import argparse
import concurrent.futures
import dataclasses
import datetime
import glob
import json
import os
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from typing import List, Optional

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the backend)
from matplotlib import ticker  # noqa: E402

SCRIPTS = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(SCRIPTS)
SHARED = os.path.join(os.path.dirname(REPO), "shared")
DEFAULT_TOOL = os.path.join(REPO, "build", "devel", "lib", "agnc_pgo", "agnc_pgo_replay")
PEER_SCRIPT = os.path.join(SCRIPTS, "gtsam_peer.py")
DEFAULT_PEER_VENV = os.path.join(REPO, "build", "peer_venv")
PEERS = ("gnc", "isam2")

SCHEDULES = ("agnc", "agnc-fixed", "risam", "none")
OUTLIER_PERCENTS = (10, 30, 50)
# Dataset key -> (display name, g2o file, ground-truth file or None). The .irl
# logs of a dataset (named CSAIL_..., INTEL_..., MANHATTAN_..., SPHERE2500_...)
# are replays of the same graph, so they share its ground truth. kitti_00,
# kitti_05 and M3500b are the long-drift and heavy-noise graphs
# (../shared/datasets/README.md, "Drift and noise"); M3500b has the poses of
# M3500, hence its ground truth.
DATASETS = {
    "csail": ("CSAIL", "csail.g2o", None),
    "intel": ("Intel", "intel.g2o", None),
    "manhattan": ("Manhattan M3500", "manhattanOlson3500.g2o", "manhattanOlson3500_gt.g2o"),
    "sphere2500": ("Sphere2500", "sphere2500.g2o", "sphere2500_gt.g2o"),
    "kitti_00": ("KITTI 00", "kitti_00.g2o", None),
    "kitti_05": ("KITTI 05", "kitti_05.g2o", None),
    "m3500b": ("M3500b", "M3500b.g2o", "manhattanOlson3500_gt.g2o"),
}
# Datasets whose outlier-free cell is in the default set even without ground
# truth: on them today's engine loses true loop closures without any outlier.
OUTLIER_FREE_ALWAYS = ("kitti_00", "kitti_05", "m3500b")
QUICK_DATASETS = ("csail", "intel")
IRL_NAME = re.compile(r"^(?P<dataset>[A-Za-z0-9]+?)_(?P<percent>\d+)(?:_random_(?P<index>\d+))?$")
SCALING_OUTLIERS = 10
DASH = "–"


# --------------------------------------------------------------------------
# Cells
# --------------------------------------------------------------------------

@dataclasses.dataclass
class Cell:
    name: str                   # unique, used by --filter and as the run directory
    kind: str                   # "irl", "g2o" or "scaling"
    dataset: str                # display name of the dataset
    input: str                  # path of the .irl / .g2o file
    outliers: Optional[float]   # percent (None: unknown)
    seed: Optional[int]         # None: outliers fixed in the .irl file, or none injected
    schedule: str
    ground_truth: Optional[str] = None

    @property
    def label(self):
        return os.path.basename(self.input)

    @property
    def input_key(self):
        """Identifies the input of the cell independently of its schedule."""
        return (self.label, self.outliers, self.seed)

    def command(self, tool, out_dir):
        cmd = [tool, "--input", self.input, "--schedule", self.schedule, "--output", out_dir, "--quiet"]
        if self.kind != "irl":
            cmd += ["--outliers", f"{self.outliers:g}"]
        if self.kind != "irl" and self.seed is not None:
            cmd += ["--seed", str(self.seed)]
        if self.ground_truth:
            cmd += ["--ground-truth", self.ground_truth]
        return cmd


def irl_label(path):
    """(dataset key, display name, outlier percent) of a log: from the name in
    its first line (e.g. CSAIL_30_random_0); a bare name (CSAIL) gets the
    percent counted from its LOOP entries (0 for the outlier-free logs)."""
    with open(path) as f:
        name = f.readline().strip() or os.path.splitext(os.path.basename(path))[0]
    match = IRL_NAME.match(name)
    dataset = match["dataset"] if match else name
    percent = float(match["percent"]) if match else counted_outlier_percent(path)
    key = dataset.lower()
    return key, DATASETS[key][0] if key in DATASETS else dataset, percent


def counted_outlier_percent(path):
    """100 * outlier loops / loops (LOOP entries whose `correct` field is not 0)."""
    loops = outliers = 0
    with open(path) as f:
        for line in f:
            fields = line.split()
            if fields and fields[0] == "LOOP" and len(fields) > 2:
                loops += 1
                outliers += fields[2] != "0"
    return float(round(100.0 * outliers / loops)) if loops else None


def ground_truth_path(key):
    gt = DATASETS.get(key, (None, None, None))[2]
    path = gt and os.path.join(SHARED, "datasets", gt)
    return path if path and os.path.exists(path) else None


def irl_cells(schedules, quick):
    cells = []
    for path in sorted(glob.glob(os.path.join(SHARED, "irl", "*.irl"))):
        key, display, percent = irl_label(path)
        if quick and key not in QUICK_DATASETS:
            continue
        stem = os.path.splitext(os.path.basename(path))[0]
        for schedule in schedules:
            cells.append(Cell(f"irl/{stem}/{schedule}", "irl", display, path, percent, None, schedule,
                              ground_truth_path(key)))
    return cells


def g2o_cells(schedules, seeds):
    """Every g2o dataset at every outlier rate and seed; a dataset with ground
    truth (or in OUTLIER_FREE_ALWAYS) also outlier-free."""
    cells = []
    for key, (display, g2o, gt) in DATASETS.items():
        path = os.path.join(SHARED, "datasets", g2o)
        if not os.path.exists(path):
            continue
        if gt or key in OUTLIER_FREE_ALWAYS:
            for schedule in schedules:
                cells.append(Cell(f"g2o/{key}/0pct/{schedule}", "g2o", display, path, 0.0, None, schedule,
                                  ground_truth_path(key)))
        for percent in OUTLIER_PERCENTS:
            for seed in seeds:
                for schedule in schedules:
                    cells.append(Cell(f"g2o/{key}/{percent}pct/seed{seed}/{schedule}", "g2o", display, path,
                                      float(percent), seed, schedule, ground_truth_path(key)))
    return cells


def scaling_cells(args):
    """Generates the synthetic graphs (make_scaling_graph.py); returns their
    cells and the generator's summaries."""
    sys.path.insert(0, SCRIPTS)
    sys.dont_write_bytecode = True  # no __pycache__ in scripts/
    import make_scaling_graph  # a sibling script

    cells, graphs = [], []
    for dim, poses in ((2, args.scaling_poses_2d), (3, args.scaling_poses_3d)):
        if not poses:
            continue
        options = make_scaling_graph.parse_arguments(
            ["--dim", str(dim), "--poses", str(poses), "--seed", "1", "--out", args.scaling_dir])
        graph, gt, summary = make_scaling_graph.generate(options)
        graphs.append(summary)
        print(f"generated {shown_path(graph)}: {summary['poses']} poses, {summary['loops']} loop "
              f"closures ({summary['loops_per_pose']:.2f}/pose)", flush=True)
        for seed in args.seeds:
            for schedule in args.schedules:
                cells.append(Cell(f"scaling/{summary['name']}/{SCALING_OUTLIERS}pct/seed{seed}/{schedule}",
                                  "scaling", f"grid {dim}D, {poses} poses", graph, float(SCALING_OUTLIERS),
                                  seed, schedule, gt))
    return cells, graphs


def select_cells(args):
    """The cells to run (after --filter) and the synthetic graphs made for them."""
    cells, graphs = irl_cells(args.schedules, args.quick), []
    if not args.quick:
        cells += g2o_cells(args.schedules, args.seeds)
    if args.scaling:
        scaling, graphs = scaling_cells(args)
        cells += scaling
    if not args.sphere:
        # SE(3) Sphere2500 takes ~9 min per cell on 2 cores: opt-in, so the
        # default set stays under 15 minutes.
        cells = [c for c in cells if "sphere" not in c.name.lower()]
    if args.filter:
        pattern = re.compile(args.filter)
        cells = [c for c in cells if pattern.search(c.name)]
    return cells, graphs


# --------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------

@dataclasses.dataclass
class Result:
    cell: Cell
    status: str                       # "ok", "timeout" or "failed: ..."
    metrics: Optional[dict] = None    # metrics.json of the median-runtime run
    runtimes: List[float] = dataclasses.field(default_factory=list)
    run_dir: Optional[str] = None     # directory of that run (latency.csv, ...)
    deterministic: bool = True        # same solves/steps/P/R in every repeat
    peer: Optional[dict] = None       # gtsam_peer.py's report on that run's final graph
    peer_status: Optional[str] = None  # None: no peer ran; "ok", "timeout" or "failed: ..."

    @property
    def ok(self):
        return self.status == "ok"

    @property
    def runtime(self):
        return statistics.median(self.runtimes) if self.runtimes else None


def perf_command(output):
    """perf stat counting the user-space instructions of a command into `output`
    (the one measure of work that the VM's speed drift does not touch)."""
    return ["perf", "stat", "-x,", "-e", "instructions:u", "-o", output, "--"]


def read_instructions(path):
    """The instruction count perf stat -x, wrote, or None."""
    try:
        with open(path) as f:
            for line in f:
                fields = line.strip().split(",")
                if len(fields) > 2 and fields[2].startswith("instructions") and fields[0].isdigit():
                    return int(fields[0])
    except OSError:
        pass
    return None


def perf_available():
    """Whether perf stat can count instructions here (not on every VM)."""
    if shutil.which("perf") is None:
        return False
    with tempfile.TemporaryDirectory() as tmp:
        output = os.path.join(tmp, "perf.csv")
        try:
            subprocess.run(perf_command(output) + ["true"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           timeout=30)
        except (OSError, subprocess.TimeoutExpired):
            return False
        return read_instructions(output) is not None


def run_once(cell, tool, run_dir, timeout, count_instructions=False):
    """One replay; returns (metrics dict, None) or (None, error status). With
    count_instructions, metrics gets "instructions" (whole process: reading,
    the reference optimum and the replay)."""
    shutil.rmtree(run_dir, ignore_errors=True)
    os.makedirs(run_dir)
    perf_output = os.path.join(run_dir, "perf.csv")
    command = cell.command(tool, run_dir)
    if count_instructions:
        command = perf_command(perf_output) + command
    try:
        proc = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"timeout ({timeout:g} s)"
    if proc.returncode != 0:
        message = (proc.stderr.strip().splitlines() or [f"exit code {proc.returncode}"])[-1]
        return None, f"failed: {message}"
    try:
        with open(os.path.join(run_dir, "metrics.json")) as f:
            metrics = json.load(f)
    except (OSError, ValueError) as e:
        return None, f"failed: unreadable metrics.json ({e})"
    if count_instructions:
        metrics["instructions"] = read_instructions(perf_output)
    return metrics, None


def run_cell(cell, args):
    cell_dir = os.path.join(args.work, cell.name)
    runs = []
    for k in range(args.repeat):
        run_dir = os.path.join(cell_dir, f"run{k + 1}")
        metrics, error = run_once(cell, args.tool, run_dir, args.timeout, args.count_instructions)
        if error:
            return Result(cell, error)
        runs.append((metrics, run_dir))
    median = statistics.median(m["runtime_s"] for m, _ in runs)
    metrics, run_dir = min(runs, key=lambda r: abs(r[0]["runtime_s"] - median))
    signature = {tuple(m.get(k) for k in ("solves", "gnc_steps", "precision", "recall")) for m, _ in runs}
    result = Result(cell, "ok", metrics, [m["runtime_s"] for m, _ in runs], run_dir, len(signature) == 1)
    if cell.name in args.peer_cells:
        result.peer, result.peer_status = run_peer(cell, run_dir, args)
    return result


# --------------------------------------------------------------------------
# GTSAM peers (--peers): a venv of their own, a process of their own
# --------------------------------------------------------------------------

def peer_cells(cells, peers):
    """Names of the cells whose final graph the peers solve: one cell per
    input (the schedules of an input replay the same graph)."""
    if not peers:
        return set()
    first = {}
    for cell in cells:
        first.setdefault(cell.input_key, cell.name)
    return set(first.values())


def peer_venv_python(venv):
    """The python of the peers' venv, made on first use (python3 -m venv, pip
    install gtsam numpy from PyPI). GTSAM is a benchmark peer only: nothing
    of agnc_pgo's build or tests needs it. Raises RuntimeError saying why."""
    python = os.path.join(venv, "bin", "python")

    def has_gtsam():
        return os.access(python, os.X_OK) and subprocess.run(
            [python, "-c", "import gtsam, numpy"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode == 0

    if has_gtsam():
        return python
    print(f"making the GTSAM peer venv {shown_path(venv)} (python3 -m venv; pip install gtsam numpy)", flush=True)
    for command in ([sys.executable, "-m", "venv", venv],
                    [python, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "gtsam", "numpy"]):
        proc = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if proc.returncode != 0:
            last = (proc.stdout.strip().splitlines() or [f"exit code {proc.returncode}"])[-1]
            raise RuntimeError(f"{' '.join(command[:3])} ... failed: {last}")
    if not has_gtsam():
        raise RuntimeError(f"{shown_path(venv)}: gtsam does not import after pip install")
    return python


def run_peer(cell, run_dir, args):
    """gtsam_peer.py on a replay's output: (report dict, "ok") or (None, why not)."""
    output = os.path.join(run_dir, "peer.json")
    command = [args.peer_python, PEER_SCRIPT, "--run", run_dir, "--output", output]
    if cell.ground_truth:
        command += ["--ground-truth", cell.ground_truth]
    if "isam2" in args.peers:
        command.append("--isam2")
    try:
        proc = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              timeout=args.timeout)
    except subprocess.TimeoutExpired:
        return None, f"timeout ({args.timeout:g} s)"
    if proc.returncode != 0:
        return None, "failed: " + (proc.stderr.strip().splitlines() or [f"exit code {proc.returncode}"])[-1]
    try:
        with open(output) as f:
            return json.load(f), "ok"
    except (OSError, ValueError) as e:
        return None, f"failed: unreadable peer.json ({e})"


class Progress:
    """One line per cell: name, runtime, precision, recall."""

    def __init__(self, total, width):
        self.total, self.width, self.done = total, width, 0
        self.lock = threading.Lock()

    def report(self, result):
        with self.lock:
            self.done += 1
            head = f"[{self.done:{len(str(self.total))}d}/{self.total}] {result.cell.name:<{self.width}}"
            if result.ok:
                m = result.metrics
                note = "" if result.deterministic else "  (repeats differ in solves/steps/P/R)"
                print(f"{head} {result.runtime:9.2f} s  P {fmt(m.get('precision'), 3)}  "
                      f"R {fmt(m.get('recall'), 3)}{note}{peer_note(result)}", flush=True)
            else:
                print(f"{head} {result.status}", flush=True)


def peer_note(result):
    if result.peer_status is None:
        return ""
    if result.peer is None:
        return f"  | GTSAM: {result.peer_status}"
    p = result.peer
    return (f"  | GTSAM GNC {fmt(p.get('gnc_cpu_s'), 2)} s CPU  P {fmt(p.get('gnc_precision'), 3)}  "
            f"R {fmt(p.get('gnc_recall'), 3)}")


def run_all(cells, args):
    """Runs the cells, --jobs at a time; results in the order of the cells."""
    progress = Progress(len(cells), max(len(c.name) for c in cells))
    results = [None] * len(cells)
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs)
    try:
        futures = {pool.submit(run_cell, cell, args): i for i, cell in enumerate(cells)}
        for future in concurrent.futures.as_completed(futures):
            result = future.result()
            progress.report(result)
            results[futures[future]] = result
    finally:  # on Ctrl-C: start no further cell (the running replays get the SIGINT too)
        pool.shutdown(wait=True, cancel_futures=True)
    return results


# --------------------------------------------------------------------------
# Report: header, tables
# --------------------------------------------------------------------------

def fmt(value, digits):
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return DASH
    return f"{value:.{digits}f}"


def count(metrics, key):
    value = metrics.get(key)
    return DASH if value is None else str(value)


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def git_commit():
    def git(*argv):
        return subprocess.run(["git", "-C", REPO, *argv], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                              text=True).stdout.strip()
    commit = git("rev-parse", "--short", "HEAD") or "unknown"
    # The reports of earlier runs (doc/) do not change what ran.
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)doc")
    return commit + (" (working tree has uncommitted changes)" if dirty else "")


def reproduce_command():
    """The command line that reproduces this run (set by benchmark.sh when used)."""
    wrapper = os.environ.get("AGNC_BENCHMARK_COMMAND")
    if wrapper:
        return wrapper
    return "/usr/bin/python3 scripts/benchmark.py" + "".join(" " + shlex.quote(a) for a in sys.argv[1:])


def shown_path(path):
    """A path inside the repository relative to it; outside it, the file name only
    (the report must not carry the paths of one machine)."""
    relative = os.path.relpath(os.path.abspath(path), REPO)
    return os.path.basename(path) if relative.startswith("..") else relative


def header(args, started, load_before):
    load_after = os.getloadavg()
    built = datetime.datetime.fromtimestamp(os.path.getmtime(args.tool), datetime.timezone.utc)
    lines = [
        "# agnc_pgo benchmark",
        "",
        "Generated by `scripts/benchmark.py` (protocol: `../shared/ALGORITHM.md` §5). Do not edit by hand.",
        "",
        f"- Machine: {len(os.sched_getaffinity(0))} CPUs (nproc), {cpu_model()}",
        f"- Date: {started:%Y-%m-%d %H:%M} UTC",
        f"- Git commit: {git_commit()}",
        f"- Tool: `{shown_path(args.tool)}` (built {built:%Y-%m-%d %H:%M} UTC)",
        f"- Command: `{reproduce_command()}`",
        f"- Runs: {args.repeat} per cell (runtime = median), {args.jobs} at a time"
        + ("" if args.jobs == 1 else " (parallel runs: timings are not comparable to serial ones)")
        + f"; load average before/after: {load_before[0]:.2f} / {load_after[0]:.2f}",
    ]
    return lines


RESULT_COLUMNS = ("input", "outliers %", "seed", "schedule", "runtime s (median)", "solves", "GNC steps",
                  "instructions G",
                  "precision", "recall", "ATE m", "ATE vs outlier-free optimum m", "p50 update ms",
                  "p95 update ms", "max update ms", "peak RSS MB")


def result_row(r):
    c = r.cell
    head = [f"`{c.label}`", fmt(c.outliers, 0), DASH if c.seed is None else str(c.seed), c.schedule]
    if not r.ok:
        return head + [r.status] + [""] * (len(RESULT_COLUMNS) - len(head) - 1)
    m = r.metrics
    return head + [fmt(r.runtime, 3) + ("" if r.deterministic else "*"), count(m, "solves"),
                   count(m, "gnc_steps"), fmt(giga(m.get("instructions")), 2), fmt(m.get("precision"), 3), fmt(m.get("recall"), 3),
                   fmt(m.get("ate_m"), 3), fmt(m.get("ate_vs_inlier_optimum_m"), 3),
                   fmt(m.get("update_ms_p50"), 1), fmt(m.get("update_ms_p95"), 1),
                   fmt(m.get("update_ms_max"), 1), fmt(m.get("peak_rss_mb"), 1)]


def markdown_table(columns, rows):
    lines = ["| " + " | ".join(columns) + " |", "|" + "|".join("---" for _ in columns) + "|"]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def results_section(results):
    if not results:
        return ["No cell ran."]
    lines = markdown_table(RESULT_COLUMNS, [result_row(r) for r in results])
    notes = [
        "",
        "Seed `–`: the outliers are fixed in the `.irl` file (riSAM's generator), or there are none; `.g2o` "
        "inputs get outliers "
        "injected by the tool with the given seed. ATE: after rigid alignment to the shipped ground truth "
        "(`_gt` files), `–` where none is shipped. Update latencies are per loop-closure update "
        "(`latency.csv`).",
    ]
    if any(r.ok and not r.deterministic for r in results):
        notes.append("`*`: the repeats of this cell differ in solves, GNC steps, precision or recall.")
    return lines + notes


def giga(value):
    return None if value is None else value / 1e9


def ratio(a, b):
    return a / b if a is not None and b else float("nan")


def ratio_section(results):
    """Per input: agnc/risam runtime, instruction and GNC-step ratios; then
    per dataset, their geometric means over its inputs."""
    by_input, dataset_of = {}, {}
    for r in results:
        if r.ok:
            by_input.setdefault(r.cell.input_key, {})[r.cell.schedule] = r
            dataset_of[r.cell.input_key] = (r.cell.dataset, r.cell.kind)
    rows, per_dataset = [], {}
    for key, runs in by_input.items():
        if "agnc" not in runs or "risam" not in runs:
            continue
        a, b = runs["agnc"], runs["risam"]
        ratios = (ratio(a.runtime, b.runtime),
                  ratio(a.metrics.get("instructions"), b.metrics.get("instructions")),
                  ratio(a.metrics.get("gnc_steps"), b.metrics.get("gnc_steps")))
        per_dataset.setdefault(dataset_of[key], []).append(ratios)
        label, outliers, seed = key
        rows.append([f"`{label}`", fmt(outliers, 0), DASH if seed is None else str(seed),
                     fmt(a.runtime, 3), fmt(b.runtime, 3), fmt(ratios[0], 2), fmt(ratios[1], 2),
                     count(a.metrics, "gnc_steps"), count(b.metrics, "gnc_steps"), fmt(ratios[2], 2)])
    if not rows:
        return ["Needs both the `agnc` and the `risam` schedule on the same input."]
    columns = ("input", "outliers %", "seed", "agnc s", "risam s", "runtime agnc/risam",
               "instructions agnc/risam", "agnc GNC steps", "risam GNC steps", "GNC steps agnc/risam")
    summary_columns = ("dataset", "input", "inputs", "runtime agnc/risam (geo. mean)", "runtime worst",
                       "instructions agnc/risam (geo. mean)", "instructions worst",
                       "GNC steps agnc/risam (geo. mean)", "GNC steps worst")
    summary = []
    for (dataset, kind), values in per_dataset.items():
        columns_of = list(zip(*values))
        cells = [dataset, kind, str(len(values))]
        for k in range(3):
            finite = [v for v in columns_of[k] if np.isfinite(v)]
            cells += [fmt(geometric_mean(columns_of[k]), 2), fmt(max(finite) if finite else None, 2)]
        summary.append(cells)
    return (markdown_table(columns, rows)
            + ["", "Per dataset (every input and seed of it):", ""]
            + markdown_table(summary_columns, summary)
            + ["", "Ratios below 1: `agnc` needs less than `risam`. Instructions: user-space instructions of "
               "the whole process (perf stat; `–` where perf cannot count), reading and the reference optimum "
               "included, which both schedules share; unlike the runtime they do not drift with the VM."])


def accuracy_section(results):
    """The g2o cells per dataset, outlier rate and schedule over their seeds
    (the acceptance matrix of the core issue), then agnc/risam per dataset and
    outlier rate."""
    groups, reference = {}, {}
    for r in results:
        if r.ok and r.cell.kind == "g2o":
            groups.setdefault((r.cell.dataset, r.cell.outliers, r.cell.schedule), []).append(r)
            if r.cell.outliers == 0:
                reference[(r.cell.dataset, r.cell.schedule)] = r.metrics.get("ate_m")
    if not groups:
        return []
    rows = []
    for (dataset, outliers, schedule), runs in groups.items():
        metrics = [r.metrics for r in runs]
        ates = [m["ate_m"] for m in metrics if m.get("ate_m") is not None]
        ate = max(ates) if ates else None
        free = reference.get((dataset, schedule))
        change = f"{100 * (ate / free - 1):+.1f} %" if ate is not None and free and outliers else DASH
        seeds = ",".join(DASH if r.cell.seed is None else str(r.cell.seed) for r in runs)
        rows.append([dataset, fmt(outliers, 0) + " %", schedule, seeds,
                     fmt(min(m["precision"] for m in metrics), 3), fmt(min(m["recall"] for m in metrics), 3),
                     fmt(ate, 3), change, fmt(max(m["ate_vs_inlier_optimum_m"] for m in metrics), 3),
                     fmt(statistics.median(r.runtime for r in runs), 2),
                     fmt(max(m.get("update_ms_max") or 0.0 for m in metrics), 1),
                     fmt(statistics.median(m["gnc_steps"] for m in metrics), 0)])
    columns = ("dataset", "outliers", "schedule", "seeds", "precision (min)", "recall (min)", "ATE m (max)",
               "ATE vs outlier-free run", "ATE vs outlier-free optimum m (max)", "runtime s (median)",
               "slowest update ms (max)", "GNC steps (median)")
    ratio_rows = []
    for (dataset, outliers, schedule), runs in groups.items():
        if schedule != "agnc" or not outliers:
            continue
        risam = {r.cell.seed: r for r in groups.get((dataset, outliers, "risam"), [])}
        pairs = [(a, risam[a.cell.seed]) for a in runs if a.cell.seed in risam]
        if not pairs:
            continue
        cells = [dataset, fmt(outliers, 0) + " %", str(len(pairs))]
        for measure in (lambda r: r.runtime, lambda r: r.metrics.get("instructions"),
                        lambda r: r.metrics.get("gnc_steps")):
            values = [v for v in (ratio(measure(a), measure(b)) for a, b in pairs) if np.isfinite(v)]
            cells.append(f"{statistics.median(values):.2f}, {max(values):.2f}" if values else DASH)
        ratio_rows.append(cells)
    ratio_columns = ("dataset", "outliers", "seeds", "runtime agnc/risam (median, worst)",
                     "instructions agnc/risam (median, worst)", "GNC steps agnc/risam (median, worst)")
    return (markdown_table(columns, rows)
            + ["", "ATE against the shipped ground truth (`–` where none is shipped), worst seed; \"vs "
               "outlier-free run\": against the same schedule's run without outliers.", ""]
            + markdown_table(ratio_columns, ratio_rows))


PEER_COLUMNS = ("input", "outliers %", "seed", "schedule", "agnc_pgo precision", "agnc_pgo recall",
                "agnc_pgo ATE m", "agnc_pgo ATE vs optimum m", "agnc_pgo ATE vs peer's optimum m",
                "agnc_pgo runtime s", "agnc_pgo max update ms", "GNC precision", "GNC recall", "GNC ATE m",
                "GNC ATE vs peer's optimum m", "GNC CPU s", "GNC CPU / agnc_pgo runtime",
                "peer's optimum χ² (start)")
ISAM2_COLUMNS = ("iSAM2 CPU s", "iSAM2 max update ms", "iSAM2 ATE vs peer's optimum m")


def optimum_note(peer):
    """The outlier-free optimum's χ², its start, and the starts that ended higher."""
    starts = peer.get("reference_chi2_by_start") or {}
    if not starts:
        return DASH
    best = min(starts, key=starts.get)
    worse = [f"{name} {value:.4g}" for name, value in starts.items()
             if value > starts[best] * (1 + 1e-6) + 1e-9]
    return f"{starts[best]:.4g} ({best}" + (f"; {', '.join(worse)}" if worse else "") + ")"


def peer_row(r, with_isam2):
    c, m, p = r.cell, r.metrics, r.peer
    row = [f"`{c.label}`", fmt(c.outliers, 0), DASH if c.seed is None else str(c.seed), c.schedule,
           fmt(m.get("precision"), 3), fmt(m.get("recall"), 3), fmt(m.get("ate_m"), 3),
           fmt(m.get("ate_vs_inlier_optimum_m"), 3)]
    if p is None:
        return row + [DASH, fmt(r.runtime, 3), fmt(m.get("update_ms_max"), 1), r.peer_status] \
            + [""] * (len(PEER_COLUMNS) + (len(ISAM2_COLUMNS) if with_isam2 else 0) - len(row) - 4)
    row += [fmt(p.get("replay_ate_vs_optimum_m"), 3), fmt(r.runtime, 3), fmt(m.get("update_ms_max"), 1),
            fmt(p.get("gnc_precision"), 3), fmt(p.get("gnc_recall"), 3),
            fmt(p.get("gnc_ate_vs_ground_truth_m"), 3), fmt(p.get("gnc_ate_vs_optimum_m"), 3),
            fmt(p.get("gnc_cpu_s"), 2), fmt(ratio(p.get("gnc_cpu_s"), r.runtime), 1), optimum_note(p)]
    if with_isam2:
        row += [fmt(p.get("isam2_cpu_s"), 2), fmt(p.get("isam2_update_ms_max"), 1),
                fmt(p.get("isam2_ate_vs_optimum_m"), 3)]
    return row


def peer_section(results, peers):
    ran = [r for r in results if r.ok and r.peer_status is not None]
    if not ran:
        return ["No peer ran."]
    with_isam2 = "isam2" in peers
    columns = PEER_COLUMNS + (ISAM2_COLUMNS if with_isam2 else ())
    versions = ordered(r.peer.get("gtsam_version", "unknown") for r in ran if r.peer)
    lines = markdown_table(columns, [peer_row(r, with_isam2) for r in ran])
    lines += ["", f"GTSAM {', '.join(versions) or 'unknown'} from PyPI, in its own venv and process "
              "(`scripts/gtsam_peer.py`), on the final graph of the agnc_pgo run beside it (its "
              "`estimate.g2o`: every odometry edge and loop closure, injected outliers included; labels from "
              "`loop_closures.csv`). GNC: `GncLMOptimizer`, TLS, default parameters, initialised by composing "
              "the odometry, prior on pose 0, prior and odometry known inliers; a loop closure is kept when "
              "its final weight is above 0.5. GNC CPU s: process CPU time of building and running the "
              "optimiser; agnc_pgo runtime: its total update time (one thread). \"optimum\": the replay's "
              "own outlier-free least-squares reference; \"peer's optimum\": GTSAM's Levenberg-Marquardt on "
              "the outlier-free graph from the odometry, from LAGO / chordal initialisation and from the "
              "ground truth, the lowest χ² (shown with its start, and the starts that ended higher: a local "
              "minimum). ATE m: against the shipped ground truth."]
    if with_isam2:
        lines += ["", "iSAM2: `gtsam.ISAM2`, default parameters, fed the true loop closures only, pose by pose "
                  "(its odometry, then the loop closures ending there), one update per pose; CPU time of the "
                  "updates and of reading the newest pose: the speed floor of an exact incremental solver "
                  "that is told which loop closures are true."]
    return lines


def geometric_mean(values):
    values = [v for v in values if np.isfinite(v) and v > 0]
    return float(np.exp(np.mean(np.log(values)))) if values else float("nan")


# --------------------------------------------------------------------------
# Plots
# --------------------------------------------------------------------------

def read_latency(result):
    """(poses, update_ms) arrays of a run's latency.csv."""
    path = os.path.join(result.run_dir, "latency.csv")
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError):
        return np.empty(0), np.empty(0)
    if data.size == 0:
        return np.empty(0), np.empty(0)
    return data[:, 0], data[:, 1]


def pooled_latency(results):
    poses, ms = zip(*(read_latency(r) for r in results)) if results else ((), ())
    poses = np.concatenate(poses) if poses else np.empty(0)
    ms = np.concatenate(ms) if ms else np.empty(0)
    order = np.argsort(poses, kind="stable")
    return poses[order], ms[order]


def binned_median(poses, ms, bins=30):
    """Median latency in equal-width graph-size bins: (bin centres, medians),
    only bins holding at least 3 updates."""
    edges = np.linspace(poses.min(), poses.max(), bins + 1)
    index = np.clip(np.digitize(poses, edges) - 1, 0, bins - 1)
    centres, medians = [], []
    for b in range(bins):
        mine = ms[index == b]
        if len(mine) >= 3:
            centres.append((edges[b] + edges[b + 1]) / 2)
            medians.append(np.median(mine))
    return np.array(centres), np.array(medians)


def ordered(values):
    return list(dict.fromkeys(values))


def plot_latency(results, path):
    """(a) per-update latency against graph size: one panel per schedule,
    one colour per dataset (all its inputs pooled), binned median on top."""
    ok = [r for r in results if r.ok]
    schedules = ordered(r.cell.schedule for r in ok)
    datasets = ordered(r.cell.dataset for r in ok)
    colours = dict(zip(datasets, plt.rcParams["axes.prop_cycle"].by_key()["color"] * 4))
    fig, axes = plt.subplots(1, len(schedules), figsize=(6 * len(schedules), 4.5), sharey=True, squeeze=False)
    for ax, schedule in zip(axes[0], schedules):
        for dataset in datasets:
            poses, ms = pooled_latency([r for r in ok if r.cell.schedule == schedule and r.cell.dataset == dataset])
            if not len(ms):
                continue
            ax.scatter(poses, ms, s=4, alpha=0.3, color=colours[dataset], linewidths=0)
            ax.plot(*binned_median(poses, ms), color=colours[dataset], lw=1.8, marker=".", label=dataset)
        plain_log_axis(ax)
        ax.set_title(f"schedule {schedule}")
        ax.set_xlabel("graph size (poses)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    axes[0][0].set_ylabel("update latency (ms)")
    fig.suptitle("Per-update latency of loop-closure updates (dots: updates of all inputs of a dataset, "
                 "lines: median per graph-size bin)")
    save(fig, path)


def plot_runtime(results, path):
    """(b) runtime per dataset and schedule: one panel per dataset, grouped
    bars (one group per input, one bar per schedule), values on the bars."""
    ok = [r for r in results if r.ok]
    datasets = ordered(r.cell.dataset for r in ok)
    schedules = ordered(r.cell.schedule for r in ok)
    colours = dict(zip(schedules, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    columns = min(2, len(datasets))
    rows = (len(datasets) + columns - 1) // columns
    fig, axes = plt.subplots(rows, columns, figsize=(7 * columns, 4 * rows), squeeze=False)
    for ax, dataset in zip(axes.flat, datasets):
        mine = [r for r in ok if r.cell.dataset == dataset]
        inputs = ordered(r.cell.input_key for r in mine)
        width = 0.8 / len(schedules)
        for s, schedule in enumerate(schedules):
            runtime = {r.cell.input_key: r.runtime for r in mine if r.cell.schedule == schedule}
            x = [i + (s - (len(schedules) - 1) / 2) * width for i, key in enumerate(inputs) if key in runtime]
            bars = ax.bar(x, [runtime[key] for key in inputs if key in runtime], width,
                          color=colours[schedule], label=schedule)
            ax.bar_label(bars, fmt="%.3g", fontsize=7)
        ax.set_xticks(range(len(inputs)))
        ax.set_xticklabels([input_tick(key) for key in inputs], rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("runtime (s)")
        ax.set_title(dataset)
        ax.grid(True, axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    for ax in list(axes.flat)[len(datasets):]:
        ax.set_visible(False)
    fig.suptitle("Total runtime of all updates (median of the repeats)")
    save(fig, path)


def plain_log_axis(ax):
    """Log y axis with plain numbers (0.5, 2, 30) instead of 5x10^-1."""
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(ticker.FuncFormatter(lambda value, _: f"{value:g}"))
    ax.yaxis.set_minor_formatter(ticker.LogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))


def input_tick(key):
    label, outliers, seed = key
    kind = "irl" if label.endswith(".irl") else "g2o"
    return f"{kind} {fmt(outliers, 0)} %" + ("" if seed is None else f" s{seed}")


def linear_fit(poses, ms):
    """(intercept ms, slope ms/pose, R²) of the least-squares line."""
    slope, intercept = np.polyfit(poses, ms, 1)
    residual = ms - (intercept + slope * poses)
    total = np.sum((ms - ms.mean()) ** 2)
    return intercept, slope, (1 - np.sum(residual ** 2) / total) if total > 0 else float("nan")


def plot_scaling(results, path):
    """Latency against size on the synthetic graphs, with linear fits; the
    y axis is cut at the 99th percentile (the caption says how many updates
    lie above). Returns {(input, schedule): (intercept, slope, r2, n)}."""
    ok = [r for r in results if r.ok]
    inputs = ordered(r.cell.dataset for r in ok)
    fig, axes = plt.subplots(1, len(inputs), figsize=(7 * len(inputs), 4.8), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fits = {}
    for ax, name in zip(axes[0], inputs):
        mine = [r for r in ok if r.cell.dataset == name]
        top, hidden = 0.0, 0
        for colour, schedule in zip(colours, ordered(r.cell.schedule for r in mine)):
            poses, ms = pooled_latency([r for r in mine if r.cell.schedule == schedule])
            if len(ms) < 2:
                continue
            intercept, slope, r2 = linear_fit(poses, ms)
            fits[(name, schedule)] = (intercept, slope, r2, len(ms))
            cut = np.percentile(ms, 99)
            top, hidden = max(top, cut), hidden + int(np.sum(ms > cut))
            ax.scatter(poses, ms, s=5, alpha=0.35, color=colour, linewidths=0)
            xs = np.array([poses.min(), poses.max()])
            ax.plot(xs, intercept + slope * xs, color=colour, lw=2,
                    label=f"{schedule}: {intercept:.1f} ms + {1000 * slope:.2f} ms per 1000 poses (R² {r2:.2f})")
        if top > 0:
            ax.set_ylim(0, 1.1 * top)
        ax.set_title(f"{name} ({hidden} updates above the 99th percentile not shown)", fontsize=10)
        ax.set_xlabel("graph size (poses)")
        ax.set_ylabel("update latency (ms)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"Scaling: per-update latency on synthetic grid graphs ({SCALING_OUTLIERS} % outliers), "
                 "linear least-squares fit")
    save(fig, path)
    return fits


def save(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def scaling_section(results, fits, graphs):
    rows = [[f"`{g['name']}.g2o`", f"{g['dim']}D", str(g["poses"]), str(g["loops"]),
             fmt(g["loops_per_pose"], 2), f"{g['side']}×{g['side']}" + (f"×{g['floors']}" if g["dim"] == 3 else ""),
             fmt(g["drift_m"], 1)] for g in graphs]
    lines = ["Generated graphs (the tool injects "
             f"{SCALING_OUTLIERS} % outliers with the given seed; ground truth: the `_gt.g2o` next to each):", ""]
    lines += markdown_table(("graph", "dim", "poses", "loop closures", "loops per pose", "grid",
                             "odometry drift at the end m"), rows)
    lines += [""] + markdown_table(RESULT_COLUMNS, [result_row(r) for r in results])
    lines += ["", "Linear fit of the per-update latency against graph size:", ""]
    rows = [[name, schedule, fmt(a, 2), fmt(1000 * b, 3), fmt(r2, 3), str(n)]
            for (name, schedule), (a, b, r2, n) in fits.items()]
    lines += markdown_table(("input", "schedule", "intercept ms", "ms per 1000 poses", "R²", "updates"), rows)
    lines += ["", "![latency against graph size on synthetic graphs](scaling_latency.png)"]
    return lines


# --------------------------------------------------------------------------

def write_report(results, graphs, args, started, load_before):
    os.makedirs(args.out, exist_ok=True)
    main = [r for r in results if r.cell.kind != "scaling"]
    scaling = [r for r in results if r.cell.kind == "scaling"]
    lines = header(args, started, load_before)
    if main or not scaling:
        lines += ["", "## Results", ""] + results_section(main)
        lines += ["", "## agnc vs risam", ""] + ratio_section(main)
        accuracy = accuracy_section(main)
        if accuracy:
            lines += ["", "## g2o datasets by outlier rate (seeds pooled)", ""] + accuracy
    if args.peers:
        lines += ["", "## GTSAM peers on the same final graphs", ""] + peer_section(results, args.peers)
    if any(r.ok for r in main):
        plot_latency(main, os.path.join(args.out, "benchmark_latency.png"))
        plot_runtime(main, os.path.join(args.out, "benchmark_runtime.png"))
        lines += ["", "## Plots", "", "![per-update latency against graph size](benchmark_latency.png)", "",
                  "![runtime per dataset and schedule](benchmark_runtime.png)"]
    if scaling:
        fits = plot_scaling(scaling, os.path.join(args.out, "scaling_latency.png")) \
            if any(r.ok for r in scaling) else {}
        lines += ["", "## Scaling (synthetic grid graphs, `scripts/make_scaling_graph.py`)", ""]
        lines += scaling_section(scaling, fits, graphs)
    path = os.path.join(args.out, "benchmark.md")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


def comma_list(convert, allowed=None):
    def parse(text):
        values = [convert(v.strip()) for v in text.split(",") if v.strip()]
        bad = [v for v in values if allowed and v not in allowed]
        if not values or bad:
            raise argparse.ArgumentTypeError(f"expected a comma-separated list"
                                             + (f" of {', '.join(allowed)}" if allowed else "")
                                             + (f"; unknown: {', '.join(map(str, bad))}" if bad else ""))
        return values
    return parse


def positive_int(text):
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError("must be at least 1")
    return value


def parse_arguments(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add = parser.add_argument
    add("--quick", action="store_true", help="only the CSAIL and Intel .irl logs")
    add("--schedules", type=comma_list(str, SCHEDULES), default=["agnc", "risam"],
        help=f"comma-separated, of {', '.join(SCHEDULES)} (default agnc,risam)")
    add("--seeds", type=comma_list(int), default=[1],
        help="outlier-injection seeds of the g2o cells, comma-separated (default 1)")
    add("--repeat", type=positive_int, default=1, help="runs per cell; runtime = their median (default 1)")
    add("--filter", help="regular expression on cell names, e.g. 'irl/CSAIL' or '^scaling/'")
    add("--jobs", type=positive_int, default=1,
        help="cells run at a time (default 1: timings need a quiet machine)")
    add("--timeout", type=float, default=7200, help="seconds per run of a cell (default %(default)g)")
    add("--out", default=os.path.join(REPO, "doc"), help="where benchmark.md and the PNGs go (default doc/)")
    add("--work", default=os.path.join(REPO, "build", "benchmark"),
        help="raw output of every run: metrics.json, latency.csv, ... (default build/benchmark/)")
    add("--tool", default=DEFAULT_TOOL,
        help="agnc_pgo_replay binary (default build/devel/lib/agnc_pgo/agnc_pgo_replay)")
    add("--scaling", action="store_true",
        help=f"also generate large synthetic grid graphs and run them ({SCALING_OUTLIERS} %% outliers)")
    add("--scaling-poses-2d", type=int, default=20000, help="poses of the 2D graph (default %(default)d; 0: none)")
    add("--scaling-poses-3d", type=int, default=5000, help="poses of the 3D graph (default %(default)d; 0: none)")
    add("--scaling-dir", default=os.path.join(REPO, "build", "scaling"),
        help="where the synthetic graphs go (default build/scaling/)")
    add("--sphere", action="store_true", help="also run the Sphere2500 cells (SE(3); ~9 min each)")
    add("--list", action="store_true", help="list the selected cells and exit")
    add("--peers", nargs="?", const=["gnc"], default=[], type=comma_list(str, PEERS),
        help="also run GTSAM peers on the final graph of every input (one schedule's run): gnc = batch "
             "GncLMOptimizer (TLS), isam2 = ISAM2 on the true loop closures (speed floor); comma-separated, "
             "--peers alone = gnc. GTSAM comes from PyPI into --peer-venv, made on first use")
    add("--peer-venv", default=DEFAULT_PEER_VENV,
        help="the peers' virtual environment (default build/peer_venv/)")
    add("--no-instructions", dest="count_instructions", action="store_false",
        help="do not count instructions with perf stat (counted by default where perf can)")
    args = parser.parse_args(argv)
    args.schedules = ordered(args.schedules)
    args.seeds = ordered(args.seeds)
    args.peers = ordered(args.peers)
    if not args.list and not os.access(args.tool, os.X_OK):
        parser.error(f"replay tool not found: {args.tool} (build it with scripts/setup.sh, or pass --tool)")
    return args


def main(argv=None):
    args = parse_arguments(argv)
    if args.list and args.scaling:
        args.scaling = False
        print("(--list does not generate the --scaling graphs; their cells are not listed)")
    cells, graphs = select_cells(args)
    if args.list:
        print("\n".join(c.name for c in cells))
        return 0
    if not cells:
        print("no cell selected", file=sys.stderr)
        return 1
    args.peer_cells = peer_cells(cells, args.peers)
    if args.peers:
        try:
            args.peer_python = peer_venv_python(args.peer_venv)
        except RuntimeError as e:
            print(f"--peers: {e}", file=sys.stderr)
            return 1
    if args.count_instructions and not perf_available():
        print("perf stat cannot count instructions here: the instructions column stays empty", flush=True)
        args.count_instructions = False
    started, load_before = datetime.datetime.now(datetime.timezone.utc), os.getloadavg()
    print(f"{len(cells)} cells, {args.repeat} run(s) each, {args.jobs} at a time; raw output in "
          f"{shown_path(args.work)}", flush=True)
    begin = time.monotonic()
    try:
        results = run_all(cells, args)
    except KeyboardInterrupt:
        print("interrupted: no report written", file=sys.stderr)
        return 130
    path = write_report(results, graphs, args, started, load_before)
    failed = sum(not r.ok for r in results)
    print(f"wrote {shown_path(path)} ({len(results) - failed}/{len(results)} cells ok, "
          f"{time.monotonic() - begin:.0f} s)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
