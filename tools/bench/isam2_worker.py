#!/usr/bin/env python3
"""GTSAM's iSAM2 fed a graph file as a robot's stream, one ``update()`` per pose:
``isam2_worker.py METHOD FILE OUTDIR [--time-limit S] [--guess anchored|file]``.

The stream is pgem-online-driver's: the poses in the file's VERTEX order, each followed by
every edge whose later pose it is, in file order; after each pose's edges one ``update()``
(the first once the graph has an edge: poses 0 and 1, the gauge prior and their odometry).
Methods: ``isam2`` (every edge a plain Gaussian BetweenFactor: iSAM2 has no robust layer by
default) and ``isam2-cauchy`` (the loop closures wrapped in ``noiseModel.Robust`` with
``mEstimator.Cauchy(1)``, odometry Gaussian). The gauge is bench_gn's: a prior of sigma 1e-6
on the first pose (or the FIX poses). ISAM2Params are GTSAM's defaults (see PARAMETERS).

With ``--guess anchored`` (default) a new pose joined by odometry to a pose already in iSAM2
starts at that pose's current estimate composed with the measurement, as the LCM bridge (and
pgem-online-driver) place a new pose; ``--guess file`` inserts the file's VERTEX values.

Each update is timed alone (``update()``), then ``calculateEstimate()`` of the whole estimate
separately; neither includes building the factors in Python. One JSON line per update on
stdout, then a summary line; OUTDIR/result.g2o (vertices) and OUTDIR/weights.txt (pgem's
format) at the end, also when ``--time-limit`` stopped the stream early. One error line on
stderr and status 1 on failure.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Sequence

try:
    import numpy as np
except ImportError:  # the parent processes import this module for command() without numpy
    np = None

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (g2o parsing, gauge priors, vertices output)
import gtsam_worker  # noqa: E402  (GTSAM poses and noise models from g2o values, weights file)

METHODS = ("isam2", "isam2-cauchy")
PARAMETERS = {"relinearizeThreshold": 0.1, "relinearizeSkip": 10, "factorization": "CHOLESKY",
              "optimizer": "GaussNewton"}  # what ISAM2Params() gives; checked at start
GUESSES = ("anchored", "file")


def stream_order(parsed: bench_gn.G2oGraph) -> list[list[int]]:
    """Per pose (VERTEX order), the edges whose later pose it is, in file order."""
    position = {vertex: index for index, vertex in enumerate(parsed.vertex_ids)}
    per_pose: list[list[int]] = [[] for _ in parsed.vertex_ids]
    for edge, (source, target) in enumerate(zip(parsed.edge_from.tolist(), parsed.edge_to.tolist())):
        per_pose[max(position[source], position[target])].append(edge)
    return per_pose


def check_parameters(gtsam: Any) -> Any:
    """ISAM2Params(), checked against PARAMETERS as it prints itself (a GTSAM with other defaults
    is an error, not a silently different peer)."""
    params = gtsam.ISAM2Params()
    printed = {}
    for line in str(params).splitlines():
        name, sep, value = line.partition(":")
        if sep:
            printed[name.strip()] = value.strip()
    found = {"relinearizeThreshold": float(printed.get("relinearizeThreshold", "nan")),
             "relinearizeSkip": int(printed.get("relinearizeSkip", "-1")),
             "factorization": printed.get("factorization"),
             "optimizer": "GaussNewton" if "GaussNewton" in printed.get("type", "") else printed.get("type")}
    if found != PARAMETERS:
        raise bench_gn.BenchError(f"ISAM2Params() gives {found}, expected {PARAMETERS}")
    return params


class Stream:
    """The iSAM2 instance fed by the stream, and what the next update() will add."""

    def __init__(self, gtsam: Any, parsed: bench_gn.G2oGraph, method: str, guess: str) -> None:
        self.gtsam, self.parsed, self.guess = gtsam, parsed, guess
        self.isam = gtsam.ISAM2(check_parameters(gtsam))
        self.kernel = gtsam.noiseModel.mEstimator.Cauchy.Create(gtsam_worker.KERNEL_SCALE) \
            if method == "isam2-cauchy" else None
        self.between = gtsam.BetweenFactorPose3 if parsed.is_3d else gtsam.BetweenFactorPose2
        self.anchors = set(parsed.fixed_ids or parsed.vertex_ids[:1])
        self.inserted: list[int] = []  # keys in iSAM2, insertion order
        self.settled: set[int] = set()  # keys in iSAM2 or placed by odometry in this batch
        self.loops: list[tuple[int, int, int, Any, Any]] = []  # (edge, from, to, factor, Gaussian model)
        self.updates = 0
        self.edges = 0
        self.reset_batch()

    def reset_batch(self) -> None:
        """An empty batch: the factors and values of the next update()."""
        self.factors = self.gtsam.NonlinearFactorGraph()
        self.values = self.gtsam.Values()
        self.added = self.loops_added = 0

    def estimate_of(self, key: int) -> Any:
        """A pose's current value: placed in this batch, else iSAM2's estimate."""
        if self.values.exists(key):
            return self.values.atPose3(key) if self.parsed.is_3d else self.values.atPose2(key)
        if self.parsed.is_3d:
            return self.isam.calculateEstimatePose3(key)
        return self.isam.calculateEstimatePose2(key)

    def add_pose(self, key: int) -> None:
        """A new pose at its guess from the file, with the gauge prior if it is an anchor."""
        pose = gtsam_worker.gtsam_pose(self.gtsam, self.parsed.poses[key], self.parsed.is_3d)
        self.values.insert(key, pose)
        if key in self.anchors:
            bench_gn.add_gauge_priors(self.gtsam, self.factors, self.values, [key], self.parsed.is_3d)

    def place(self, source: int, target: int, measured: Any) -> None:
        """The bridge's placement: an odometry edge from a settled pose to a new one puts the new
        pose where the measurement says (once iSAM2 has solved anything)."""
        settled = self.settled
        if self.updates == 0 or (source in settled) == (target in settled):
            return
        if source in settled:
            placed_key, value = target, self.estimate_of(source).compose(measured)
        else:
            placed_key, value = source, self.estimate_of(target).compose(measured.inverse())
        self.values.update(placed_key, value)
        settled.add(placed_key)

    def add_edge(self, edge: int) -> None:
        """One edge of the file as a BetweenFactor (the kernel on loop closures, if any)."""
        parsed = self.parsed
        source, target = int(parsed.edge_from[edge]), int(parsed.edge_to[edge])
        gaussian = gtsam_worker.gtsam_gaussian(self.gtsam, parsed.information[edge], parsed.is_3d)
        is_loop = abs(source - target) != 1
        model = self.gtsam.noiseModel.Robust.Create(self.kernel, gaussian) if is_loop and self.kernel else gaussian
        measured = gtsam_worker.gtsam_pose(self.gtsam, parsed.measurements[edge], parsed.is_3d)
        factor = self.between(source, target, measured, model)
        self.factors.add(factor)
        self.added += 1
        self.loops_added += is_loop
        self.edges += 1
        if is_loop:
            self.loops.append((edge, source, target, factor, gaussian))
        elif self.guess == "anchored":
            self.place(source, target, measured)

    def update(self, pose: int, key: int) -> dict[str, Any]:
        """One update() of the batch, timed, then calculateEstimate(), timed; its JSON line."""
        keys = [int(k) for k in self.values.keys()]
        start = time.perf_counter()
        result = self.isam.update(self.factors, self.values)
        seconds = time.perf_counter() - start
        start = time.perf_counter()
        self.isam.calculateEstimate()
        estimate_seconds = time.perf_counter() - start
        self.inserted += keys
        self.settled.update(keys)
        self.updates += 1
        line = {"type": "update", "update": self.updates, "pose": pose, "id": key, "poses": len(self.inserted),
                "edges": self.edges, "added": self.added, "loops_added": self.loops_added, "seconds": seconds,
                "estimate_seconds": estimate_seconds, "relinearized": int(result.getVariablesRelinearized()),
                "reeliminated": int(result.getVariablesReeliminated())}
        self.reset_batch()
        return line


def final_weights(stream: Stream, values: Any) -> list[float]:
    """Every loop's weight at the final estimate: 1 for plain factors; for Cauchy the
    m-estimator's weight of the norm of the Gaussian-whitened error (as gtsam_worker)."""
    if stream.kernel is None:
        return [1.0] * len(stream.loops)
    return [float(stream.kernel.weight(float(np.linalg.norm(gaussian.whiten(factor.unwhitenedError(values))))))
            for _, _, _, factor, gaussian in stream.loops]


