"""GTSAM peers of the benchmark, run on the final graph of one replay.

Run by scripts/benchmark.py --peers in its own virtual environment (GTSAM
from PyPI is a benchmark peer only, never a dependency of agnc_pgo):

  peer_venv/bin/python scripts/gtsam_peer.py --run RUN_DIR [--ground-truth GT.g2o]
      [--without-gnc] [--isam2] [--kernel C] --output peer.json

RUN_DIR is an `agnc_pgo_replay --output` directory: estimate.g2o holds every
odometry and loop-closure edge of the replay (injected outliers included)
and the replay's final estimate; loop_closures.csv labels the loop closures
in the order of their edges. Measured here:

- batch GNC (unless --without-gnc): gtsam.GncLMOptimizer (TLS loss, default parameters) on that
  graph, initialised by composing the odometry, with a prior on pose 0 and
  the prior and the odometry as known inliers; a loop closure is kept when its
  final GNC weight is above 0.5.
- --isam2: gtsam.ISAM2 (default parameters) fed the TRUE loop closures only,
  pose by pose (odometry, then the loop closures ending there), the speed
  floor of an exact incremental solver.
- --kernel C: the robust objective agnc_pgo's GNC ends on (the SIG kernel at
  mu = 1, i.e. Geman-McClure with shape C, on every loop closure) minimised
  by Levenberg-Marquardt on that graph, started from the outlier-free
  optimum below: where that objective's own minimum next to the truth lies,
  whatever the graduation. A loop closure is kept there under the replay's
  default classification (whitened residual r < q(0.95) of chi2 with the
  factor's degrees of freedom, the reference implementations' convention).
  Reported with that objective there and at the replay's own estimate:
  whichever is lower is the better minimum of the same objective.
- the references: the ground truth, and the outlier-free optimum (LM on
  odometry and true loop closures, started from the odometry, from LAGO /
  chordal initialisation and from the ground truth; the lowest chi2 wins).
  ATE (rigid Umeyama alignment, RMSE of positions, as the replay's metrics)
  of GNC, of iSAM2 and of the replay's own estimate against both.
"""

import argparse
import csv
import json
import math
import os
import sys
import time

import numpy as np
import gtsam

KEPT_WEIGHT = 0.5
PRIOR_SIGMA = 1e-6
# q(0.95) of chi2 with 3 (SE(2)) and 6 (SE(3)) degrees of freedom (ALGORITHM.md's golden values).
CHI2_95 = {2: 7.814728, 3: 12.591587}


class InputError(Exception):
    """A malformed or inconsistent input file (message names file and line)."""


# --------------------------------------------------------------------------
# Reading the replay's output
# --------------------------------------------------------------------------

def information_matrix(values, n, where):
    """The symmetric n x n matrix of a g2o upper triangle (row-major)."""
    if len(values) != n * (n + 1) // 2:
        raise InputError(f"{where}: expected {n * (n + 1) // 2} information entries, got {len(values)}")
    info, k = np.zeros((n, n)), 0
    for r in range(n):
        for c in range(r, n):
            info[r, c] = info[c, r] = values[k]
            k += 1
    return info


def g2o_order_to_gtsam(info):
    """g2o's SE(3) information is ordered x y z rx ry rz, GTSAM's Pose3
    tangent rx ry rz x y z."""
    order = [3, 4, 5, 0, 1, 2]
    return info[np.ix_(order, order)]


def pose3(values):
    x, y, z, qx, qy, qz, qw = values
    return gtsam.Pose3(gtsam.Rot3.Quaternion(qw, qx, qy, qz), gtsam.Point3(x, y, z))


