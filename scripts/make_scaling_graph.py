#!/usr/bin/python3
"""Generate a large synthetic pose graph for scaling benchmarks.

A robot walks a Manhattan-like grid world (step 1 m, no U-turns, mostly
straight) inside a bounded area, so it keeps revisiting places:

- 2D (default, >= 20 000 poses): a square grid; g2o VERTEX_SE2 / EDGE_SE2.
- 3D (``--dim 3``, >= 5 000 poses): a multi-floor grid (ramps between floors)
  with a small random roll/pitch at every pose; g2o VERTEX_SE3:QUAT /
  EDGE_SE3:QUAT, information in g2o order x y z rx ry rz.

Odometry is the true relative pose perturbed by Gaussian noise. Whenever the
robot returns to a grid point it visited before (at least ``--min-gap`` poses
earlier), a loop closure to one earlier visit (picked at random) is added with
the same noise model. The grid size is tuned automatically so the graph has
about ``--loops-per-pose`` loop closures per pose (default 0.45; Manhattan
M3500 has 0.6, Intel 0.95, CSAIL 0.12).

Writes NAME.g2o (vertices = odometry-composed initial values, i.e. with drift)
and NAME_gt.g2o (true poses, vertices only) to ``--out`` (default
build/scaling/, git-ignored). The graph is a pure function of the arguments.
"""

import argparse
import math
import os
import sys

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Unit moves of the walk. Headings 0..3 (+x, +y, -x, -y); 3D adds up/down.
HEADINGS = ((1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0))
UP, DOWN = (0, 0, 1), (0, 0, -1)


# --------------------------------------------------------------------------
# The walk on the grid (integer lattice points)
# --------------------------------------------------------------------------