def run(method: str, path: Path, outdir: Path, time_limit: float | None, guess: str) -> dict[str, Any]:
    """Streams the file; prints the update lines; writes the result files; returns the summary."""
    import gtsam  # imported here: the parent process imports this module without it

    parsed = bench_gn.parse_g2o(path)
    if not parsed.vertex_ids:
        raise bench_gn.BenchError(f"{path} has no VERTEX lines (the worker needs the initial guesses)")
    stream = Stream(gtsam, parsed, method, guess)
    per_pose = stream_order(parsed)
    started = time.perf_counter()
    update_seconds = estimate_seconds = 0.0
    stopped = False
    for pose, key in enumerate(parsed.vertex_ids):
        stream.add_pose(key)
        for edge in per_pose[pose]:
            stream.add_edge(edge)
        if stream.edges == 0:
            continue  # the first pose alone: nothing to solve
        line = stream.update(pose, key)
        update_seconds += line["seconds"]
        estimate_seconds += line["estimate_seconds"]
        print(json.dumps(line), flush=stream.updates % 100 == 0)
        if time_limit is not None and time.perf_counter() - started > time_limit and pose + 1 < len(per_pose):
            stopped = True
            break
    values = stream.isam.calculateEstimate()
    weights = final_weights(stream, values)
    outdir.mkdir(parents=True, exist_ok=True)
    bench_gn.write_vertices(outdir / gtsam_worker.RESULT_FILE, values, stream.inserted, parsed.is_3d)
    gtsam_worker.write_weights(outdir / gtsam_worker.WEIGHTS_FILE, stream.loops, weights)
    return {"type": "summary", "input": str(path), "method": method, "guess": guess, "parameters": PARAMETERS,
            "poses": len(stream.inserted), "poses_total": len(parsed.vertex_ids), "edges": stream.edges,
            "edges_total": len(parsed.edge_from), "updates": stream.updates, "stopped": stopped,
            "time_limit": time_limit, "update_seconds": update_seconds, "estimate_seconds": estimate_seconds,
            "wall_seconds": time.perf_counter() - started, "loops": len(stream.loops),
            "rejected": sum(w < gtsam_worker.REJECT_BELOW for w in weights)}


def command(method: str, path: Path, outdir: Path, time_limit: float | None, guess: str) -> list[str]:
    """The command line of one run in a fresh Python process."""
    extra = ["--time-limit", repr(time_limit)] if time_limit is not None else []
    return [sys.executable, str(Path(__file__).resolve()), method, str(path), str(outdir), "--guess", guess, *extra]


def main(argv: Sequence[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("method", choices=METHODS)
    parser.add_argument("file", type=Path)
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--time-limit", type=float, help="stop streaming after this many seconds")
    parser.add_argument("--guess", choices=GUESSES, default="anchored")
    args = parser.parse_args(argv)
    try:
        print(json.dumps(run(args.method, args.file, args.outdir, args.time_limit, args.guess)), flush=True)
    except Exception as error:  # any GTSAM exception is a failed run, reported in one line
        message = " ".join(str(error).split()) or type(error).__name__
        print(f"isam2 worker: {type(error).__name__}: {message}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
