#!/usr/bin/python3
"""Generate synthetic pose graphs with ground truth: large grid worlds for
scaling benchmarks, and long-drift city drives for robustness.

--world grid (default): a robot walks a Manhattan-like grid world (step 1 m,
no U-turns, mostly straight) inside a bounded area, so it keeps revisiting
places:

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

--world drift (2D): a car drives the streets of a square city (``--block``
100 m blocks, quarter-circle turns on the right-hand lane, a pose every 0.8 m
+-25 %, as the KITTI graphs), preferring streets it has not driven yet, so it
explores for hundreds to thousands of poses before it drives a street again.
Only such genuine revisits (within ``--loop-radius`` of a pose at least
``--min-gap`` poses earlier, heading the same way) get loop closures, one per
``--loop-every`` poses. Odometry noise is small per step (0.04 m, 1e-3 rad)
and its information is the true one, as is the loop closures' (0.05 m,
2e-3 rad); the heading noise integrates into metres to tens of metres of
drift at the revisits.

Writes NAME.g2o (vertices = odometry-composed initial values, i.e. with drift)
and NAME_gt.g2o (true poses, vertices only, same ids) to ``--out`` (default
build/scaling/, git-ignored). The graph is a pure function of the arguments
(numpy's seeded generator).
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
    """Noisy edges (i, j, T_ij, information): odometry k -> k+1, then the
    loop closures, all with the same noise."""
    pairs = [(k, k + 1) for k in range(len(truth) - 1)] + list(loops)
    info = information(dim, sigma_t, sigma_r)
    return [(i, j, noisy(rng, relative(truth[i], truth[j]), dim, sigma_t, sigma_r), info) for i, j in pairs]


def dead_reckoning(first, edges):
    """Initial values: the odometry composed from the first true pose."""
    poses = [first]
    for i, j, T, _ in edges:
        if j == i + 1 and j == len(poses):
            poses.append(poses[i] @ T)
    return poses


# --------------------------------------------------------------------------
# The drift world (--world drift): a car on a city street grid
# --------------------------------------------------------------------------
#
# The car drives the streets of a square city (blocks of --block metres),
# turning at intersections through quarter circles of --turn-radius on the
# right-hand lane, and prefers streets it has not driven yet, so it explores
# for a long time before it must drive a street again. Only then, hundreds to
# thousands of poses later, do loop closures appear: along the stretch it
# drives again in the same direction, one every --loop-every poses. The
# odometry's small heading noise integrates into metres to tens of metres of
# drift by then, as on the KITTI graphs.

DRIFT_DEFAULTS = dict(poses=5000, step=0.8, sigma_t=0.04, sigma_r=0.001, min_gap=300,
                      loop_sigma_t=0.05, loop_sigma_r=0.002)
LEFT, RIGHT = 1, -1


def street_route(rng, blocks, length_needed, block, revisit_weight, straight_weight):
    """Intersections (lattice points (a, b), 0..blocks) the car passes, long
    enough to drive length_needed metres. Never U-turns; an undriven street
    weighs 1 against revisit_weight for one driven before (either direction),
    and going straight weighs straight_weight times a turn."""
    node, heading = (blocks // 2, blocks // 2), 0
    route, driven = [node], set()
    while (len(route) - 1) * block < length_needed:
        options = []
        for turn, weight in ((0, straight_weight), (LEFT, 1.0), (RIGHT, 1.0)):
            h = (heading + turn) % 4
            nxt = (node[0] + HEADINGS[h][0], node[1] + HEADINGS[h][1])
            if 0 <= nxt[0] <= blocks and 0 <= nxt[1] <= blocks:
                street = frozenset((node, nxt))
                options.append((h, nxt, weight * (revisit_weight if street in driven else 1.0)))
        heading, nxt, _ = pick(options, rng.random())
        driven.add(frozenset((node, nxt)))
        node = nxt
        route.append(node)
    return route


def route_segments(route, block, radius, lane):
    """The lane the car drives along the route, as straight lines and
    quarter-circle turns: ('line', start xy, unit direction, length) and
    ('arc', centre xy, radius, start angle, +1 left / -1 right, length). The
    lane lies `lane` metres right of the street's centre line."""
    points = [np.array(p, dtype=float) * block for p in route]
    directions = [(b - a) / block for a, b in zip(points, points[1:])]
    segments, start = [], points[0] + lane * right_normal(directions[0])
    for k, d in enumerate(directions):
        turn = 0 if k + 1 == len(directions) else turn_sign(d, directions[k + 1])
        end_of_line = block - (radius if turn else 0) - (radius if k and segments[-1][0] == "arc" else 0)
        segments.append(("line", start, d, end_of_line))
        start = start + end_of_line * d
        if turn:
            r = radius + turn * lane  # the right-hand lane: outside on left turns
            normal = -right_normal(d) * turn  # towards the centre of the turn
            centre = start + r * normal
            angle = math.atan2(*(start - centre)[::-1])
            segments.append(("arc", centre, r, angle, turn, r * math.pi / 2))
            start = centre + r * np.array([math.cos(angle + turn * math.pi / 2),
                                           math.sin(angle + turn * math.pi / 2)])
    return segments