def read_g2o(path):
    """(dimension, {id: pose}, [(i, j, measurement, information)]) of a g2o file."""
    poses, edges, dimension = {}, [], None
    with open(path) as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            where = f"{path}:{number}"
            try:
                tag, numbers = fields[0], [float(v) for v in fields[1:]]
            except ValueError as e:
                raise InputError(f"{where}: not a number ({e})") from None
            if tag == "FIX":
                continue  # the fixed pose 0: the peer's prior holds it
            if tag == "VERTEX_SE2" and len(numbers) == 4:
                dimension, poses[int(numbers[0])] = 2, gtsam.Pose2(*numbers[1:4])
            elif tag == "VERTEX_SE3:QUAT" and len(numbers) == 8:
                dimension, poses[int(numbers[0])] = 3, pose3(numbers[1:8])
            elif tag == "EDGE_SE2":
                dimension = 2
                edges.append((int(numbers[0]), int(numbers[1]), gtsam.Pose2(*numbers[2:5]),
                              information_matrix(numbers[5:], 3, where)))
            elif tag == "EDGE_SE3:QUAT":
                dimension = 3
                edges.append((int(numbers[0]), int(numbers[1]), pose3(numbers[2:9]),
                              g2o_order_to_gtsam(information_matrix(numbers[9:], 6, where))))
            else:
                raise InputError(f"{where}: unsupported line '{fields[0]}' with {len(numbers)} numbers")
    if dimension is None:
        raise InputError(f"{path}: no pose or edge")
    return dimension, poses, edges


def read_labels(path):
    """[(from, to, is_outlier)] of loop_closures.csv, in file order."""
    labels = []
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = {"from", "to", "outlier"} - set(reader.fieldnames or ())
        if missing:
            raise InputError(f"{path}:1: missing columns {', '.join(sorted(missing))}")
        for number, row in enumerate(reader, 2):
            try:
                labels.append((int(row["from"]), int(row["to"]), int(row["outlier"]) != 0))
            except (TypeError, ValueError):
                raise InputError(f"{path}:{number}: from, to and outlier must be integers") from None
    return labels


def split_edges(edges, labels, path):
    """(odometry edges in pose order, loop-closure edges with their labels).
    The first edge k -> k+1 of every k is odometry; every other edge is a loop
    closure, in the order of loop_closures.csv (checked endpoint by endpoint)."""
    odometry, loops = {}, []
    for i, j, z, info in edges:
        if j == i + 1 and i not in odometry:
            odometry[i] = (i, j, z, info)
        else:
            loops.append((i, j, z, info))
    if len(loops) != len(labels):
        raise InputError(f"{path}: {len(loops)} loop-closure edges but {len(labels)} labelled loop closures")
    for k, ((i, j, *_), (a, b, _)) in enumerate(zip(loops, labels)):
        if (i, j) != (a, b):
            raise InputError(f"{path}: loop-closure edge {k} is {i} -> {j}, its label says {a} -> {b}")
    poses = len(odometry) + 1
    if sorted(odometry) != list(range(poses - 1)):
        raise InputError(f"{path}: the odometry chain has gaps (edges k -> k+1 for {len(odometry)} of "
                         f"{max(odometry, default=0) + 1} poses)")
    return [odometry[k] for k in range(poses - 1)], [(e, label[2]) for e, label in zip(loops, labels)]


# --------------------------------------------------------------------------
# Graphs
# --------------------------------------------------------------------------

def between(dimension, edge, shape=None):
    i, j, z, info = edge
    noise = gtsam.noiseModel.Gaussian.Information(info)
    if shape is not None:
        noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.GemanMcClure.Create(shape), noise)
    factor = gtsam.BetweenFactorPose2 if dimension == 2 else gtsam.BetweenFactorPose3
    return factor(i, j, z, noise)


def prior(dimension):
    identity = gtsam.Pose2() if dimension == 2 else gtsam.Pose3()
    noise = gtsam.noiseModel.Isotropic.Sigma(3 if dimension == 2 else 6, PRIOR_SIGMA)
    factor = gtsam.PriorFactorPose2 if dimension == 2 else gtsam.PriorFactorPose3
    return factor(0, identity, noise)


def composed_odometry(dimension, odometry):
    """Initial values: the odometry composed from the identity at pose 0."""
    values = gtsam.Values()
    pose = gtsam.Pose2() if dimension == 2 else gtsam.Pose3()
    values.insert(0, pose)
    for i, j, z, _ in odometry:
        pose = pose.compose(z)
        values.insert(j, pose)
    return values


