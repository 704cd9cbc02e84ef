#!/usr/bin/env python3
"""GTSAM solves for the benchmarks, one per process: ``gtsam_worker.py METHOD FILE OUTDIR``.

Methods: ``gtsam-gn`` (bench_gn's Gauss-Newton solve of the file as it is), ``gtsam-cauchy`` and
``gtsam-dcs`` (Levenberg-Marquardt with the robust noise model on every loop closure),
``gtsam-gnc`` (GncLMOptimizer with the truncated-least-squares loss, the gauge prior and the
odometry declared known inliers, GTSAM's defaults otherwise). The worker reads a g2o file with
VERTEX lines (its initial estimate), writes the estimate to OUTDIR/result.g2o (vertices only)
and, for the robust methods, OUTDIR/weights.txt in pgem's weights format (one ``from to weight
state`` line per loop closure, file order); it prints one JSON object (the solve's time, memory
and counters) on stdout, or one error line on stderr and exits with status 1.

bench.py, bench_robust.py and bench_real.py run it through ``command()``.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

try:
    import numpy as np
except ImportError:  # the parent processes import this module for command() without numpy
    np = None

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (g2o parsing, g2o-convention chi2, gauge priors, Gauss-Newton worker)

BenchError = bench_gn.BenchError

GTSAM_GN = "gtsam-gn"
ROBUST_METHODS = ("gtsam-cauchy", "gtsam-dcs", "gtsam-gnc")
METHODS = (GTSAM_GN, *ROBUST_METHODS)

KERNEL_SCALE = 1.0  # Cauchy c and DCS phi (pgem's --robust-scale default is 1 too)
LM_MAX_ITERATIONS = 100
LM_ERROR_TOL = 1e-9  # relative and absolute error tolerance of GTSAM's LM
REJECT_BELOW = 0.01  # a loop weighted below this is rejected (pgem's prune threshold): not in the kept chi2

RESULT_FILE = "result.g2o"
WEIGHTS_FILE = "weights.txt"
WEIGHTS_HEADER = "# from to weight state (one line per loop closure)"


# --------------------------------------------------------------------------------------
# Robust solves: Cauchy, DCS, GNC
# --------------------------------------------------------------------------------------


def gtsam_pose(gtsam: Any, values: np.ndarray, is_3d: bool) -> Any:
    """A gtsam Pose2 from (x, y, theta) or Pose3 from (x, y, z, qx, qy, qz, qw)."""
    if not is_3d:
        return gtsam.Pose2(float(values[0]), float(values[1]), float(values[2]))
    q = values[3:7] / np.linalg.norm(values[3:7])  # Rot3.Quaternion expects a unit quaternion
    rotation = gtsam.Rot3.Quaternion(float(q[3]), float(q[0]), float(q[1]), float(q[2]))
    return gtsam.Pose3(rotation, gtsam.Point3(*(float(v) for v in values[:3])))


def gtsam_gaussian(gtsam: Any, information: np.ndarray, is_3d: bool) -> Any:
    """Gaussian noise model from a g2o information matrix.

    g2o orders a 3D tangent as (translation, rotation), GTSAM's Pose3 as (rotation,
    translation): the blocks are swapped, as gtsam.readG2o does. The rotation values are
    used unchanged, so GTSAM applies them to its angle-axis error (see the README)."""
    if is_3d:
        order = [3, 4, 5, 0, 1, 2]
        information = information[np.ix_(order, order)]
    return gtsam.noiseModel.Gaussian.Information(np.ascontiguousarray(information))


def lm_params(gtsam: Any) -> Any:
    """Levenberg-Marquardt settings shared by every GTSAM method."""
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(LM_MAX_ITERATIONS)
    params.setRelativeErrorTol(LM_ERROR_TOL)
    params.setAbsoluteErrorTol(LM_ERROR_TOL)
    return params


@dataclass
class WorkerGraph:
    """The GTSAM problem built from one g2o file, with the bookkeeping of its loops."""

    graph: Any
    initial: Any
    vertex_ids: list[int]
    is_3d: bool
    known_inliers: list[int]  # factor indices: gauge priors and odometry
    loops: list[tuple[int, int, int, Any, Any]]  # (factor index, from, to, factor, Gaussian model)
    parsed: bench_gn.G2oGraph  # the file's edges, for the g2o-convention chi2


def build_worker_graph(gtsam: Any, path: Path, kernel: Any) -> WorkerGraph:
    """Reads the file and builds the factor graph; loop closures get the kernel, if any.

    Odometry is every edge with |from - to| == 1 (pgem's reader uses the same rule); every
    other edge is a loop closure. The first pose (or the FIX poses) is held by a prior of
    sigma 1e-6, as pgem holds its gauge."""
    parsed = bench_gn.parse_g2o(path)
    if not parsed.vertex_ids:
        raise BenchError(f"{path} has no VERTEX lines (the worker needs the initial estimate)")
    initial = gtsam.Values()
    for vertex in parsed.vertex_ids:
        initial.insert(vertex, gtsam_pose(gtsam, parsed.poses[vertex], parsed.is_3d))
    graph = gtsam.NonlinearFactorGraph()
    bench_gn.add_gauge_priors(gtsam, graph, initial, parsed.fixed_ids or parsed.vertex_ids[:1], parsed.is_3d)
    known_inliers = list(range(graph.size()))
    loops = []
    between = gtsam.BetweenFactorPose3 if parsed.is_3d else gtsam.BetweenFactorPose2
    for k in range(len(parsed.edge_from)):
        source, target = int(parsed.edge_from[k]), int(parsed.edge_to[k])
        gaussian = gtsam_gaussian(gtsam, parsed.information[k], parsed.is_3d)
        is_loop = abs(source - target) != 1
        model = gtsam.noiseModel.Robust.Create(kernel, gaussian) if is_loop and kernel is not None else gaussian
        factor = between(source, target, gtsam_pose(gtsam, parsed.measurements[k], parsed.is_3d), model)
        index = graph.size()
        graph.add(factor)
        if is_loop:
            loops.append((index, source, target, factor, gaussian))
        else:
            known_inliers.append(index)
    return WorkerGraph(graph, initial, parsed.vertex_ids, parsed.is_3d, known_inliers, loops, parsed)


def write_weights(path: Path, loops: Sequence[tuple[int, int, int, Any, Any]], weights: Sequence[float]) -> None:
    """Writes pgem's weights format; GTSAM never prunes, so every state is 'accepted'."""
    with open(path, "w", encoding="ascii") as handle:
        handle.write(WEIGHTS_HEADER + "\n")
        for (_, source, target, _, _), weight in zip(loops, weights):
            handle.write(f"{source} {target} {weight:.9g} accepted\n")


def kept_chi2(problem: WorkerGraph, values: Any, weights: Sequence[float]) -> float:
    """g2o-convention chi2 at the estimate over the edges kept at weight 1: odometry and every
    loop closure weighted at least REJECT_BELOW (pgem's final chi2 after pruning)."""
    parsed = problem.parsed
    keep = np.abs(parsed.edge_from - parsed.edge_to) == 1
    loop_edges = np.flatnonzero(~keep)  # in file order, as problem.loops and weights
    keep[loop_edges] = np.asarray(weights, dtype=float) >= REJECT_BELOW
    kept = dataclasses.replace(parsed, edge_from=parsed.edge_from[keep], edge_to=parsed.edge_to[keep],
                               measurements=parsed.measurements[keep], information=parsed.information[keep])
    return bench_gn.g2o_chi2(kept, bench_gn.gtsam_values_to_poses(values, problem.vertex_ids, problem.is_3d))


def robust_worker(method: str, path: Path, outdir: Path) -> dict[str, Any]:
    """Solves one corrupted file with one GTSAM method; writes the result and the weights.

    Besides the time, the summary has the peak resident-set growth during the solve (as
    bench_gn measures it), LM's iteration count (not for GNC) and the kept edges' chi2."""
    import gtsam  # imported here so the parent process stays small

    mestimator = gtsam.noiseModel.mEstimator
    kernels = {"gtsam-cauchy": lambda: mestimator.Cauchy.Create(KERNEL_SCALE),
               "gtsam-dcs": lambda: mestimator.DCS.Create(KERNEL_SCALE)}
    if method not in ROBUST_METHODS:
        raise BenchError(f"unknown GTSAM method {method}")
    kernel = kernels[method]() if method in kernels else None
    problem = build_worker_graph(gtsam, path, kernel)
    summary: dict[str, Any] = {"method": method, "loops": len(problem.loops)}

    summary["peak_reset"] = bench_gn.reset_peak_rss()
    rss_before = bench_gn.proc_status_bytes("VmRSS")
    if method == "gtsam-gnc":
        params = gtsam.GncLMParams(lm_params(gtsam))
        params.setLossType(gtsam.GncLossType.TLS)
        params.setKnownInliers(problem.known_inliers)
        start = time.perf_counter()
        optimizer = gtsam.GncLMOptimizer(problem.graph, problem.initial, params)
        result = optimizer.optimize()
        seconds = time.perf_counter() - start
        peak_after = bench_gn.proc_status_bytes("VmHWM")
        all_weights = np.asarray(optimizer.getWeights()).reshape(-1)
        weights = [float(all_weights[index]) for index, *_ in problem.loops]
    else:
        start = time.perf_counter()
        optimizer = gtsam.LevenbergMarquardtOptimizer(problem.graph, problem.initial, lm_params(gtsam))
        result = optimizer.optimize()
        seconds = time.perf_counter() - start
        peak_after = bench_gn.proc_status_bytes("VmHWM")
        summary["iterations"] = int(optimizer.iterations())
        # The weight GTSAM's iteratively reweighted solve gives a robust factor: the
        # m-estimator's weight of the norm of the Gaussian-whitened error (Block reweighting).
        weights = [float(kernel.weight(float(np.linalg.norm(gaussian.whiten(factor.unwhitenedError(result))))))
                   for _, _, _, factor, gaussian in problem.loops]

    summary["solve_seconds"] = seconds
    summary["peak_rss_growth"] = peak_after - rss_before
    summary["final_chi2"] = kept_chi2(problem, result, weights)
    outdir.mkdir(parents=True, exist_ok=True)
    bench_gn.write_vertices(outdir / RESULT_FILE, result, problem.vertex_ids, problem.is_3d)
    write_weights(outdir / WEIGHTS_FILE, problem.loops, weights)
    return summary


# --------------------------------------------------------------------------------------
# Entry points
# --------------------------------------------------------------------------------------


def solve(method: str, path: Path, outdir: Path) -> dict[str, Any]:
    """One solve of the file by one method, its files written into outdir; its summary."""
    if method == GTSAM_GN:
        outdir.mkdir(parents=True, exist_ok=True)
        return bench_gn.gtsam_worker(path, outdir / RESULT_FILE)
    return robust_worker(method, path, outdir)


def command(method: str, path: Path, outdir: Path) -> list[str]:
    """The command line that runs one solve in a fresh Python process."""
    return [sys.executable, str(Path(__file__).resolve()), method, str(path), str(outdir)]


def main(argv: Sequence[str]) -> int:
    """METHOD FILE OUTDIR: JSON on stdout, or a one-line error on stderr and status 1."""
    if len(argv) != 3 or argv[0] not in METHODS:
        print(f"usage: gtsam_worker.py {{{'|'.join(METHODS)}}} FILE OUTDIR", file=sys.stderr)
        return 2
    try:
        print(json.dumps(solve(argv[0], Path(argv[1]), Path(argv[2]))))
    except Exception as error:  # any GTSAM exception is a failed run, reported in one line
        message = " ".join(str(error).split()) or type(error).__name__
        print(f"gtsam worker: {type(error).__name__}: {message}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