def right_normal(d):
    return np.array([d[1], -d[0]])


def turn_sign(d, e):
    """+1 for a left turn from direction d to e, -1 for a right one, 0 straight."""
    cross = d[0] * e[1] - d[1] * e[0]
    return 0 if abs(cross) < 0.5 else int(round(cross))


def sample_segments(segments, distances):
    """Poses (x, y, yaw) at the given increasing arc lengths along the segments."""
    poses, k, offset = [], 0, 0.0
    for s in distances:
        while k + 1 < len(segments) and s > offset + segments[k][-1]:
            offset += segments[k][-1]
            k += 1
        u = s - offset
        seg = segments[k]
        if seg[0] == "line":
            _, start, d, _ = seg
            p = start + u * d
            poses.append((p[0], p[1], math.atan2(d[1], d[0])))
        else:
            _, centre, r, angle, turn, _ = seg
            a = angle + turn * u / r
            poses.append((centre[0] + r * math.cos(a), centre[1] + r * math.sin(a), a + turn * math.pi / 2))
    return poses


def drift_truth(rng, args):
    """True SE(2) poses of the car: one every --step metres on average (the
    speed varies by +-25 % from pose to pose), starting at the origin."""
    increments = args.step * (1.0 + 0.25 * rng.uniform(-1.0, 1.0, args.poses - 1))
    distances = np.concatenate([[0.0], np.cumsum(increments)])
    route = street_route(rng, args.blocks, distances[-1] + 2 * args.block, args.block,
                         args.revisit_weight, args.straight_weight)
    poses = sample_segments(route_segments(route, args.block, args.turn_radius, args.lane), distances)
    first = se2(*poses[0])
    return [relative(first, se2(*p)) for p in poses]


def street_revisits(truth, min_gap, radius, max_angle, every):
    """Loop closures (j, i), j < i - min_gap: pose i is within `radius` metres
    of an earlier pose j heading the same way (within max_angle); the nearest
    such j, at most one loop closure per `every` poses."""
    xy = np.array([T[:2, 2] for T in truth])
    yaw = np.array([math.atan2(T[1, 0], T[0, 0]) for T in truth])
    cells = {}
    loops, last = [], -every
    for i in range(len(truth)):
        key = tuple(np.floor(xy[i] / radius).astype(int))
        if i >= min_gap and i - last >= every:
            best, best_distance = None, radius
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for j in cells.get((key[0] + dx, key[1] + dy), ()):
                        distance = float(np.linalg.norm(xy[i] - xy[j]))
                        turn = abs((yaw[i] - yaw[j] + math.pi) % (2 * math.pi) - math.pi)
                        if j <= i - min_gap and distance < best_distance and turn < max_angle:
                            best, best_distance = j, distance
            if best is not None:
                loops.append((best, i))
                last = i
        cells.setdefault(key, []).append(i)
    return loops


def city_blocks(args):
    """Blocks per side of the smallest square city whose streets are at
    least as long as the drive (so the car explores before it revisits)."""
    drive = args.poses * args.step
    blocks = 1
    while 2 * blocks * (blocks + 1) * args.block < drive:
        blocks += 1
    return blocks


def generate_drift(args):
    """The drift world's graph: (true poses, edges with information, loops)."""
    rng = np.random.default_rng(args.seed)
    truth = drift_truth(rng, args)
    loops = street_revisits(truth, args.min_gap, args.loop_radius, math.radians(args.loop_angle),
                            args.loop_every)
    odometry_info = information(2, args.sigma_t, args.sigma_r)
    loop_info = information(2, args.loop_sigma_t, args.loop_sigma_r)
    edges = [(k, k + 1, noisy(rng, relative(truth[k], truth[k + 1]), 2, args.sigma_t, args.sigma_r),
              odometry_info) for k in range(len(truth) - 1)]
    edges += [(j, i, noisy(rng, relative(truth[j], truth[i]), 2, args.loop_sigma_t, args.loop_sigma_r), loop_info)
              for j, i in loops]
    return truth, edges, loops


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


