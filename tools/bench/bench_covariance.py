#!/usr/bin/env python3
"""Every pose's marginal covariance: pgem against GTSAM's Marginals, interleaved.

For each dataset the graph is read and solved once by pgem (the Python package), then, N times
each and interleaved (pgem, GTSAM, pgem, GTSAM, ...) so that drift of a shared machine hits
both sides alike, every pose's marginal covariance is computed at that same estimate:

* pgem: ``pgem_covariance_prepare`` (assembly and factorisation at the estimate; the symbolic
  analysis is the solve's, done once) and ``pgem_covariances`` (one sparse inverse on the
  factor's pattern), through ``Graph.covariances()``;
* GTSAM: ``gtsam.Marginals(graph, values)`` (linearisation and elimination into a Bayes tree)
  and ``marginalCovariance(key)`` for every free pose, on the same graph with the first pose
  held by a tight prior and pgem's 3D noise model converted to GTSAM's tangent.

File reading, the solve and graph building are outside the timings. The report gives the
medians, the spread, the ratio GTSAM/pgem, and the agreement of the two (relative Frobenius
norm of the difference, newest pose and worst pose, in GTSAM's order). It is printed as
Markdown and written to ``--out``. Needs the pgem package (``pip install ./python``, or
``PYTHONPATH=build/release/python``), numpy and gtsam.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_DATASETS = REPO_ROOT.parent / "shared" / "datasets"
DEFAULT_OUT = REPO_ROOT / "build" / "bench" / "bench_covariance.md"
DEFAULT_FILES = ("2d/city10000.g2o", "3d/sphere2500.g2o")
QUICK_FILES = ("2d/input_M3500_g2o.g2o",)
HELD_SIGMA = 1e-6  # GTSAM's prior on the first pose (pgem holds it: no column)

sys.path.insert(0, str(REPO_ROOT / "build" / "release" / "python"))  # the build tree's package
sys.path.insert(0, str(REPO_ROOT / "python" / "tests"))  # peers.py: the same graph in GTSAM
sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (the spread every benchmark reports)


class BenchError(Exception):
    """A failure that ends the benchmark with a message."""


@dataclass
class Result:
    """One dataset's runs."""

    name: str
    poses: int
    pgem_seconds: list[float] = field(default_factory=list)
    gtsam_seconds: list[float] = field(default_factory=list)
    newest_error: float = 0.0
    worst_error: float = 0.0


def progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run_pgem(graph: Any) -> tuple[float, Any]:
    """The factor at the estimate and every pose's marginal; seconds and the covariances."""
    start = time.perf_counter()
    graph._graph.prepare_covariance()  # a new factor each run, as a changed graph would need
    covariances = graph.covariances()
    return time.perf_counter() - start, covariances


def run_gtsam(gtsam: Any, problem: Any, values: Any, keys: Sequence[int]) -> tuple[float, list]:
    """Marginals at the estimate and every free pose's covariance; seconds and the matrices."""
    start = time.perf_counter()
    marginals = gtsam.Marginals(problem, values)
    covariances = [marginals.marginalCovariance(int(key)) for key in keys]
    return time.perf_counter() - start, covariances


def bench_dataset(path: Path, runs: int) -> Result:
    import gtsam
    import numpy as np
    import pgem
    from peers import gtsam_problem, read_edges, relative_frobenius

    graph = pgem.read_g2o(path)
    graph.optimize()
    ids, poses = graph.poses()
    problem, values = gtsam_problem(gtsam, read_edges(path), ids, poses)
    result = Result(path.name, len(ids))
    ours = theirs = None
    for run in range(runs):
        seconds, ours = run_pgem(graph)
        result.pgem_seconds.append(seconds)
        seconds, theirs = run_gtsam(gtsam, problem, values, ids[1:])
        result.gtsam_seconds.append(seconds)
        progress(f"{path.name}: run {run + 1}/{runs}: pgem {result.pgem_seconds[-1] * 1e3:.1f} ms, "
                 f"GTSAM {seconds * 1e3:.1f} ms")
    ours = pgem.to_gtsam(ours)
    errors = [relative_frobenius(ours[k + 1], c) for k, c in enumerate(theirs)]
    result.newest_error, result.worst_error = errors[-1], float(np.max(errors))
    return result


def spread(times: list[float]) -> str:
    return f"{bench_gn.spread_percent(times):.0f}%" if statistics.median(times) > 0 else "-"


def render(results: list[Result], runs: int) -> str:
    import importlib.metadata

    import pgem

    try:
        gtsam_version = importlib.metadata.version("gtsam")
    except importlib.metadata.PackageNotFoundError:
        gtsam_version = "?"
    lines = [
        "# Every pose's marginal covariance: pgem vs GTSAM's Marginals", "",
        f"pgem {pgem.__version__}, GTSAM {gtsam_version} (Python "
        f"{sys.version.split()[0]}); {runs} run(s) per side per dataset, interleaved; "
        f"{time.strftime('%Y-%m-%d')}", "",
        "| dataset | poses | pgem ms (median) | pgem spread | GTSAM ms (median) | GTSAM spread "
        "| GTSAM/pgem | newest pose rel. Frobenius | worst pose |",
        "|---|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for r in results:
        p, g = statistics.median(r.pgem_seconds), statistics.median(r.gtsam_seconds)
        lines.append(f"| {r.name} | {r.poses} | {p * 1e3:.1f} | {spread(r.pgem_seconds)} "
                     f"| {g * 1e3:.1f} | {spread(r.gtsam_seconds)} | **{g / p:.0f}x** "
                     f"| {r.newest_error:.1e} | {r.worst_error:.1e} |")
    lines += ["", "pgem: the factor at the estimate and one sparse inverse "
              "(`Graph.covariances()`, one thread). GTSAM: `Marginals(graph, values)` and "
              "`marginalCovariance` per free pose. Spread = (max - min) / median. The agreement "
              "columns compare the last run's matrices in GTSAM's order (`pgem.to_gtsam`)."]
    return "\n".join(lines) + "\n"


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=None, help="runs per side per dataset (default 5)")
    parser.add_argument("--datasets", type=Path, default=DEFAULT_DATASETS,
                        help=f"datasets folder (default {DEFAULT_DATASETS})")
    parser.add_argument("--files", default=None,
                        help=f"comma-separated paths under --datasets (default {','.join(DEFAULT_FILES)})")
    parser.add_argument("--quick", action="store_true", help="1 run on M3500 only")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"Markdown report (default {DEFAULT_OUT})")
    args = parser.parse_args(argv)
    if args.runs is None:
        args.runs = 1 if args.quick else 5
    if args.runs < 1:
        parser.error("--runs must be at least 1")
    names = args.files.split(",") if args.files else (QUICK_FILES if args.quick else DEFAULT_FILES)
    args.paths = [args.datasets / n.strip() for n in names if n.strip()]
    return args


def main(argv: Sequence[str]) -> int:
    args = parse_args(argv)
    try:
        try:
            import gtsam  # noqa: F401
            import pgem  # noqa: F401
        except ImportError as error:
            raise BenchError(f"{error}: build the package (cmake --workflow --preset test, or "
                             "pip install ./python) and pip install gtsam") from error
        missing = [str(p) for p in args.paths if not p.is_file()]
        if missing:
            raise BenchError(f"dataset(s) not found: {', '.join(missing)}")
        results = [bench_dataset(path, args.runs) for path in args.paths]
    except BenchError as error:
        print(f"bench_covariance: error: {error}", file=sys.stderr)
        return 1
    report = render(results, args.runs)
    print(report)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report, encoding="utf-8")
    progress(f"report written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
