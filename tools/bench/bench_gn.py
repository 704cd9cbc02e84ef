#!/usr/bin/env python3
"""Speed and memory benchmark of pgem's Gauss-Newton solver against GTSAM's.

For each dataset the script runs ``pgem optimize --json`` and a GTSAM Gauss-Newton solve
N times each, interleaved (pgem, GTSAM, pgem, GTSAM, ...) so that drift of a shared
machine hits both sides alike. Every GTSAM solve runs in a fresh Python subprocess
(``bench_gn.py --gtsam-worker FILE``) so that its memory measurement starts clean.

What is compared:

* solve time: pgem's ``solve_seconds`` (the ``pgem_optimize`` call) against the wall time of
  ``GaussNewtonOptimizer(graph, initial, params).optimize()``; file reading and graph
  building are excluded on both sides, and so is pgem's first symbolic analysis, which the
  command runs while loading to size its block to the factor;
* memory: pgem's fixed ``block_bytes`` against GTSAM's peak resident-set growth during
  the solve (VmHWM after the solve minus VmRSS before it);
* final chi2, evaluated for GTSAM by the worker itself in g2o's convention (the one pgem
  reports), so that both numbers measure the same cost.

The result is printed as a Markdown report and written to ``--out``. Only numpy and
gtsam are needed beyond the standard library; gtsam is imported by the worker only, and
numpy only when present (callers that run pgem alone, such as bench.py --peer none, import
this module without it).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import importlib.metadata
import json
import os
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

try:
    import numpy as np
except ImportError:  # only the g2o parsing and the GTSAM worker need it
    np = None

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_DATASETS = REPO_ROOT.parent / "shared" / "datasets"
DEFAULT_PGEM = REPO_ROOT / "build" / "release" / "tools" / "pgem" / "pgem"
DEFAULT_OUT = REPO_ROOT / "build" / "bench" / "bench_gn.md"
DEFAULT_FILES = ("input_M3500_g2o", "manhattanOlson3500", "intel", "city10000", "sphere2500")
QUICK_FILES = ("intel", "input_M3500_g2o")
SUBDIRS = ("2d", "3d")

MAX_ITERATIONS = 100
GTSAM_ERROR_TOL = 1e-9  # relative and absolute error tolerance (pgem: relative chi2 < 1e-9)
ANCHOR_SIGMA = 1e-6
CHI2_WARN_RELATIVE = 1e-3  # flag final chi2 values that differ by more than this


class BenchError(Exception):
    """A failure that ends the benchmark with a message and a non-zero exit code."""


# --------------------------------------------------------------------------------------
# g2o parsing and chi2 in g2o's convention (used by the GTSAM worker)
# --------------------------------------------------------------------------------------


@dataclass
class G2oGraph:
    """Poses and edges of a g2o file, as arrays, for evaluating chi2."""

    is_3d: bool
    vertex_ids: list[int]  # file order
    fixed_ids: list[int]
    poses: dict[int, np.ndarray]  # 2D: (x, y, theta); 3D: (x, y, z, qx, qy, qz, qw)
    edge_from: np.ndarray
    edge_to: np.ndarray
    measurements: np.ndarray  # (E, 3) or (E, 7), same layout as poses
    information: np.ndarray  # (E, 3, 3) or (E, 6, 6)


def upper_to_symmetric(values: Sequence[float], size: int) -> np.ndarray:
    """Builds a symmetric matrix from its upper triangle given row by row."""
    matrix = np.zeros((size, size))
    matrix[np.triu_indices(size)] = values
    return matrix + np.triu(matrix, 1).T


def parse_g2o(path: Path) -> G2oGraph:
    """Reads VERTEX_SE2/EDGE_SE2 or VERTEX_SE3:QUAT/EDGE_SE3:QUAT lines and FIX lines."""
    vertex_ids: list[int] = []
    fixed_ids: list[int] = []
    poses: dict[int, np.ndarray] = {}
    edges: list[tuple[int, int, list[float], np.ndarray]] = []
    is_3d = False
    with open(path, encoding="ascii", errors="replace") as handle:
        for line in handle:
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            tag = fields[0]
            if tag in ("VERTEX_SE2", "VERTEX_SE3:QUAT"):
                is_3d = tag == "VERTEX_SE3:QUAT"
                vertex_ids.append(int(fields[1]))
                poses[int(fields[1])] = np.array([float(v) for v in fields[2:(9 if is_3d else 5)]])
            elif tag == "EDGE_SE2":
                values = [float(v) for v in fields[3:12]]
                edges.append((int(fields[1]), int(fields[2]), values[:3],
                              upper_to_symmetric(values[3:], 3)))
            elif tag == "EDGE_SE3:QUAT":
                is_3d = True
                values = [float(v) for v in fields[3:31]]
                edges.append((int(fields[1]), int(fields[2]), values[:7],
                              upper_to_symmetric(values[7:], 6)))
            elif tag == "FIX":
                fixed_ids.extend(int(v) for v in fields[1:])
    return G2oGraph(
        is_3d=is_3d,
        vertex_ids=vertex_ids,
        fixed_ids=fixed_ids,
        poses=poses,
        edge_from=np.array([e[0] for e in edges], dtype=np.int64),
        edge_to=np.array([e[1] for e in edges], dtype=np.int64),
        measurements=np.array([e[2] for e in edges]),
        information=np.array([e[3] for e in edges]),
    )


def rotate_2d(theta: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Rotates each row of vectors (N, 2) by the matching angle."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * vectors[:, 0] - s * vectors[:, 1], s * vectors[:, 0] + c * vectors[:, 1]], axis=1)


def residuals_2d(pose_i: np.ndarray, pose_j: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """g2o EDGE_SE2 error: (dx, dy, wrap(dtheta)) of Z^-1 * Xi^-1 * Xj, one row per edge."""
    delta_t = rotate_2d(-pose_i[:, 2], pose_j[:, :2] - pose_i[:, :2])
    delta_theta = pose_j[:, 2] - pose_i[:, 2]
    error_t = rotate_2d(-measured[:, 2], delta_t - measured[:, :2])
    error_theta = np.arctan2(np.sin(delta_theta - measured[:, 2]), np.cos(delta_theta - measured[:, 2]))
    return np.column_stack([error_t, error_theta])


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugates quaternions stored as (x, y, z, w) rows."""
    return np.column_stack([-q[:, :3], q[:, 3]])


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b of (x, y, z, w) rows."""
    va, wa = a[:, :3], a[:, 3:4]
    vb, wb = b[:, :3], b[:, 3:4]
    vector = wa * vb + wb * va + np.cross(va, vb)
    scalar = wa[:, 0] * wb[:, 0] - np.einsum("ij,ij->i", va, vb)
    return np.column_stack([vector, scalar])


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotates each row of v by the matching unit quaternion (x, y, z, w)."""
    u, w = q[:, :3], q[:, 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def normalize_quats(q: np.ndarray) -> np.ndarray:
    """Scales (x, y, z, w) rows to unit length."""
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def residuals_3d(pose_i: np.ndarray, pose_j: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """g2o EDGE_SE3:QUAT error: (translation, quaternion vector with w >= 0) of Z^-1 Xi^-1 Xj."""
    qi, qj, qz = (normalize_quats(p[:, 3:7]) for p in (pose_i, pose_j, measured))
    delta_t = quat_rotate(quat_conjugate(qi), pose_j[:, :3] - pose_i[:, :3])
    delta_q = quat_multiply(quat_conjugate(qi), qj)
    error_t = quat_rotate(quat_conjugate(qz), delta_t - measured[:, :3])
    error_q = normalize_quats(quat_multiply(quat_conjugate(qz), delta_q))
    error_q *= np.where(error_q[:, 3:4] < 0.0, -1.0, 1.0)
    return np.column_stack([error_t, error_q[:, :3]])


def g2o_chi2(graph: G2oGraph, poses: dict[int, np.ndarray]) -> float:
    """Sum over edges of e^T Omega e in g2o's convention for the given pose estimates."""
    pose_i = np.array([poses[i] for i in graph.edge_from])
    pose_j = np.array([poses[j] for j in graph.edge_to])
    residual_fn = residuals_3d if graph.is_3d else residuals_2d
    errors = residual_fn(pose_i, pose_j, graph.measurements)
    return float(np.einsum("ei,eij,ej->", errors, graph.information, errors))


# --------------------------------------------------------------------------------------
# GTSAM worker (runs in its own process)
# --------------------------------------------------------------------------------------


def proc_status_bytes(field_name: str) -> int:
    """A kB field of /proc/self/status (VmRSS, VmHWM) in bytes."""
    with open("/proc/self/status", encoding="ascii") as handle:
        for line in handle:
            if line.startswith(field_name + ":"):
                return int(line.split()[1]) * 1024
    raise BenchError(f"{field_name} not found in /proc/self/status")


def reset_peak_rss() -> bool:
    """Resets VmHWM to the current RSS (Linux clear_refs 5); False if not permitted."""
    try:
        with open("/proc/self/clear_refs", "w", encoding="ascii") as handle:
            handle.write("5")
        return True
    except OSError:
        return False


def gtsam_values_to_poses(values: Any, keys: Sequence[int], is_3d: bool) -> dict[int, np.ndarray]:
    """Extracts poses from a gtsam.Values in the layout of G2oGraph.poses."""
    poses: dict[int, np.ndarray] = {}
    for key in keys:
        if is_3d:
            pose = values.atPose3(key)
            q = pose.rotation().toQuaternion()
            poses[key] = np.concatenate([np.asarray(pose.translation()), [q.x(), q.y(), q.z(), q.w()]])
        else:
            pose = values.atPose2(key)
            poses[key] = np.array([pose.x(), pose.y(), pose.theta()])
    return poses


def add_gauge_priors(gtsam: Any, graph: Any, initial: Any, anchor_ids: Sequence[int], is_3d: bool) -> None:
    """Holds the anchor poses at their initial values with tight priors (pgem's gauge)."""
    noise = gtsam.noiseModel.Isotropic.Sigma(6 if is_3d else 3, ANCHOR_SIGMA)
    for key in anchor_ids:
        if is_3d:
            graph.add(gtsam.PriorFactorPose3(key, initial.atPose3(key), noise))
        else:
            graph.add(gtsam.PriorFactorPose2(key, initial.atPose2(key), noise))


def write_vertices(path: Path, values: Any, vertex_ids: Sequence[int], is_3d: bool) -> None:
    """Writes a gtsam.Values estimate as a vertices-only g2o file (unit quaternions, w last)."""
    poses = gtsam_values_to_poses(values, vertex_ids, is_3d)
    with open(path, "w", encoding="ascii") as handle:
        for vertex in vertex_ids:
            pose = poses[vertex]
            if is_3d:
                q = pose[3:7] / np.linalg.norm(pose[3:7])
                numbers = list(pose[:3]) + list(q)
                handle.write(f"VERTEX_SE3:QUAT {vertex} " + " ".join(f"{v:.17g}" for v in numbers) + "\n")
            else:
                handle.write(f"VERTEX_SE2 {vertex} " + " ".join(f"{v:.17g}" for v in pose) + "\n")


def gtsam_worker(path: Path, result_path: Path | None = None) -> dict[str, Any]:
    """Solves one file with GTSAM Gauss-Newton and returns the measurements as a dict; writes
    the optimised poses to result_path (vertices only) when given."""
    import gtsam  # imported here so the parent process stays small

    parsed = parse_g2o(path)
    graph, initial = gtsam.readG2o(str(path), parsed.is_3d)
    # pgem holds the FIX poses, or the first pose in file order when there is none.
    anchor_ids = parsed.fixed_ids or parsed.vertex_ids[:1]
    add_gauge_priors(gtsam, graph, initial, anchor_ids, parsed.is_3d)
    params = gtsam.GaussNewtonParams()
    params.setMaxIterations(MAX_ITERATIONS)
    params.setRelativeErrorTol(GTSAM_ERROR_TOL)
    params.setAbsoluteErrorTol(GTSAM_ERROR_TOL)

    hwm_reset = reset_peak_rss()
    rss_before = proc_status_bytes("VmRSS")
    start = time.perf_counter()
    optimizer = gtsam.GaussNewtonOptimizer(graph, initial, params)
    result = optimizer.optimize()
    seconds = time.perf_counter() - start
    peak_after = proc_status_bytes("VmHWM")

    keys = parsed.vertex_ids
    if result_path is not None:
        write_vertices(result_path, result, keys, parsed.is_3d)
    return {
        "is_3d": parsed.is_3d,
        "iterations": int(optimizer.iterations()),
        "solve_seconds": seconds,
        "rss_before": rss_before,
        "peak_rss_growth": peak_after - rss_before,
        "peak_reset": hwm_reset,
        "initial_chi2": g2o_chi2(parsed, gtsam_values_to_poses(initial, keys, parsed.is_3d)),
        "final_chi2": g2o_chi2(parsed, gtsam_values_to_poses(result, keys, parsed.is_3d)),
        "gtsam_error": float(graph.error(result)),
    }


# --------------------------------------------------------------------------------------
# Running both sides
# --------------------------------------------------------------------------------------


@dataclass
class Dataset:
    """One benchmark input: a short name and the file path."""

    name: str
    path: Path


@dataclass
class DatasetResult:
    """All runs of both solvers on one dataset."""

    dataset: Dataset
    pgem: list[dict[str, Any]] = field(default_factory=list)
    gtsam: list[dict[str, Any]] = field(default_factory=list)


def progress(message: str) -> None:
    """Prints one progress line to stderr."""
    print(message, file=sys.stderr, flush=True)


def check_pgem_binary(pgem: Path) -> None:
    """Raises BenchError, saying how to build it, unless pgem is an executable file."""
    if not (pgem.is_file() and os.access(pgem, os.X_OK)):
        raise BenchError(f"pgem not found at {pgem}; build it with "
                         "`cmake --preset release && cmake --build --preset release` or pass --pgem")


def pgem_solve_status(summary: Any) -> tuple[bool, bool]:
    """(status is PGEM_OK, estimate usable) of a `pgem optimize --json` summary; output that is
    not a JSON object is neither."""
    if not isinstance(summary, dict):
        return False, False
    return summary.get("status") == "PGEM_OK", summary.get("usable") is True


def run_pgem(pgem: Path, dataset: Dataset) -> dict[str, Any]:
    """Runs pgem Gauss-Newton once and returns its JSON summary."""
    command = [str(pgem), "optimize", str(dataset.path), "--json", "--quiet",
               "--solver", "gn", "--max-iterations", str(MAX_ITERATIONS)]
    proc = subprocess.run(command, capture_output=True, text=True, check=False)
    try:
        summary = json.loads(proc.stdout)
    except json.JSONDecodeError:
        summary = None
    solved, usable = pgem_solve_status(summary)
    if proc.returncode != 0 or not solved:
        raise BenchError(f"pgem failed on {dataset.path} (exit {proc.returncode}): "
                         f"{proc.stderr.strip() or proc.stdout.strip()}")
    if not usable:
        raise BenchError(f"pgem returned an unusable estimate on {dataset.path}: {proc.stdout.strip()}")
    return summary


def run_gtsam(dataset: Dataset) -> dict[str, Any]:
    """Runs one GTSAM solve in a fresh worker process and returns its measurements."""
    command = [sys.executable, str(Path(__file__).resolve()), "--gtsam-worker", str(dataset.path)]
    proc = subprocess.run(command, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise BenchError(f"GTSAM worker failed on {dataset.path} (exit {proc.returncode}): "
                         f"{proc.stderr.strip()}")
    return json.loads(proc.stdout)


def bench_dataset(pgem: Path, dataset: Dataset, runs: int) -> DatasetResult:
    """Runs pgem and GTSAM alternately, runs times each."""
    result = DatasetResult(dataset)
    for run in range(1, runs + 1):
        progress(f"[{dataset.name}] run {run}/{runs}: pgem")
        result.pgem.append(run_pgem(pgem, dataset))
        progress(f"[{dataset.name}] run {run}/{runs}: gtsam "
                 f"(pgem {result.pgem[-1]['solve_seconds']:.4f} s)")
        result.gtsam.append(run_gtsam(dataset))
        progress(f"[{dataset.name}] run {run}/{runs}: gtsam {result.gtsam[-1]['solve_seconds']:.4f} s")
    return result


def resolve_datasets(root: Path, names: Sequence[str]) -> tuple[list[Dataset], list[str]]:
    """Finds each name (bare, with .g2o, or a path under root); returns found and missing."""
    found: list[Dataset] = []
    missing: list[str] = []
    for name in names:
        stem = name[:-4] if name.endswith(".g2o") else name
        candidates = [root / name, root / f"{name}.g2o"] + [root / sub / f"{stem}.g2o" for sub in SUBDIRS]
        path = next((c for c in candidates if c.is_file()), None)
        if path is None:
            missing.append(name)
        else:
            found.append(Dataset(Path(stem).name, path))
    return found, missing


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def read_cpu_model() -> str:
    """The first 'model name' of /proc/cpuinfo, or 'unknown'."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as handle:
            for line in handle:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


def pgem_version(pgem: Path) -> str:
    """The first line of `pgem --version`."""
    proc = subprocess.run([str(pgem), "--version"], capture_output=True, text=True, check=False)
    return (proc.stdout or proc.stderr).strip().splitlines()[0] if proc.returncode == 0 else "unknown"


def gtsam_version() -> str:
    """The installed gtsam distribution's version (the module has no __version__)."""
    try:
        return importlib.metadata.version("gtsam")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def binary_fingerprint(path: Path) -> str:
    """Short SHA-256 of a file, to notice a binary rebuilt during the run."""
    return hashlib.sha256(path.read_bytes()).hexdigest()[:12]


def rebuilt_note(pgem: Path, fingerprint: str, what: str) -> str | None:
    """The report's note when the pgem binary no longer has the fingerprint taken before the
    run (what: the results that may mix two builds), else None."""
    if binary_fingerprint(pgem) == fingerprint:
        return None
    return f"the pgem binary changed during the run (rebuilt?); {what} may mix two builds."


def machine_line(pgem: Path, *details: str, gtsam: bool = True) -> str:
    """'Machine: CPUs (model); pgem version (binary sha256); GTSAM and Python versions; details;
    date' (the report's first line); gtsam=False says GTSAM was not run instead of its version."""
    nproc = len(os.sched_getaffinity(0))
    date = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    peer = f"GTSAM {gtsam_version()}" if gtsam else "GTSAM not run"
    return "; ".join([f"Machine: {nproc} CPUs ({read_cpu_model()})",
                      f"{pgem_version(pgem)} (binary sha256 {binary_fingerprint(pgem)})",
                      f"{peer} (Python {sys.version.split()[0]})", *details, date])


def header_line(pgem: Path, runs: int) -> str:
    """Machine, versions, run count and date."""
    return machine_line(pgem, f"{runs} run(s) per solver per dataset, interleaved")


def mib(n_bytes: float) -> str:
    """Bytes as MiB with one decimal."""
    return f"{n_bytes / 2**20:.1f} MiB"


def median_of(runs: list[dict[str, Any]], key: str) -> float:
    """Median of one field over runs."""
    return statistics.median(r[key] for r in runs)


def spread_percent(times: list[float]) -> float:
    """(max - min) as a percentage of the median."""
    med = statistics.median(times)
    return 100.0 * (max(times) - min(times)) / med if med > 0 else 0.0


def main_row(res: DatasetResult) -> str:
    """One row of the main table."""
    p, g = res.pgem, res.gtsam
    p_time, g_time = median_of(p, "solve_seconds"), median_of(g, "solve_seconds")
    p_iter, g_iter = median_of(p, "iterations"), median_of(g, "iterations")
    block, growth = median_of(p, "block_bytes"), median_of(g, "peak_rss_growth")
    cells = [
        res.dataset.name, str(p[0]["poses"]), str(p[0]["edges"]),
        f"{p_time * 1e3:.2f}", f"{g_time * 1e3:.2f}", f"**{g_time / p_time:.1f}x**",
        f"{p_iter:g} / {g_iter:g}",
        f"{p_time / max(p_iter, 1) * 1e3:.2f}", f"{g_time / max(g_iter, 1) * 1e3:.2f}",
        f"{p[-1]['final_chi2']:.4f}", f"{g[-1]['final_chi2']:.4f}",
        mib(block), mib(growth), f"{growth / block:.1f}x",
    ]
    return "| " + " | ".join(cells) + " |"


def spread_row(res: DatasetResult) -> str:
    """One row of the timing-spread table (milliseconds)."""
    cells = [res.dataset.name]
    for runs in (res.pgem, res.gtsam):
        times = [r["solve_seconds"] * 1e3 for r in runs]
        cells += [f"{min(times):.2f}", f"{statistics.median(times):.2f}", f"{max(times):.2f}",
                  f"{spread_percent(times):.0f}%"]
    return "| " + " | ".join(cells) + " |"


def check_notes(res: DatasetResult) -> list[str]:
    """Consistency remarks: chi2 agreement, evaluator check, non-convergence."""
    notes: list[str] = []
    name = res.dataset.name
    p_last, g_last = res.pgem[-1], res.gtsam[-1]
    init_diff = abs(g_last["initial_chi2"] - p_last["initial_chi2"]) / max(p_last["initial_chi2"], 1e-300)
    if init_diff > 1e-6:
        notes.append(f"{name}: the worker's initial chi2 {g_last['initial_chi2']:.6g} differs from "
                     f"pgem's {p_last['initial_chi2']:.6g} (relative {init_diff:.1e}); "
                     f"the chi2 columns may not be comparable.")
    p_chi2, g_chi2 = p_last["final_chi2"], g_last["final_chi2"]
    if abs(g_chi2 - p_chi2) > CHI2_WARN_RELATIVE * max(p_chi2, g_chi2):
        note = f"{name}: final chi2 differs: pgem {p_chi2:.6g}, GTSAM {g_chi2:.6g}."
        if g_last.get("is_3d"):
            note += (" Expected in 3D: gtsam.readG2o applies the file's rotation information to its"
                     " angle-axis error (about twice g2o's quaternion-vector error), so GTSAM minimises"
                     " a different cost that weights rotations 4x; it is at its own optimum, not pgem's.")
        notes.append(note)
    if median_of(res.gtsam, "iterations") >= MAX_ITERATIONS:
        notes.append(f"{name}: GTSAM stopped at the {MAX_ITERATIONS}-iteration limit.")
    if p_last.get("termination") == "max-iterations":
        notes.append(f"{name}: pgem stopped at the iteration limit.")
    if not all(r.get("peak_reset", False) for r in res.gtsam):
        notes.append(f"{name}: VmHWM could not be reset; GTSAM's peak growth may be understated.")
    return notes


def spread_summary(results: list[DatasetResult]) -> str:
    """One sentence on how noisy the timings were."""
    if all(len(res.pgem) < 2 for res in results):
        return "One run per solver: no spread to report (smoke run; do not quote these timings)."
    worst = max(((spread_percent([r["solve_seconds"] for r in runs]), res.dataset.name, side)
                 for res in results for side, runs in (("pgem", res.pgem), ("GTSAM", res.gtsam))),
                default=(0.0, "-", "-"))
    return (f"Largest min-max spread: {worst[0]:.0f}% of the median ({worst[2]} on {worst[1]}). "
            f"Quote the medians and the ratio, not single runs.")


def render_report(results: list[DatasetResult], header: str, extra_notes: list[str], runs: int) -> str:
    """The whole Markdown report."""
    lines = [
        "# pgem vs GTSAM: Gauss-Newton solve time and memory", "", header, "",
        "| dataset | poses | edges | pgem ms | GTSAM ms | GTSAM/pgem time | iterations pgem / GTSAM "
        "| pgem ms/iter | GTSAM ms/iter | pgem final chi2 | GTSAM final chi2 | pgem block "
        "| GTSAM peak RSS growth | GTSAM/pgem memory |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    lines += [main_row(res) for res in results]
    lines += [
        "", f"Times are medians of {runs} run(s) of the solve only (no file reading, no graph building). "
        "GTSAM/pgem time = how many times faster pgem is. Chi2 is in g2o's convention for both.",
        "", "Timing spread (ms):", "",
        "| dataset | pgem min | pgem median | pgem max | pgem spread | GTSAM min | GTSAM median "
        "| GTSAM max | GTSAM spread |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    lines += [spread_row(res) for res in results]
    lines += ["", spread_summary(results)]
    notes = list(extra_notes)
    notes += [note for res in results for note in check_notes(res)]
    if notes:
        lines += ["", "Notes:", ""] + [f"- {note}" for note in notes]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Command-line options."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=None, help="runs per solver per dataset (default 5)")
    parser.add_argument("--datasets", type=Path, default=DEFAULT_DATASETS,
                        help=f"datasets folder (default {DEFAULT_DATASETS})")
    parser.add_argument("--pgem", type=Path, default=DEFAULT_PGEM, help=f"pgem binary (default {DEFAULT_PGEM})")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"Markdown report (default {DEFAULT_OUT})")
    parser.add_argument("--files", default=None,
                        help="comma-separated dataset names or paths under --datasets "
                             f"(default {','.join(DEFAULT_FILES)})")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke run: 1 run, only {' and '.join(QUICK_FILES)}")
    parser.add_argument("--gtsam-worker", type=Path, metavar="FILE", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.runs is None:
        args.runs = 1 if args.quick else 5
    if args.runs < 1:
        parser.error("--runs must be at least 1")
    names = args.files.split(",") if args.files else (QUICK_FILES if args.quick else DEFAULT_FILES)
    args.names = [n.strip() for n in names if n.strip()]
    return args


def run_benchmark(args: argparse.Namespace) -> None:
    """Checks the inputs, runs every dataset and writes the report."""
    check_pgem_binary(args.pgem)
    datasets, missing = resolve_datasets(args.datasets, args.names)
    for name in missing:
        progress(f"note: dataset {name} not found under {args.datasets}, skipping it")
    if not datasets:
        raise BenchError(f"none of the datasets {', '.join(args.names)} found under {args.datasets}")
    fingerprint = binary_fingerprint(args.pgem)
    header = header_line(args.pgem, args.runs)
    progress(header)
    results = [bench_dataset(args.pgem, dataset, args.runs) for dataset in datasets]
    notes = [f"{name}: dataset not found, skipped." for name in missing]
    rebuilt = rebuilt_note(args.pgem, fingerprint, "its rows")
    if rebuilt:
        notes.append(rebuilt)
        progress(f"warning: {rebuilt}")
    report = render_report(results, header, notes, args.runs)
    print(report)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report, encoding="utf-8")
    progress(f"report written to {args.out}")


def main(argv: Sequence[str]) -> int:
    """Entry point: benchmark, or the GTSAM worker when --gtsam-worker is given."""
    args = parse_args(argv)
    try:
        if args.gtsam_worker is not None:
            print(json.dumps(gtsam_worker(args.gtsam_worker)))
        else:
            run_benchmark(args)
    except BenchError as error:
        print(f"bench_gn: error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