def write_g2o(path, poses, edges, dim):
    """Writes atomically (temporary file + rename): no half-written graph."""
    temporary = path + ".tmp"
    with open(temporary, "w") as f:
        for index, T in enumerate(poses):
            f.write(vertex_line(index, T, dim) + "\n")
        for i, j, T, info in edges:
            f.write(edge_line(i, j, T, dim, info) + "\n")
    os.replace(temporary, path)


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
    if args.world == "drift":
        truth, edges, loops = generate_drift(args)
        layout = dict(side=args.blocks, floors=1)
    else:
        side = grid_side(args)
        rng = np.random.default_rng(args.seed)
        cells, headings = walk(rng, args.poses, side, **walk_parameters(args))
        loops = revisits(rng, cells, args.min_gap)
        truth = true_poses(rng, cells, headings, args.dim, args.step, args.tilt)
        edges = measure(rng, truth, loops, args.dim, args.sigma_t, args.sigma_r)
        layout = dict(side=side, floors=walk_parameters(args)["floors"])
    initial = dead_reckoning(truth[0], edges)

    os.makedirs(args.out, exist_ok=True)
    name = args.name or f"{args.world}{args.dim}d_{args.poses}_seed{args.seed}"
    graph_path = os.path.join(args.out, name + ".g2o")
    gt_path = os.path.join(args.out, name + "_gt.g2o")
    write_g2o(graph_path, initial, edges, args.dim)
    write_g2o(gt_path, truth, [], args.dim)
    drift = [float(np.linalg.norm(a[:-1, -1] - b[:-1, -1])) for a, b in zip(initial, truth)]
    gaps = [i - j for j, i in loops]
    summary = dict(name=name, world=args.world, dim=args.dim, poses=args.poses, loops=len(loops),
                   loops_per_pose=len(loops) / args.poses, **layout, drift_m=drift[-1],
                   max_drift_m=max(drift), revisits=revisit_stretches(loops),
                   gap_min=min(gaps, default=0), gap_median=float(np.median(gaps)) if gaps else 0.0,
                   drift_at_loops_m=[drift[i] for _, i in loops])
    return graph_path, gt_path, summary


def revisit_stretches(loops, apart=50):
    """Runs of loop closures whose newer endpoints lie within `apart` poses
    of each other (one stretch of road driven again)."""
    newer = sorted(i for _, i in loops)
    return sum(1 for k, i in enumerate(newer) if k == 0 or i - newer[k - 1] > apart)


