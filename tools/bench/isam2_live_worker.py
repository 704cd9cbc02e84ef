#!/usr/bin/env python3
"""GTSAM's iSAM2 with a robust loop-closure kernel fed a graph file as a robot's stream, its
estimate written at checkpoints: ``isam2_live_worker.py METHOD FILE OUTDIR --checkpoints K
[--time-limit S] [--guess anchored|file]``.

The stream, the updates and the gauge are isam2_worker.py's (one ``update()`` per pose, the poses
in the file's VERTEX order, each followed by the edges whose later pose it is; GTSAM's default
ISAM2Params, checked). Methods: ``isam2-cauchy`` (the loop closures in ``noiseModel.Robust`` with
``mEstimator.Cauchy(1)``) and ``isam2-dcs`` (``mEstimator.DCS(1)``, dynamic covariance scaling);
odometry is Gaussian in both.

Checkpoints are pgem-online-driver's: checkpoint i of K the first time the stream holds
ceil(i P / K) of its P poses (after that pose's update), and checkpoint K at the end, also when
``--time-limit`` stopped the stream early. Each is ``calculateEstimate()`` (not timed) written as
OUTDIR/checkpoint_II.g2o (vertices) and OUTDIR/checkpoint_II.weights (pgem's weights format: every
loop closure so far with its kernel weight at that estimate), and a JSON line of type checkpoint.
Update lines as isam2_worker.py's, then a summary line. One error line on stderr and status 1 on
failure.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (g2o parsing, vertices output)
import gtsam_worker  # noqa: E402  (kernel scale, weights file)
import isam2_worker  # noqa: E402  (the stream and its updates)

METHODS = ("isam2-cauchy", "isam2-dcs")


class LiveStream(isam2_worker.Stream):
    """isam2_worker's stream with the method's kernel on the loop closures."""

    def __init__(self, gtsam: Any, parsed: bench_gn.G2oGraph, method: str, guess: str) -> None:
        super().__init__(gtsam, parsed, "isam2-cauchy", guess)
        if method == "isam2-dcs":
            self.kernel = gtsam.noiseModel.mEstimator.DCS.Create(gtsam_worker.KERNEL_SCALE)


def checkpoint_poses(index: int, count: int, total: int) -> int:
    """The poses the stream holds at checkpoint index of count: ceil(index total / count)."""
    return -(-index * total // count)


def write_checkpoint(stream: LiveStream, outdir: Path, index: int, count: int, end: bool) -> dict[str, Any]:
    """The whole estimate now and the loops' weights at it; the checkpoint's JSON line."""
    values = stream.isam.calculateEstimate()
    graph, weights_path = outdir / f"checkpoint_{index:02d}.g2o", outdir / f"checkpoint_{index:02d}.weights"
    bench_gn.write_vertices(graph, values, stream.inserted, stream.parsed.is_3d)
    weights = isam2_worker.final_weights(stream, values)
    gtsam_worker.write_weights(weights_path, stream.loops, weights)
    return {"type": "checkpoint", "checkpoint": index, "of": count, "poses": len(stream.inserted),
            "edges": stream.edges, "end": end, "graph": str(graph), "weights": str(weights_path),
            "loops": len(stream.loops), "rejected": sum(w < gtsam_worker.REJECT_BELOW for w in weights)}


def run(method: str, path: Path, outdir: Path, checkpoints: int, time_limit: float | None,
        guess: str) -> dict[str, Any]:
    """Streams the file; prints the update and checkpoint lines; returns the summary."""
    import gtsam  # imported here: the parent process imports this module without it

    parsed = bench_gn.parse_g2o(path)
    if not parsed.vertex_ids:
        raise bench_gn.BenchError(f"{path} has no VERTEX lines (the worker needs the initial guesses)")
    outdir.mkdir(parents=True, exist_ok=True)
    stream = LiveStream(gtsam, parsed, method, guess)
    per_pose = isam2_worker.stream_order(parsed)
    total = len(parsed.vertex_ids)
    started = time.perf_counter()
    update_seconds = estimate_seconds = 0.0
    stopped, written = False, 0
    for pose, key in enumerate(parsed.vertex_ids):
        stream.add_pose(key)
        for edge in per_pose[pose]:
            stream.add_edge(edge)
        if stream.edges > 0:
            line = stream.update(pose, key)
            update_seconds += line["seconds"]
            estimate_seconds += line["estimate_seconds"]
            print(json.dumps(line), flush=stream.updates % 100 == 0)
        while written + 1 < checkpoints and pose + 1 >= checkpoint_poses(written + 1, checkpoints, total):
            written += 1
            print(json.dumps(write_checkpoint(stream, outdir, written, checkpoints, False)), flush=True)
        if time_limit is not None and time.perf_counter() - started > time_limit and pose + 1 < total:
            stopped = True
            break
    last = write_checkpoint(stream, outdir, checkpoints, checkpoints, True)
    print(json.dumps(last), flush=True)
    return {"type": "summary", "input": str(path), "method": method, "guess": guess,
            "parameters": isam2_worker.PARAMETERS, "kernel_scale": gtsam_worker.KERNEL_SCALE,
            "poses": len(stream.inserted), "poses_total": total, "edges": stream.edges,
            "edges_total": len(parsed.edge_from), "updates": stream.updates, "stopped": stopped,
            "time_limit": time_limit, "update_seconds": update_seconds, "estimate_seconds": estimate_seconds,
            "wall_seconds": time.perf_counter() - started, "checkpoints": written + 1, "loops": last["loops"],
            "rejected": last["rejected"]}


def command(method: str, path: Path, outdir: Path, checkpoints: int, time_limit: float | None,
            guess: str = "anchored") -> list[str]:
    """The command line of one run in a fresh Python process."""
    extra = ["--time-limit", repr(time_limit)] if time_limit is not None else []
    return [sys.executable, str(Path(__file__).resolve()), method, str(path), str(outdir), "--checkpoints",
            str(checkpoints), "--guess", guess, *extra]


def main(argv: Sequence[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("method", choices=METHODS)
    parser.add_argument("file", type=Path)
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--checkpoints", type=int, required=True, help="checkpoints over the stream (K >= 1)")
    parser.add_argument("--time-limit", type=float, help="stop streaming after this many seconds")
    parser.add_argument("--guess", choices=isam2_worker.GUESSES, default="anchored")
    args = parser.parse_args(argv)
    if args.checkpoints < 1:
        parser.error("--checkpoints needs at least 1")
    try:
        summary = run(args.method, args.file, args.outdir, args.checkpoints, args.time_limit, args.guess)
        print(json.dumps(summary), flush=True)
    except Exception as error:  # any GTSAM exception is a failed run, reported in one line
        message = " ".join(str(error).split()) or type(error).__name__
        print(f"isam2 live worker: {type(error).__name__}: {message}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