def build_graph(dimension, odometry, loops, shape=None):
    """Prior, odometry, then the loop closures, with a Geman-McClure kernel of
    the given shape on each loop closure (the SIG kernel at mu = 1) if one is
    given; returns (graph, indices of the prior and odometry factors)."""
    graph = gtsam.NonlinearFactorGraph()
    graph.add(prior(dimension))
    for edge in odometry:
        graph.add(between(dimension, edge))
    for edge in loops:
        graph.add(between(dimension, edge, shape))
    return graph, list(range(1 + len(odometry)))


def values_of(poses):
    values = gtsam.Values()
    for key, pose in poses.items():
        values.insert(key, pose)
    return values


def positions(dimension, values, count):
    if dimension == 2:
        return np.array([[values.atPose2(k).x(), values.atPose2(k).y()] for k in range(count)])
    return np.array([values.atPose3(k).translation() for k in range(count)])


# --------------------------------------------------------------------------
# Metrics
# --------------------------------------------------------------------------

def ate(estimate, reference):
    """RMSE of positions after rigid (Umeyama, no scale) alignment of the
    estimate onto the reference, as the replay's absoluteTrajectoryError."""
    mu_e, mu_r = estimate.mean(0), reference.mean(0)
    cov = (reference - mu_r).T @ (estimate - mu_e) / len(estimate)
    u, _, vt = np.linalg.svd(cov)
    s = np.eye(cov.shape[0])
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[-1, -1] = -1
    rotation = u @ s @ vt
    aligned = (estimate - mu_e) @ rotation.T + mu_r
    return float(math.sqrt(np.mean(np.sum((aligned - reference) ** 2, axis=1))))


def precision_recall(kept, is_outlier):
    """Same conventions as the replay: nothing kept is precision 1, no true
    loop closure is recall 1."""
    tp = sum(k and not o for k, o in zip(kept, is_outlier))
    fp = sum(k and o for k, o in zip(kept, is_outlier))
    fn = sum(not k and not o for k, o in zip(kept, is_outlier))
    return dict(precision=tp / (tp + fp) if tp + fp else 1.0, recall=tp / (tp + fn) if tp + fn else 1.0,
                true_positives=tp, false_positives=fp, false_negatives=fn)


def chi2(graph, values):
    return 2.0 * graph.error(values)


def plain(value):
    """JSON-ready: numpy scalars as Python numbers, inf and NaN as None."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


# --------------------------------------------------------------------------
# The solvers
# --------------------------------------------------------------------------

def run_gnc(graph, initial, known_inliers):
    """GncLMOptimizer with TLS and default parameters: (values, weights, cpu s, wall s)."""
    params = gtsam.GncLMParams()
    params.setLossType(gtsam.GncLossType.TLS)
    params.setKnownInliers(known_inliers)
    cpu, wall = time.process_time(), time.perf_counter()
    optimizer = gtsam.GncLMOptimizer(graph, initial, params)
    result = optimizer.optimize()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    return result, np.asarray(optimizer.getWeights()), cpu, wall


def whitened_norm(dimension, values, edge):
    """r = |S e| of a loop closure at the given estimate, e in GTSAM's tangent."""
    i, j, z, info = edge
    get = values.atPose2 if dimension == 2 else values.atPose3
    error = z.localCoordinates(get(i).between(get(j)))
    return float(math.sqrt(max(0.0, error @ info @ error)))


def run_kernel(dimension, odometry, loops, shape, start, replay):
    """LM on the robust objective from `start`: (values, kept per loop
    closure, cpu s, the objective there, the objective at the replay's
    estimate `replay`), objectives as 2 x GTSAM's error (a chi2)."""
    graph, _ = build_graph(dimension, odometry, loops, shape)
    cpu = time.process_time()
    values = least_squares(graph, start)
    cpu = time.process_time() - cpu
    kept = [whitened_norm(dimension, values, edge) < CHI2_95[dimension] for edge in loops]
    return values, kept, cpu, chi2(graph, values), chi2(graph, replay)