def parse_arguments(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add = parser.add_argument
    add("--world", choices=("grid", "drift"), default="grid",
        help="grid: the Manhattan-like grid walk (default); drift: a car on a city street grid, long "
             "excursions between few revisits (2D only)")
    add("--dim", type=int, choices=(2, 3), default=2, help="2: square grid (default), 3: multi-floor grid")
    add("--poses", type=int,
        help=f"number of poses (default: grid 20000 in 2D, 5000 in 3D; drift {DRIFT_DEFAULTS['poses']})")
    add("--seed", type=int, default=1, help="random seed of walk, tilt and noise (default 1)")
    add("--out", default=os.path.join(REPO, "build", "scaling"), help="output directory (default build/scaling/)")
    add("--name", help="file name stem (default WORLDDd_POSES_seedSEED, e.g. grid2d_20000_seed1)")
    add("--loops-per-pose", type=float, default=0.45,
        help="grid: target loop closures per pose; sets the grid size (default %(default)g)")
    add("--side", type=int, help="grid: grid side in cells (overrides --loops-per-pose)")
    add("--floors", type=int, default=4, help="grid, 3D: floors (default %(default)d)")
    add("--step", type=float,
        help=f"grid: grid spacing in metres (default 1); drift: mean distance between poses "
             f"(default {DRIFT_DEFAULTS['step']:g}, the KITTI graphs' 0.8 m)")
    add("--p-turn", type=float, default=0.15,
        help="grid: probability of a left (and of a right) turn (default %(default)g)")
    add("--p-floor", type=float, default=0.03, help="grid, 3D: probability of going up (and down) (default %(default)g)")
    add("--min-gap", type=int,
        help=f"loop closures only to poses at least this many steps back (default: grid 4, drift "
             f"{DRIFT_DEFAULTS['min_gap']})")
    add("--sigma-t", type=float,
        help=f"odometry translation noise std-dev in m (default: grid 0.05, drift {DRIFT_DEFAULTS['sigma_t']:g})")
    add("--sigma-r", type=float,
        help=f"odometry rotation noise std-dev in rad (default: grid 0.01, drift {DRIFT_DEFAULTS['sigma_r']:g})")
    add("--tilt", type=float, default=0.03, help="grid, 3D: std-dev of the true roll and pitch in rad (default %(default)g)")
    add("--block", type=float, default=100.0, help="drift: street block length in m (default %(default)g)")
    add("--blocks", type=int,
        help="drift: city side in blocks (default: the smallest city whose streets are as long as the drive)")
    add("--turn-radius", type=float, default=8.0,
        help="drift: radius of the street centre line in turns, m (default %(default)g)")
    add("--lane", type=float, default=1.75,
        help="drift: the car drives this far right of the centre line, m (default %(default)g)")
    add("--revisit-weight", type=float, default=0.02,
        help="drift: weight of a street driven before against 1 for a new one (default %(default)g)")
    add("--straight-weight", type=float, default=2.0,
        help="drift: weight of going straight at an intersection against 1 per turn (default %(default)g)")
    add("--loop-radius", type=float, default=2.0,
        help="drift: a revisit is a pose within this distance of an earlier one, m (default %(default)g)")
    add("--loop-angle", type=float, default=30.0,
        help="drift: ... heading the same way within this angle, degrees (default %(default)g)")
    add("--loop-every", type=int, default=5,
        help="drift: at most one loop closure per this many poses of a revisit (default %(default)d, as KITTI)")
    add("--loop-sigma-t", type=float, default=DRIFT_DEFAULTS["loop_sigma_t"],
        help="drift: loop-closure translation noise std-dev in m (default %(default)g)")
    add("--loop-sigma-r", type=float, default=DRIFT_DEFAULTS["loop_sigma_r"],
        help="drift: loop-closure rotation noise std-dev in rad (default %(default)g)")
    args = parser.parse_args(argv)
    if args.world == "drift":
        check_drift_arguments(parser, args)
    else:
        for key, value in dict(poses=20000 if args.dim == 2 else 5000, step=1.0, min_gap=4, sigma_t=0.05,
                               sigma_r=0.01).items():
            if getattr(args, key) is None:
                setattr(args, key, value)
    if args.poses < 2:
        parser.error("--poses must be at least 2")
    if args.dim == 3 and args.floors < 1:
        parser.error("--floors must be at least 1")
    if not 0 <= 2 * args.p_turn + (2 * args.p_floor if args.dim == 3 else 0) < 1:
        parser.error("turn/floor probabilities must leave room for going straight")
    return args


def check_drift_arguments(parser, args):
    """Fills in the drift world's defaults and rejects what it cannot build."""
    if args.dim != 2:
        parser.error("--world drift is 2D only")
    for key, value in DRIFT_DEFAULTS.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    if args.blocks is None:
        args.blocks = city_blocks(args)
    positive = dict(step=args.step, block=args.block, blocks=args.blocks, loop_radius=args.loop_radius,
                    loop_every=args.loop_every, sigma_t=args.sigma_t, sigma_r=args.sigma_r,
                    loop_sigma_t=args.loop_sigma_t, loop_sigma_r=args.loop_sigma_r,
                    straight_weight=args.straight_weight, revisit_weight=args.revisit_weight)
    for key, value in positive.items():
        if not value > 0:
            parser.error(f"--{key.replace('_', '-')} must be positive")
    if not 0 <= args.lane < args.turn_radius or 2 * args.turn_radius > args.block:
        parser.error("need 0 <= --lane < --turn-radius <= --block / 2")


def main(argv=None):
    args = parse_arguments(argv)
    graph_path, gt_path, s = generate(args)
    layout = "city" if s["world"] == "drift" else "grid"
    print(f"{s['name']}: {s['dim']}D, {s['poses']} poses, {s['loops']} loop closures "
          f"({s['loops_per_pose']:.3f} per pose) in {s['revisits']} revisits, {layout} {s['side']}x{s['side']}"
          + (f"x{s['floors']}" if s["dim"] == 3 else "") + f", odometry drift at the end {s['drift_m']:.1f} m"
          f" (max {s['max_drift_m']:.1f} m)")
    if s["loops"]:
        at_loops = s["drift_at_loops_m"]
        print(f"  poses between loop-closure endpoints: min {s['gap_min']}, median {s['gap_median']:.0f}; "
              f"odometry drift at the loop closures: median {np.median(at_loops):.1f} m, "
              f"max {max(at_loops):.1f} m")
    print(graph_path)
    print(gt_path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
