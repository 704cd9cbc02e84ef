#!/usr/bin/env python3
"""EM on a corrupted graph, with covariance ellipses: a robot drives laps of a block with noisy
odometry and true loop closures; 40 false loop closures are added between random poses.
Plain least squares bends the map onto them; pgem's EM rejects them, and each pose's marginal
covariance (one sparse-inverse pass) is drawn as its 95 % position ellipse.

    python3 examples/python/em_covariance.py [OUT.png]      (needs pgem, numpy, matplotlib)
"""
import math
import sys

import numpy as np

import pgem

RNG = np.random.default_rng(7)
SIGMA = np.array([0.05, 0.05, 0.01])  # odometry noise: x, y (m), theta (rad)
INFORMATION = np.diag(1.0 / SIGMA**2)
SIDE, LAPS, FALSE_LOOPS = 20, 6, 40


def compose(a, d):
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * d[0] - s * d[1], a[1] + s * d[0] + c * d[1],
                     math.atan2(math.sin(a[2] + d[2]), math.cos(a[2] + d[2]))])


def between(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy,
                     math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))])


def world():
    """Truth, odometry measurements and loop closures of laps around a square block: every
    third pose of a lap closes a loop to the same place one lap before."""
    truth = [np.zeros(3)]
    for k in range(1, 4 * SIDE * LAPS):
        turn = math.pi / 2 if k % SIDE == 0 else 0.0
        truth.append(compose(truth[-1], [1.0, 0.0, turn]))
    truth = np.array(truth)
    odometry = [between(truth[k - 1], truth[k]) + RNG.normal(0, SIGMA) for k in range(1, len(truth))]
    loops = [(k - 4 * SIDE, k) for k in range(4 * SIDE, len(truth), 3)]
    measured = [between(truth[a], truth[b]) + RNG.normal(0, SIGMA) for a, b in loops]
    return truth, odometry, list(zip(loops, measured))


def build(odometry, loops, false_loops):
    count = len(odometry) + 1
    graph = pgem.Graph(2, count, count + len(loops) + len(false_loops))
    pose = np.zeros(3)
    graph.add_pose(0, pose)
    for k, z in enumerate(odometry, start=1):
        pose = compose(pose, z)
        graph.add_pose(k, pose)
        graph.add_edge(k - 1, k, z, INFORMATION)
    for (a, b), z in loops + false_loops:
        graph.add_edge(a, b, z, INFORMATION, loop=True)
    return graph


def ellipse(center, covariance_xy, heading, scale=math.sqrt(5.991)):
    """The 95 % ellipse of a body-frame x-y covariance, in the world frame."""
    c, s = math.cos(heading), math.sin(heading)
    rotation = np.array([[c, -s], [s, c]])
    values, vectors = np.linalg.eigh(rotation @ covariance_xy @ rotation.T)
    angles = np.linspace(0, 2 * math.pi, 60)
    circle = np.stack([np.cos(angles), np.sin(angles)])
    return center[:, None] + vectors @ (scale * np.sqrt(np.maximum(values, 0))[:, None] * circle)


def main(out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    truth, odometry, loops = world()
    count = len(truth)
    false_loops = []
    for _ in range(FALSE_LOOPS):
        a, b = sorted(RNG.choice(count, 2, replace=False))
        false_loops.append(((int(a), int(b)), np.array([RNG.uniform(-10, 10), RNG.uniform(-10, 10),
                                                         RNG.uniform(-math.pi, math.pi)])))
    plain = build(odometry, loops, false_loops)
    plain.optimize("none")
    graph = build(odometry, loops, false_loops)
    summary = graph.optimize("em")
    ids, poses = graph.poses()
    covariances = graph.covariances()
    rows = graph.loop_weights()
    false = {pair for pair, _ in false_loops}
    rejected = {(int(r["from"]), int(r["to"])) for r in rows if r["pruned"]}
    print(f"EM: {summary.rejected} of {len(rows)} loop closures rejected "
          f"({len(rejected & false)} of {len(false)} false ones, {len(rejected - false)} true ones); "
          f"chi2 {summary.final_chi2:.1f}; plain least squares chi2 {plain.chi2():.0f}")
    newest = covariances[-1]
    print(f"newest pose: standard deviations x {math.sqrt(newest[0, 0]):.3f} m, "
          f"y {math.sqrt(newest[1, 1]):.3f} m, theta {math.degrees(math.sqrt(newest[2, 2])):.2f} deg")

    figure, (left, right) = plt.subplots(1, 2, figsize=(13, 6.5))
    _, bent = plain.poses()
    for axes, estimate, title in ((left, bent, "least squares: every loop closure"),
                                  (right, poses, f"EM: {summary.rejected} loop closures rejected")):
        for (a, b), _ in loops + false_loops:
            if axes is left or (a, b) not in rejected:
                color = "tab:red" if (a, b) in false else "0.75"
                axes.plot(estimate[[a, b], 0], estimate[[a, b], 1], color=color, lw=0.6)
        axes.plot(truth[:, 0], truth[:, 1], color="tab:green", lw=0.8, ls="--", label="truth")
        axes.plot(estimate[:, 0], estimate[:, 1], color="tab:blue", lw=1.2, label="estimate")
        axes.set_title(title)
        axes.set_aspect("equal")
    for (a, b) in rejected:
        right.plot(poses[[a, b], 0], poses[[a, b], 1], color="tab:red", lw=0.6, alpha=0.35)
    for k in range(0, count, 8):
        outline = ellipse(poses[k, :2], covariances[k, :2, :2], poses[k, 2])
        right.plot(outline[0], outline[1], color="tab:orange", lw=0.8)
    right.plot([], [], color="tab:red", alpha=0.35, label="rejected loop closures")
    right.plot([], [], color="tab:orange", label="95 % position ellipses (every 8th pose)")
    left.plot([], [], color="tab:red", label="false loop closures")
    left.legend(loc="upper left", fontsize=8)
    right.legend(loc="upper left", fontsize=8)
    figure.tight_layout()
    figure.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0 if rejected == false else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "em_covariance.png"))