def least_squares(graph, initial):
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(1000)
    params.setRelativeErrorTol(1e-12)
    params.setAbsoluteErrorTol(1e-12)
    return gtsam.LevenbergMarquardtOptimizer(graph, initial, params).optimize()


def global_initialisation(dimension, graph):
    """LAGO (SE(2)) or chordal rotation initialisation (SE(3)); None where
    GTSAM's initialiser refuses the graph (LAGO needs diagonal information)."""
    try:
        return gtsam.lago.initialize(graph) if dimension == 2 else gtsam.InitializePose3.initialize(graph)
    except Exception:  # noqa: BLE001 (GTSAM raises RuntimeError and others; any means "no start")
        return None


def outlier_free_optimum(dimension, odometry, true_loops, ground_truth):
    """The lowest-chi2 LM optimum of the outlier-free graph over its starts;
    returns (values, chi2, {start: chi2})."""
    graph, _ = build_graph(dimension, odometry, true_loops)
    starts = {"odometry": composed_odometry(dimension, odometry)}
    start = global_initialisation(dimension, graph)
    if start is not None:
        starts["lago" if dimension == 2 else "chordal"] = start
    if ground_truth is not None:
        starts["ground truth"] = aligned_start(dimension, ground_truth)
    best, found = None, {}
    for name, initial in starts.items():
        values = least_squares(graph, initial)
        found[name] = chi2(graph, values)
        if best is None or found[name] < found[best[0]]:
            best = (name, values)
    return best[1], found[best[0]], found


def aligned_start(dimension, poses):
    """Ground-truth poses moved so that pose 0 is the identity (the prior)."""
    first = poses[0].inverse()
    return values_of({k: first.compose(p) for k, p in poses.items()})


def run_isam2(dimension, odometry, true_loops):
    """ISAM2 (default parameters), pose by pose: its odometry, then the true
    loop closures whose newer endpoint it is. Returns (values, total cpu s,
    max update cpu ms, updates, the cpu ms of each update that added a loop
    closure: what agnc_pgo's latency percentiles count)."""
    ending_at = {}
    for edge in true_loops:
        ending_at.setdefault(max(edge[0], edge[1]), []).append(edge)
    isam = gtsam.ISAM2(gtsam.ISAM2Params())
    latest = isam.calculateEstimatePose2 if dimension == 2 else isam.calculateEstimatePose3
    slowest, total, newest, loop_updates_ms = 0.0, 0.0, None, []
    for k in range(len(odometry) + 1):
        factors, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        if k == 0:
            factors.add(prior(dimension))
            values.insert(0, gtsam.Pose2() if dimension == 2 else gtsam.Pose3())
        else:
            edge = odometry[k - 1]
            factors.add(between(dimension, edge))
            values.insert(k, newest.compose(edge[2]))
        for edge in ending_at.get(k, ()):
            factors.add(between(dimension, edge))
        # Timed: the update and the newest pose's estimate (what a front-end
        # needs next); the whole estimate only once, at the end.
        cpu = time.process_time()
        isam.update(factors, values)
        newest = latest(k)
        cpu = time.process_time() - cpu
        total, slowest = total + cpu, max(slowest, cpu)
        if k in ending_at:
            loop_updates_ms.append(1000.0 * cpu)
    return isam.calculateEstimate(), total, 1000.0 * slowest, len(odometry) + 1, loop_updates_ms


# --------------------------------------------------------------------------