def walk(rng, poses, side, floors, p_turn, p_floor):
    """Returns (cells [poses x 3] int, headings [poses] int 0..3).

    Moves one grid step per pose; turns left/right with probability p_turn
    each, changes floor with probability p_floor (3D only), never U-turns
    (nor goes straight back up/down) unless boxed in. Starts at the centre of
    the ground floor heading +x.
    """
    cell, heading, undo = (side // 2, side // 2, 0), 0, None
    cells, headings = [cell], [0]
    uniforms = rng.random(poses)
    for k in range(1, poses):
        options = [(heading, HEADINGS[heading], 1.0),
                   ((heading + 1) % 4, HEADINGS[(heading + 1) % 4], p_turn),
                   ((heading + 3) % 4, HEADINGS[(heading + 3) % 4], p_turn)]
        if floors > 1:
            options += [(heading, UP, p_floor), (heading, DOWN, p_floor)]
        options[0] = (heading, HEADINGS[heading], 1.0 - sum(o[2] for o in options[1:]))
        allowed = [o for o in options if inside(moved(cell, o[1]), side, floors) and o[1] != undo]
        if not allowed:  # boxed in: turn back
            back = (heading + 2) % 4
            allowed = [(back, HEADINGS[back], 1.0)]
        heading, move, _ = pick(allowed, uniforms[k])
        undo = (0, 0, -move[2]) if move[2] else None  # no straight back down/up
        cell = moved(cell, move)
        cells.append(cell)
        headings.append(heading)
    return np.array(cells), np.array(headings)


def moved(cell, move):
    return (cell[0] + move[0], cell[1] + move[1], cell[2] + move[2])


def pick(options, u):
    """The option whose slice of the (renormalised) weights holds u in [0, 1)."""
    total, accumulated = sum(o[2] for o in options), 0.0
    for option in options:
        accumulated += option[2] / total
        if u < accumulated:
            return option
    return options[-1]


def inside(cell, side, floors):
    return 0 <= cell[0] < side and 0 <= cell[1] < side and 0 <= cell[2] < floors


def revisits(rng, cells, min_gap):
    """Loop closures (j, i), j < i: pose i is at a grid point last seen by j."""
    visits, loops = {}, []
    for i, cell in enumerate(map(tuple, cells)):
        earlier = [j for j in visits.get(cell, []) if i - j >= min_gap]
        if earlier:
            loops.append((earlier[rng.integers(len(earlier))], i))
        visits.setdefault(cell, []).append(i)
    return loops


# --------------------------------------------------------------------------
# SE(2) / SE(3) helpers (poses as 3x3 / 4x4 homogeneous matrices)
# --------------------------------------------------------------------------

def se2(x, y, theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def se2_vector(T):
    return np.array([T[0, 2], T[1, 2], math.atan2(T[1, 0], T[0, 0])])


def rot_zyx(yaw, pitch, roll):
    """R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cz, sz, cy, sy, cx, sx = (math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch),
                              math.cos(roll), math.sin(roll))
    return np.array([[cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
                     [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
                     [-sy, cy * sx, cy * cx]])


def exp_so3(w):
    """Rodrigues' formula: rotation matrix of the rotation vector w."""
    angle = np.linalg.norm(w)
    if angle < 1e-12:
        return np.eye(3)
    k = w / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def se3(R, t):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def quaternion(R):
    """(qx, qy, qz, qw) of a rotation matrix (Shepperd's method: divides by
    the largest component, so 180-degree turns are exact too), qw >= 0."""
    trace = np.trace(R)
    i = int(np.argmax([R[0, 0], R[1, 1], R[2, 2], trace]))
    if i == 3:
        w = math.sqrt(1 + trace) / 2
        q = [(R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w), w]
    else:
        j, k = (i + 1) % 3, (i + 2) % 3
        v = math.sqrt(max(0.0, 1 + R[i, i] - R[j, j] - R[k, k])) / 2
        q = [0.0, 0.0, 0.0, (R[k, j] - R[j, k]) / (4 * v)]
        q[i], q[j], q[k] = v, (R[j, i] + R[i, j]) / (4 * v), (R[k, i] + R[i, k]) / (4 * v)
    q = np.array(q) / np.linalg.norm(q)
    return -q if q[3] < 0 else q


def relative(Ti, Tj):
    return np.linalg.solve(Ti, Tj)


# --------------------------------------------------------------------------
# Poses and noisy measurements
# --------------------------------------------------------------------------

def true_poses(rng, cells, headings, dim, step, tilt):
    """True poses (matrices): position = grid point * step, yaw = heading."""
    origin = cells[0] * step
    poses = []
    for cell, heading in zip(cells, headings):
        p = cell * step - origin
        yaw = heading * math.pi / 2
        if dim == 2:
            poses.append(se2(p[0], p[1], yaw))
        else:
            roll, pitch = (rng.normal(0.0, tilt, 2) if len(poses) else (0.0, 0.0))
            poses.append(se3(rot_zyx(yaw, pitch, roll), p))
    return poses


def noisy(rng, T, dim, sigma_t, sigma_r):
    """T perturbed on the right by Gaussian noise (translation, rotation)."""
    if dim == 2:
        v = se2_vector(T) + rng.normal(0.0, [sigma_t, sigma_t, sigma_r])
        return se2(*v)
    dt, dr = rng.normal(0.0, sigma_t, 3), rng.normal(0.0, sigma_r, 3)
    return T @ se3(exp_so3(dr), dt)


def information(dim, sigma_t, sigma_r):
    """Upper triangle (row-major) of the diagonal information matrix,
    g2o order: x y theta (2D), x y z rx ry rz (3D)."""
    diag = [sigma_t ** -2] * 2 + [sigma_r ** -2] if dim == 2 else [sigma_t ** -2] * 3 + [sigma_r ** -2] * 3
    n = len(diag)
    return [diag[r] if r == c else 0.0 for r in range(n) for c in range(r, n)]


def measure(rng, truth, loops, dim, sigma_t, sigma_r):
    """Noisy edges (i, j, T_ij): odometry k -> k+1, then the loop closures."""
    pairs = [(k, k + 1) for k in range(len(truth) - 1)] + list(loops)
    return [(i, j, noisy(rng, relative(truth[i], truth[j]), dim, sigma_t, sigma_r)) for i, j in pairs]


def dead_reckoning(first, edges):
    """Initial values: the odometry composed from the first true pose."""
    poses = [first]
    for i, j, T in edges:
        if j == i + 1 and j == len(poses):
            poses.append(poses[i] @ T)
    return poses


# --------------------------------------------------------------------------
# g2o output
# --------------------------------------------------------------------------

def fmt(values):
    return " ".join(f"{v:.9g}" for v in values)


def vertex_line(index, T, dim):
    if dim == 2:
        return f"VERTEX_SE2 {index} {fmt(se2_vector(T))}"
    return f"VERTEX_SE3:QUAT {index} {fmt(T[:3, 3])} {fmt(quaternion(T[:3, :3]))}"


def edge_line(i, j, T, dim, info):
    if dim == 2:
        return f"EDGE_SE2 {i} {j} {fmt(se2_vector(T))} {fmt(info)}"
    return f"EDGE_SE3:QUAT {i} {j} {fmt(T[:3, 3])} {fmt(quaternion(T[:3, :3]))} {fmt(info)}"


def write_g2o(path, poses, edges, dim, info):
    with open(path, "w") as f:
        for index, T in enumerate(poses):
            f.write(vertex_line(index, T, dim) + "\n")
        for i, j, T in edges:
            f.write(edge_line(i, j, T, dim, info) + "\n")


# --------------------------------------------------------------------------
# Grid size: tuned so the walk yields the requested loops per pose
# --------------------------------------------------------------------------

def walk_parameters(args):
    return dict(p_turn=args.p_turn, p_floor=args.p_floor if args.dim == 3 else 0.0,
                floors=args.floors if args.dim == 3 else 1)


def loop_rate(args, side):
    rng = np.random.default_rng(args.seed)
    cells, _ = walk(rng, args.poses, side, **walk_parameters(args))
    return len(revisits(rng, cells, args.min_gap)) / args.poses


def grid_side(args):
    """Smallest side whose walk has at most --loops-per-pose loops per pose
    (fewer loops as the area grows; bisection on the side length)."""
    if args.side:
        return args.side
    low, high = 2, 4
    while loop_rate(args, high) > args.loops_per_pose and high < 10 * args.poses:
        low, high = high, high * 2
    while high - low > 1:
        mid = (low + high) // 2
        if loop_rate(args, mid) > args.loops_per_pose:
            low = mid
        else:
            high = mid
    return high


# --------------------------------------------------------------------------

def generate(args):
    """Writes the graph and its ground truth; returns (g2o, gt, summary)."""
    side = grid_side(args)
    rng = np.random.default_rng(args.seed)
    cells, headings = walk(rng, args.poses, side, **walk_parameters(args))
    loops = revisits(rng, cells, args.min_gap)
    truth = true_poses(rng, cells, headings, args.dim, args.step, args.tilt)
    edges = measure(rng, truth, loops, args.dim, args.sigma_t, args.sigma_r)
    initial = dead_reckoning(truth[0], edges)
    info = information(args.dim, args.sigma_t, args.sigma_r)

    os.makedirs(args.out, exist_ok=True)
    name = args.name or f"grid{args.dim}d_{args.poses}_seed{args.seed}"
    graph_path = os.path.join(args.out, name + ".g2o")
    gt_path = os.path.join(args.out, name + "_gt.g2o")
    write_g2o(graph_path, initial, edges, args.dim, info)
    write_g2o(gt_path, truth, [], args.dim, info)
    summary = dict(name=name, dim=args.dim, poses=args.poses, loops=len(loops),
                   loops_per_pose=len(loops) / args.poses, side=side,
                   floors=walk_parameters(args)["floors"],
                   drift_m=float(np.linalg.norm(initial[-1][:-1, -1] - truth[-1][:-1, -1])))
    return graph_path, gt_path, summary


def parse_arguments(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add = parser.add_argument
    add("--dim", type=int, choices=(2, 3), default=2, help="2: square grid (default), 3: multi-floor grid")
    add("--poses", type=int, help="number of poses (default: 20000 in 2D, 5000 in 3D)")
    add("--seed", type=int, default=1, help="random seed of walk, tilt and noise (default 1)")
    add("--out", default=os.path.join(REPO, "build", "scaling"), help="output directory (default build/scaling/)")
    add("--name", help="file name stem (default gridDd_POSES_seedSEED)")
    add("--loops-per-pose", type=float, default=0.45,
        help="target loop closures per pose; sets the grid size (default %(default)g)")
    add("--side", type=int, help="grid side in cells (overrides --loops-per-pose)")
    add("--floors", type=int, default=4, help="floors of the 3D grid (default %(default)d)")
    add("--step", type=float, default=1.0, help="grid spacing in metres (default %(default)g)")
    add("--p-turn", type=float, default=0.15, help="probability of a left (and of a right) turn (default %(default)g)")
    add("--p-floor", type=float, default=0.03, help="3D: probability of going up (and down) (default %(default)g)")
    add("--min-gap", type=int, default=4,
        help="loop closures only to poses at least this many steps back (default %(default)d)")
    add("--sigma-t", type=float, default=0.05, help="translation noise std-dev in m (default %(default)g)")
    add("--sigma-r", type=float, default=0.01, help="rotation noise std-dev in rad (default %(default)g)")
    add("--tilt", type=float, default=0.03, help="3D: std-dev of the true roll and pitch in rad (default %(default)g)")
    args = parser.parse_args(argv)
    if args.poses is None:
        args.poses = 20000 if args.dim == 2 else 5000
    if args.poses < 2:
        parser.error("--poses must be at least 2")
    if args.dim == 3 and args.floors < 1:
        parser.error("--floors must be at least 1")
    if not 0 <= 2 * args.p_turn + (2 * args.p_floor if args.dim == 3 else 0) < 1:
        parser.error("turn/floor probabilities must leave room for going straight")
    return args


def main(argv=None):
    args = parse_arguments(argv)
    graph_path, gt_path, s = generate(args)
    print(f"{s['name']}: {s['dim']}D, {s['poses']} poses, {s['loops']} loop closures "
          f"({s['loops_per_pose']:.2f} per pose), grid {s['side']}x{s['side']}"
          + (f"x{s['floors']}" if s["dim"] == 3 else "") + f", odometry drift at the end {s['drift_m']:.1f} m")
    print(graph_path)
    print(gt_path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
