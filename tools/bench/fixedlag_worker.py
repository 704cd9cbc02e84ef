#!/usr/bin/env python3
"""GTSAM's IncrementalFixedLagSmoother fed a graph file as a robot's stream, the memory-bounded
peer of bench_longrun.py: ``fixedlag_worker.py FILE OUTDIR --poses N [--time-limit S]``.

The stream is isam2_worker.py's: the poses in the file's VERTEX order, each followed by every
edge whose later pose it is, one ``update()`` per pose; a pose's timestamp is its position in
the stream and the smoother's lag is N - 1, so the window holds the newest N poses, as many as
pgem's block (the smoother marginalises the older ones into a dense prior on the window).
Loop closures are ``noiseModel.Robust`` with ``mEstimator.Cauchy(1)`` around their Gaussian
(gtsam_worker.KERNEL_SCALE), odometry Gaussian; the gauge is a prior of sigma 1e-6 on the first
pose. A loop closure to a pose already marginalised cannot be added (the smoother no longer has
its variable): it is counted as lost. The smoother is built on iSAM2 with ISAM2Params()'s
defaults. A new pose starts at the previous pose's estimate composed with the odometry.

Each pose's estimate is the one it had when it left the window (or the final one for the
poses still in it): OUTDIR/result.g2o (vertices of every pose). One JSON line per update
(seconds of ``update()`` alone) on stdout, then a summary line. One error line on stderr and
status 1 on failure.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import deque
from pathlib import Path
from typing import Any, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (g2o parsing, gauge priors)
import gtsam_worker  # noqa: E402  (GTSAM poses and noise models from g2o values)
import isam2_worker  # noqa: E402  (the stream's order)

RESULT_FILE = "result.g2o"


def pose_values(pose: Any, is_3d: bool) -> list[float]:
    """g2o VERTEX values of a GTSAM pose."""
    if not is_3d:
        return [pose.x(), pose.y(), pose.theta()]
    q = pose.rotation().toQuaternion()
    t = pose.translation()
    return [float(t[0]), float(t[1]), float(t[2]), q.x(), q.y(), q.z(), q.w()]


def run(path: Path, outdir: Path, poses: int, time_limit: float | None) -> dict[str, Any]:
    import gtsam  # imported here: the parent process imports this module without it

    parsed = bench_gn.parse_g2o(path)
    if not parsed.vertex_ids:
        raise bench_gn.BenchError(f"{path} has no VERTEX lines (the worker needs the initial guesses)")
    is_3d = parsed.is_3d
    lag = float(max(1, poses - 1))
    smoother = gtsam.IncrementalFixedLagSmoother(lag, gtsam.ISAM2Params())
    kernel = gtsam.noiseModel.mEstimator.Cauchy.Create(gtsam_worker.KERNEL_SCALE)
    between = gtsam.BetweenFactorPose3 if is_3d else gtsam.BetweenFactorPose2
    estimate = smoother.calculateEstimatePose3 if is_3d else smoother.calculateEstimatePose2
    per_pose = isam2_worker.stream_order(parsed)
    stamp: dict[int, int] = {}  # key -> its position in the stream
    window: deque[int] = deque()  # keys in the window, oldest first
    inside: set[int] = set()
    exited: dict[int, list[float]] = {}
    lost = loops = updates = 0
    seconds: list[float] = []
    started = time.perf_counter()
    stopped = False
    for position, key in enumerate(parsed.vertex_ids):
        factors, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        stamps = gtsam.FixedLagSmootherKeyTimestampMap()
        guess = gtsam_worker.gtsam_pose(gtsam, parsed.poses[key], is_3d)
        edges = []
        for edge in per_pose[position]:
            source, target = int(parsed.edge_from[edge]), int(parsed.edge_to[edge])
            other = source if target == key else target
            is_loop = abs(source - target) != 1
            loops += is_loop
            if other != key and (other not in inside or stamp[other] < position - lag):
                lost += is_loop  # its pose has left the window: nothing to attach it to
                continue
            measured = gtsam_worker.gtsam_pose(gtsam, parsed.measurements[edge], is_3d)
            if not is_loop and other != key:  # the new pose where the odometry puts it
                base = estimate(other)
                guess = base.compose(measured) if source == other else base.compose(measured.inverse())
            gaussian = gtsam_worker.gtsam_gaussian(gtsam, parsed.information[edge], is_3d)
            model = gtsam.noiseModel.Robust.Create(kernel, gaussian) if is_loop else gaussian
            edges.append(between(source, target, measured, model))
        values.insert(key, guess)
        if position == 0:
            bench_gn.add_gauge_priors(gtsam, factors, values, [key], is_3d)
        for factor in edges:
            factors.add(factor)
        stamps.insert((key, float(position)))
        stamp[key] = position
        # the poses this update marginalises: their estimate as they leave
        while window and stamp[window[0]] < position - lag:
            leaving = window.popleft()
            inside.discard(leaving)
            exited[leaving] = pose_values(estimate(leaving), is_3d)
        window.append(key)
        inside.add(key)
        tick = time.perf_counter()
        smoother.update(factors, values, stamps)
        seconds.append(time.perf_counter() - tick)
        updates += 1
        print(json.dumps({"type": "update", "update": updates, "id": key, "seconds": seconds[-1]}),
              flush=updates % 500 == 0)
        if time_limit is not None and time.perf_counter() - started > time_limit:
            stopped = True
            break
    for k in window:
        exited[k] = pose_values(estimate(k), is_3d)
    outdir.mkdir(parents=True, exist_ok=True)
    tag = "VERTEX_SE3:QUAT" if is_3d else "VERTEX_SE2"
    with open(outdir / RESULT_FILE, "w") as out:
        for k in parsed.vertex_ids:
            if k in exited:
                out.write(f"{tag} {k} " + " ".join(repr(float(v)) for v in exited[k]) + "\n")
    return {"type": "summary", "input": str(path), "window": poses, "lag": lag,
            "kernel": f"Cauchy({gtsam_worker.KERNEL_SCALE:g}) on loop closures",
            "poses_out": len(exited), "poses_total": len(parsed.vertex_ids), "updates": updates,
            "loops": loops, "loops_lost": lost, "stopped": stopped,
            "update_seconds": sum(seconds), "wall_seconds": time.perf_counter() - started}


def command(path: Path, outdir: Path, window: int, time_limit: float | None) -> list[str]:
    extra = ["--time-limit", repr(time_limit)] if time_limit is not None else []
    return [sys.executable, str(Path(__file__).resolve()), str(path), str(outdir), "--poses", str(window), *extra]


def main(argv: Sequence[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("file", type=Path)
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--poses", type=int, required=True, help="poses the window holds")
    parser.add_argument("--time-limit", type=float, help="stop streaming after this many seconds")
    args = parser.parse_args(argv)
    try:
        print(json.dumps(run(args.file, args.outdir, args.poses, args.time_limit)), flush=True)
    except Exception as error:  # any GTSAM exception is a failed run, reported in one line
        message = " ".join(str(error).split()) or type(error).__name__
        print(f"fixed-lag worker: {type(error).__name__}: {message}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