def measure(args):
    estimate_path = os.path.join(args.run, "estimate.g2o")
    dimension, ours, edges = read_g2o(estimate_path)
    labels = read_labels(os.path.join(args.run, "loop_closures.csv"))
    odometry, labelled = split_edges(edges, labels, estimate_path)
    loops = [edge for edge, _ in labelled]
    is_outlier = [outlier for _, outlier in labelled]
    count = len(odometry) + 1
    ground_truth = None
    if args.ground_truth:
        gt_dimension, ground_truth, _ = read_g2o(args.ground_truth)
        if gt_dimension != dimension or sorted(ground_truth) != list(range(count)):
            raise InputError(f"{args.ground_truth}: not {count} {dimension}D poses 0..{count - 1}")
    if sorted(ours) != list(range(count)):
        raise InputError(f"{estimate_path}: the estimate does not hold poses 0..{count - 1}")

    true_loops = [edge for edge, outlier in labelled if not outlier]
    reference, reference_chi2, starts = outlier_free_optimum(dimension, odometry, true_loops, ground_truth)

    references = {"optimum": positions(dimension, reference, count)}
    if ground_truth is not None:
        references["ground_truth"] = positions(dimension, values_of(ground_truth), count)
    trajectories = {"replay": positions(dimension, values_of(ours), count)}
    report = dict(dimension=dimension, poses=count, loop_closures=len(loops), outliers=sum(is_outlier),
                  gtsam_version=gtsam_version(), reference_chi2=reference_chi2, reference_chi2_by_start=starts)
    if not args.without_gnc:
        graph, known_inliers = build_graph(dimension, odometry, loops)
        gnc, weights, cpu, wall = run_gnc(graph, composed_odometry(dimension, odometry), known_inliers)
        kept = [bool(w > KEPT_WEIGHT) for w in weights[len(known_inliers):]]
        trajectories["gnc"] = positions(dimension, gnc, count)
        report.update(gnc_cpu_s=cpu, gnc_wall_s=wall, gnc_chi2_all_edges=chi2(graph, gnc),
                      **{f"gnc_{k}": v for k, v in precision_recall(kept, is_outlier).items()})
    if args.isam2:
        isam, total, slowest, updates, loop_updates_ms = run_isam2(dimension, odometry, true_loops)
        trajectories["isam2"] = positions(dimension, isam, count)
        report.update(isam2_cpu_s=total, isam2_update_ms_max=slowest, isam2_updates=updates,
                      isam2_loop_update_ms_p95=(float(np.percentile(loop_updates_ms, 95)) if loop_updates_ms else None))
    if args.kernel is not None:
        values, kernel_kept, kernel_cpu, objective, replay_objective = run_kernel(
            dimension, odometry, loops, args.kernel, reference, aligned_start(dimension, ours))
        trajectories["kernel"] = positions(dimension, values, count)
        report.update(kernel_shape=args.kernel, kernel_cpu_s=kernel_cpu, kernel_objective=objective,
                      replay_objective=replay_objective,
                      **{f"kernel_{k}": v for k, v in precision_recall(kernel_kept, is_outlier).items()})
    for who, trajectory in trajectories.items():
        for name, positions_of_reference in references.items():
            report[f"{who}_ate_vs_{name}_m"] = ate(trajectory, positions_of_reference)
    if ground_truth is not None:  # plain least squares on the outlier-free graph
        report["optimum_ate_vs_ground_truth_m"] = ate(references["optimum"], references["ground_truth"])
    return plain(report)


def gtsam_version():
    try:
        from importlib import metadata
        return metadata.version("gtsam")
    except Exception:  # noqa: BLE001 (a version string is only informative)
        return "unknown"


def write_json(path, data):
    """Atomically (temporary file + rename)."""
    text = json.dumps(data, indent=2, allow_nan=False) + "\n"
    temporary = path + ".tmp"
    with open(temporary, "w") as f:
        f.write(text)
    os.replace(temporary, path)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run", required=True, help="an agnc_pgo_replay --output directory")
    parser.add_argument("--ground-truth", help="ground-truth poses (g2o VERTEX lines, same ids)")
    parser.add_argument("--without-gnc", action="store_true", help="skip the batch GNC peer")
    parser.add_argument("--isam2", action="store_true", help="also the iSAM2 speed floor on the true loop closures")
    parser.add_argument("--kernel", type=float, metavar="C",
                        help="also minimise the Geman-McClure objective of shape C from the outlier-free optimum")
    parser.add_argument("--output", required=True, help="where the JSON report goes")
    args = parser.parse_args(argv)
    try:
        write_json(args.output, measure(args))
    except (OSError, InputError) as e:
        print(f"gtsam_peer: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
