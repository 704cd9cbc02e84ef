#!/usr/bin/env python3
"""Writes the firmware example's pose graph as a C table (run at build time).

A robot drives a Manhattan grid (unit steps, quarter turns), odometry with Gaussian noise; when
it comes back to a cell it saw at least MIN_GAP poses earlier, a true loop closure (with noise)
joins the two poses; then false loop closures join random pairs with random measurements. The
initial estimate is the composed odometry. The same seed gives the same file on every machine:
Python's random module and float repr are platform-independent, and each double is written
with repr, so every compiler reads back the same bits.
"""
import argparse
import math
import random

MIN_GAP = 12
SIGMA = (0.05, 0.05, 0.01)  # odometry and loop noise: x, y (m), theta (rad)
STEPS = ((1, 0), (0, 1), (-1, 0), (0, -1))  # one cell along heading 0, 1, 2, 3 (quarter turns)


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    theta = a[2] + b[2]
    theta = math.atan2(math.sin(theta), math.cos(theta))
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], theta)


def between(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    theta = math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))
    return (c * dx + s * dy, -s * dx + c * dy, theta)


def noisy(rng, z):
    return tuple(z[k] + rng.gauss(0.0, SIGMA[k]) for k in range(3))


def build(poses, edges, false_loops, seed, loop_chance=1.0):
    rng = random.Random(seed)
    truth = [(0.0, 0.0, 0.0)]
    heading = 0
    seen = {(0, 0): [0]}
    cell = (0, 0)
    odometry, loops = [], []
    true_wanted = edges - (poses - 1) - false_loops
    if true_wanted < 0:
        raise SystemExit("make_graph: fewer edges than odometry plus false loops")
    for i in range(1, poses):
        turn = rng.random()
        if turn < 0.15:
            heading = (heading + 1) % 4
        elif turn < 0.30:
            heading = (heading + 3) % 4
        nxt = (cell[0] + STEPS[heading][0], cell[1] + STEPS[heading][1])
        if abs(nxt[0]) > 7 or abs(nxt[1]) > 7:  # stay inside a 15 x 15 block: turn around
            heading = (heading + 2) % 4
            nxt = (cell[0] + STEPS[heading][0], cell[1] + STEPS[heading][1])
        cell = nxt
        pose = (float(cell[0]), float(cell[1]), math.atan2(math.sin(heading * math.pi / 2),
                                                            math.cos(heading * math.pi / 2)))
        truth.append(pose)
        odometry.append((i - 1, i, noisy(rng, between(truth[i - 1], pose))))
        earlier = [j for j in seen.get(cell, []) if i - j >= MIN_GAP]
        # loop_chance < 1 (the stream) spreads the loop closures along the whole walk; the
        # extra draw is made only then, so the batch graph is the same as before
        if earlier and len(loops) < true_wanted and (loop_chance >= 1.0 or
                                                     rng.random() < loop_chance):
            j = rng.choice(earlier)
            loops.append((j, i, noisy(rng, between(truth[j], pose)), 0))
        seen.setdefault(cell, []).append(i)
    if len(loops) < true_wanted:
        raise SystemExit(f"make_graph: only {len(loops)} true loops for {true_wanted} wanted")
    taken = {(a, b) for a, b, _, _ in loops} | {(a, b) for a, b, _ in odometry}
    while len(loops) < true_wanted + false_loops:
        a, b = sorted(rng.sample(range(poses), 2))
        if b - a < MIN_GAP or (a, b) in taken:
            continue
        taken.add((a, b))
        z = (rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), rng.uniform(-math.pi, math.pi))
        loops.append((a, b, z, 1))
    estimate = [(0.0, 0.0, 0.0)]
    for _, _, z in odometry:
        estimate.append(compose(estimate[-1], z))
    return estimate, odometry, loops, truth


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=500)
    parser.add_argument("--edges", type=int, default=600)
    parser.add_argument("--false-loops", type=int, default=20)
    parser.add_argument("--seed", type=int, default=2013)
    parser.add_argument("--loop-chance", type=float, default=1.0,
                        help="chance of a loop closure at each return to a cell (1: every one "
                             "until the count is reached)")
    parser.add_argument("--name", default="firmware",
                        help="prefix of the C names (firmware_poses, FIRMWARE_POSES, ...)")
    parser.add_argument("--stream", action="store_true",
                        help="edges in arrival order (by their later pose, odometry first) and "
                             "the true poses as a third table, NAME_truth")
    parser.add_argument("-o", "--output", required=True)
    args = parser.parse_args()
    estimate, odometry, loops, truth = build(args.poses, args.edges, args.false_loops, args.seed,
                                             args.loop_chance)
    name, macro = args.name, args.name.upper()
    info = (400.0, 400.0, 10000.0)  # 1 / SIGMA**2
    out = [
        "/* Generated by make_graph.py at build time: do not edit. */",
        f'#include "{name}_graph.h"',
        "",
        f"const double {name}_information[3] = {{{', '.join(repr(v) for v in info)}}};",
        f"const fw_pose_t {name}_poses[{macro}_POSES] = {{",
    ]
    out += [f"    {{{repr(x)}, {repr(y)}, {repr(t)}}}," for x, y, t in estimate]
    out.append("};")
    rows = [(a, b, z, 0) for a, b, z in odometry] + [(a, b, z, 1 + f) for a, b, z, f in loops]
    if args.stream:
        rows.sort(key=lambda row: (max(row[0], row[1]), row[3] != 0))
        out.append(f"const fw_pose_t {name}_truth[{macro}_POSES] = {{")
        out += [f"    {{{repr(x)}, {repr(y)}, {repr(t)}}}," for x, y, t in truth]
        out.append("};")
    out.append(f"const fw_edge_t {name}_edges[{macro}_EDGES] = {{")
    out += [f"    {{{a}, {b}, {k}, {{{repr(z[0])}, {repr(z[1])}, {repr(z[2])}}}}},"
            for a, b, z, k in rows]
    out.append("};")
    header = [
        "/* Generated by make_graph.py at build time: do not edit. */",
        f"#ifndef {macro}_GRAPH_H",
        f"#define {macro}_GRAPH_H",
        "",
        f"#define {macro}_POSES {args.poses}u",
        f"#define {macro}_EDGES {len(rows)}u",
        f"#define {macro}_FALSE_LOOPS {args.false_loops}u",
        "",
        "#ifndef FW_GRAPH_TYPES",
        "#define FW_GRAPH_TYPES",
        "typedef struct fw_pose { double x, y, theta; } fw_pose_t;",
        "/* kind: 0 odometry, 1 true loop closure, 2 false loop closure (the truth, for the report) */",
        "typedef struct fw_edge { unsigned short from, to; unsigned char kind; double z[3]; } fw_edge_t;",
        "#endif",
        "",
        f"extern const double {name}_information[3]; /* diagonal, x y theta */",
        f"extern const fw_pose_t {name}_poses[{macro}_POSES];",
        f"extern const fw_edge_t {name}_edges[{macro}_EDGES];",
    ]
    if args.stream:
        header.append(f"extern const fw_pose_t {name}_truth[{macro}_POSES]; /* the true poses */")
    header += ["", "#endif"]
    with open(args.output, "w") as f:
        f.write("\n".join(out) + "\n")
    with open(args.output.rsplit(".", 1)[0] + ".h", "w") as f:
        f.write("\n".join(header) + "\n")


if __name__ == "__main__":
    main()
