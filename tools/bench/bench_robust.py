#!/usr/bin/env python3
"""Outlier benchmark: pgem's robust solvers against GTSAM's robust kernels and GNC.

For every dataset, false-loop policy, outlier count and seed, the script corrupts the
clean graph with ``pgem corrupt``, solves the corrupted graph with each method and
scores every result with the same command, ``pgem eval``, against the optimum of the
clean graph (the usual protocol of the robust-SLAM literature: no ground truth, the
outlier-free optimum is the reference).

Methods:

* ``pgem-em`` (default EM with pruning and a final re-solve), ``pgem-em-literal`` (EM as
  published, weights kept), ``pgem-dcs``, ``pgem-cauchy``: ``pgem optimize --robust ...``;
  the time is pgem's own ``solve_seconds``;
* ``gtsam-cauchy``, ``gtsam-dcs``: GTSAM Levenberg-Marquardt with a robust noise model on
  every loop closure; ``gtsam-gnc``: GTSAM's GncOptimizer with the truncated-least-squares
  loss on top of Levenberg-Marquardt, odometry and the gauge prior declared known inliers.
  Each GTSAM solve runs in a fresh subprocess (``gtsam_worker.py METHOD FILE OUTDIR``)
  that is killed after ``--timeout`` seconds; the time is the optimizer's construction plus
  ``optimize()``.

Every method writes a vertices-only g2o file and a weights file in pgem's format (one
``from to weight state`` line per loop closure), which ``pgem eval`` turns into trajectory
errors (ATE, RPE) and outlier-rejection scores (precision, recall). The report is Markdown
on stdout and in ``--out``; every run is also written as CSV and JSON beside it.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (shared code: machine header, dataset lookup, pgem checks)
import gtsam_worker  # noqa: E402  (the GTSAM solves, each in its own process)

BenchError = bench_gn.BenchError
progress = bench_gn.progress

REPO_ROOT = bench_gn.REPO_ROOT
DEFAULT_DATASETS = bench_gn.DEFAULT_DATASETS
DEFAULT_PGEM = bench_gn.DEFAULT_PGEM
DEFAULT_OUT = REPO_ROOT / "build" / "bench" / "bench_robust.md"
DEFAULT_WORK = REPO_ROOT / "build" / "bench" / "robust"

DEFAULT_FILES = ("input_M3500_g2o", "intel", "city10000", "sphere2500")
POLICIES = ("random", "local", "random-grouped", "local-grouped")
DEFAULT_COUNTS = (10, 100, 1000)
DEFAULT_SEEDS = (1, 2, 3)
QUICK_FILES = ("input_M3500_g2o", "intel")
QUICK_POLICIES = ("random", "local-grouped")
QUICK_COUNTS = (100,)
QUICK_SEEDS = (1,)

# pgem methods: extra arguments of `pgem optimize`.
PGEM_METHODS = {
    "pgem-em": ["--robust", "em"],
    "pgem-em-literal": ["--robust", "em", "--literal"],
    "pgem-dcs": ["--robust", "dcs"],
    "pgem-cauchy": ["--robust", "cauchy"],
}
GTSAM_METHODS = gtsam_worker.ROBUST_METHODS
ALL_METHODS = tuple(PGEM_METHODS) + GTSAM_METHODS
DEFAULT_METHODS = ("pgem-em", "gtsam-cauchy", "gtsam-dcs", "gtsam-gnc")
BASELINE = "pgem-em"  # the method the GTSAM times and accuracies are compared with

KERNEL_SCALE = gtsam_worker.KERNEL_SCALE
LM_MAX_ITERATIONS = gtsam_worker.LM_MAX_ITERATIONS
LM_ERROR_TOL = gtsam_worker.LM_ERROR_TOL
DEFAULT_TIMEOUT = 300.0
DEFAULT_REJECT_BELOW = gtsam_worker.REJECT_BELOW
ATE_WORSE_RELATIVE = 0.05  # summary: pgem-em "less accurate" when its ATE is 5 % higher ...
ATE_WORSE_ABSOLUTE = 1e-3  # ... and at least 1 mm higher than the best GTSAM method's

RESULT_FILE = gtsam_worker.RESULT_FILE
WEIGHTS_FILE = gtsam_worker.WEIGHTS_FILE
EVAL_KEYS = ("poses_matched", "ate_translation_rmse", "ate_rotation_rmse_deg", "rpe_translation_rmse",
             "rpe_rotation_rmse_deg", "extent_rms", "ate_relative", "loops", "outliers", "rejected",
             "true_positives", "false_positives", "false_negatives", "precision", "recall",
             "inlier_precision", "inlier_recall")
SOLVER_KEYS = ("iterations", "rounds", "em_iterations", "gn_iterations", "pruned", "readmitted",
               "initial_chi2", "final_chi2", "termination", "poses", "edges", "analyses", "factor_nonzeros",
               "block_bytes", "block_bytes_per_pose", "block_bytes_per_edge", "block_bytes_factor",
               "peak_rss_growth", "peak_reset", "is_3d")


def first_line(text: str) -> str:
    """The first non-empty line of a process's output, or a placeholder."""
    for line in text.splitlines():
        if line.strip():
            return line.strip()
    return "(no message)"


# --------------------------------------------------------------------------------------
# Running one grid cell
# --------------------------------------------------------------------------------------


@dataclass
class Run:
    """One method on one corrupted graph: status, time and scores."""

    dataset: str
    policy: str
    count: int
    seed: int
    method: str
    status: str = "ok"  # ok | failed | timeout
    error: str = ""
    solve_seconds: float | None = None
    wall_seconds: float = 0.0
    solver: dict[str, Any] = field(default_factory=dict)
    scores: dict[str, Any] = field(default_factory=dict)


class RunFailure(Exception):
    """One run failed; the message is what the report shows."""

    def __init__(self, message: str, status: str = "failed") -> None:
        super().__init__(message)
        self.status = status


def run_command(command: Sequence[str], what: str, timeout: float | None = None) -> str:
    """Runs a command and returns its stdout; raises RunFailure with stderr's first line."""
    try:
        proc = subprocess.run(list(command), capture_output=True, text=True, check=False, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise RunFailure(f"{what}: killed after {timeout:g} s", "timeout") from None
    except OSError as error:
        raise RunFailure(f"{what}: {error}") from None
    if proc.returncode != 0:
        raise RunFailure(f"{what} (exit {proc.returncode}): {first_line(proc.stderr or proc.stdout)}")
    return proc.stdout


def parse_json(text: str, what: str) -> dict[str, Any]:
    """Parses one JSON object printed by a command."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        raise RunFailure(f"{what}: output is not JSON: {first_line(text)}") from None
    if not isinstance(value, dict):
        raise RunFailure(f"{what}: output is not a JSON object")
    return value


def is_fresh(path: Path, *sources: Path) -> bool:
    """True if path exists and is newer than every source."""
    if not path.is_file():
        return False
    mtime = path.stat().st_mtime
    return all(mtime > source.stat().st_mtime for source in sources)


def make_reference(pgem: Path, clean: Path, workdir: Path) -> Path:
    """The clean graph's optimum (pgem Gauss-Newton), cached while newer than the input."""
    reference = workdir / "ref.g2o"
    if not is_fresh(reference, clean):
        workdir.mkdir(parents=True, exist_ok=True)
        run_command([str(pgem), "optimize", str(clean), "-o", str(reference), "--quiet"],
                    "pgem optimize (reference)")
    return reference


def make_corrupted(pgem: Path, clean: Path, celldir: Path, policy: str, count: int, seed: int,
                   group_size: int | None) -> Path:
    """The corrupted graph of one grid cell (and its .outliers list), cached."""
    corrupted = celldir / "corrupted.g2o"
    outliers = Path(str(corrupted) + ".outliers")
    if not (is_fresh(corrupted, clean) and outliers.is_file()):
        celldir.mkdir(parents=True, exist_ok=True)
        command = [str(pgem), "corrupt", str(clean), "-o", str(corrupted), "--policy", policy,
                   "--count", str(count), "--seed", str(seed)]
        if group_size is not None:
            command += ["--group-size", str(group_size)]
        run_command(command, "pgem corrupt")
    return corrupted


def pgem_optimize(pgem: Path, graph: Path, options: Sequence[str], outdir: Path) -> dict[str, Any]:
    """`pgem optimize GRAPH OPTIONS --json --quiet`, writing RESULT_FILE and WEIGHTS_FILE into
    outdir; returns its JSON summary, or raises RunFailure unless the estimate is usable."""
    outdir.mkdir(parents=True, exist_ok=True)
    command = [str(pgem), "optimize", str(graph), *options, "--json", "--quiet",
               "-o", str(outdir / RESULT_FILE), "--weights", str(outdir / WEIGHTS_FILE)]
    summary = parse_json(run_command(command, f"pgem optimize {' '.join(options)}"), "pgem optimize")
    if not all(bench_gn.pgem_solve_status(summary)):
        raise RunFailure(f"pgem optimize: status {summary.get('status')}, usable {summary.get('usable')}")
    return summary


def solve_pgem(pgem: Path, method: str, corrupted: Path, outdir: Path) -> tuple[float, dict[str, Any]]:
    """One pgem robust solve; returns (solve seconds, its JSON summary)."""
    summary = pgem_optimize(pgem, corrupted, PGEM_METHODS[method], outdir)
    return float(summary["solve_seconds"]), summary


def solve_gtsam(method: str, corrupted: Path, outdir: Path, timeout: float) -> tuple[float, dict[str, Any]]:
    """One GTSAM solve in a fresh worker process, killed after timeout seconds."""
    summary = parse_json(run_command(gtsam_worker.command(method, corrupted, outdir), f"GTSAM worker {method}",
                                     timeout), "GTSAM worker")
    return float(summary["solve_seconds"]), summary


def evaluate(pgem: Path, outdir: Path, reference: Path, corrupted: Path, reject_below: float) -> dict[str, Any]:
    """Scores one result with pgem eval (the same code for every method)."""
    command = [str(pgem), "eval", str(outdir / RESULT_FILE), "--reference", str(reference),
               "--outliers", str(corrupted) + ".outliers", "--weights", str(outdir / WEIGHTS_FILE),
               "--reject-below", repr(reject_below), "--json"]
    return parse_json(run_command(command, "pgem eval"), "pgem eval")


def execute(run: Run, outdir: Path, solve: Callable[[], dict[str, Any]],
            score: Callable[[], dict[str, Any]]) -> None:
    """Solves (solve returns the solver's summary, with solve_seconds) and scores one run in
    place, from outdir's RESULT_FILE and WEIGHTS_FILE; failures become the run's status."""
    for stale in (outdir / RESULT_FILE, outdir / WEIGHTS_FILE):
        stale.unlink(missing_ok=True)  # never score a previous run's files
    start = time.perf_counter()
    try:
        summary = solve()
        run.solve_seconds = float(summary["solve_seconds"])
        run.solver = {key: summary[key] for key in SOLVER_KEYS if key in summary}
        run.wall_seconds = time.perf_counter() - start
        run.scores = score()
    except RunFailure as failure:
        run.status, run.error = failure.status, str(failure)
    except (KeyError, TypeError, ValueError, OSError) as error:  # malformed output: still just one run
        run.status, run.error = "failed", f"{type(error).__name__}: {error}"
    if run.status != "ok":
        run.wall_seconds = run.wall_seconds or time.perf_counter() - start


def run_method(args: argparse.Namespace, run: Run, corrupted: Path, reference: Path) -> None:
    """Solves and scores one run of the grid in place; failures become the run's status."""
    outdir = corrupted.parent / run.method
    if run.method in PGEM_METHODS:
        def solve() -> dict[str, Any]:
            return solve_pgem(args.pgem, run.method, corrupted, outdir)[1]
    else:
        def solve() -> dict[str, Any]:
            return solve_gtsam(run.method, corrupted, outdir, args.timeout)[1]
    execute(run, outdir, solve, lambda: evaluate(args.pgem, outdir, reference, corrupted, args.reject_below))


# --------------------------------------------------------------------------------------
# The grid
# --------------------------------------------------------------------------------------


class Eta:
    """Remaining-time estimate from the mean wall time of the runs done so far."""

    def __init__(self, total: int) -> None:
        self.total, self.done, self.start = total, 0, time.perf_counter()

    def step(self, skipped: int = 0) -> str:
        """Counts one run (plus runs skipped without work); returns 'i/N, ETA ...'."""
        self.done += 1 + skipped
        elapsed = time.perf_counter() - self.start
        remaining = elapsed / self.done * (self.total - self.done) if self.done else 0.0
        return f"{self.done}/{self.total}, ETA {format_duration(remaining)}"


def format_duration(seconds: float) -> str:
    """Seconds as '1h02m', '3m05s' or '12s'."""
    seconds = int(round(seconds))
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    if seconds >= 60:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds}s"


def format_seconds(seconds: float | None) -> str:
    """A time with a unit that keeps three significant digits."""
    if seconds is None or not math.isfinite(seconds):
        return "-"
    if seconds < 1.0:
        return f"{seconds * 1e3:.3g} ms"
    return f"{seconds:.3g} s"


def progress_line(run: Run, eta: str) -> str:
    """One stderr line per run."""
    where = f"[{run.dataset} {run.policy} {run.count} seed {run.seed}] {run.method}"
    if run.status != "ok":
        return f"{where}: {run.status.upper()}: {run.error} ({eta})"
    p, r = run.scores.get("precision"), run.scores.get("recall")
    return (f"{where}: {format_seconds(run.solve_seconds)}, precision {format_ratio(p)} "
            f"recall {format_ratio(r)}, ATE {format_length(run.scores.get('ate_translation_rmse'))} ({eta})")


def bench_dataset(args: argparse.Namespace, dataset: bench_gn.Dataset, eta: Eta, notes: list[str]) -> list[Run]:
    """Every cell of one dataset; failures are recorded, never raised."""
    runs: list[Run] = []
    workdir = args.work / dataset.name
    per_cell = len(args.methods)
    try:
        reference = make_reference(args.pgem, dataset.path, workdir)
    except RunFailure as failure:
        notes.append(f"{dataset.name}: skipped, no reference optimum: {failure}")
        progress(f"[{dataset.name}] skipped: {failure}")
        eta.step(len(args.policies) * len(args.counts) * len(args.seeds) * per_cell - 1)
        return runs
    for policy in args.policies:
        for count in args.counts:
            for seed in args.seeds:
                cell = [Run(dataset.name, policy, count, seed, method) for method in args.methods]
                folder = f"{policy}-{count}-seed{seed}"
                if args.group_size is not None and policy.endswith("-grouped"):
                    folder += f"-group{args.group_size}"  # another group size is another corruption
                try:
                    corrupted = make_corrupted(args.pgem, dataset.path, workdir / folder,
                                               policy, count, seed, args.group_size)
                except RunFailure as failure:
                    for run in cell:
                        run.status, run.error = "failed", str(failure)
                    runs += cell
                    progress(f"[{dataset.name} {policy} {count} seed {seed}] {failure} ({eta.step(per_cell - 1)})")
                    continue
                for run in cell:
                    run_method(args, run, corrupted, reference)
                    runs.append(run)
                    progress(progress_line(run, eta.step()))
    return runs


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def format_ratio(value: Any) -> str:
    """A precision or recall with three decimals, truncated so that only 1 shows as 1.000."""
    if value is None or not math.isfinite(float(value)):
        return "-"
    value = float(value)
    shown = math.floor(value * 1000.0 + 1e-6) / 1000.0
    return f"{min(shown, 0.999) if value < 1.0 else shown:.3f}"


def format_length(value: Any) -> str:
    """A length in metres with three significant digits."""
    return "-" if value is None or not math.isfinite(float(value)) else f"{float(value):.3g} m"


def numbers(runs: Iterable[Run], key: str) -> list[float]:
    """The finite values of one eval score over runs."""
    values = []
    for run in runs:
        value = run.scores.get(key)
        if value is not None and math.isfinite(float(value)):
            values.append(float(value))
    return values


@dataclass
class Cell:
    """All seeds of one method on one (dataset, policy, count)."""

    runs: list[Run]

    @property
    def ok(self) -> list[Run]:
        return [run for run in self.runs if run.status == "ok"]

    def mean(self, key: str) -> float | None:
        values = numbers(self.ok, key)
        return statistics.fmean(values) if values else None

    def min(self, key: str) -> float | None:
        values = numbers(self.ok, key)
        return min(values) if values else None

    def max(self, key: str) -> float | None:
        values = numbers(self.ok, key)
        return max(values) if values else None

    def median_time(self) -> float | None:
        times = [run.solve_seconds for run in self.ok if run.solve_seconds is not None]
        return statistics.median(times) if times else None

    def perfect(self) -> bool:
        """Precision and recall 1 in every seed (and no seed failed)."""
        return bool(self.runs) and len(self.ok) == len(self.runs) and all(
            run.scores.get("precision") == 1.0 and run.scores.get("recall") == 1.0 for run in self.runs)

    def trouble(self) -> str:
        """'timeout 1/3, failed 1/3' for the seeds that produced no result."""
        parts = []
        for status in ("timeout", "failed"):
            n = sum(run.status == status for run in self.runs)
            if n:
                parts.append(f"{status} {n}/{len(self.runs)}")
        return ", ".join(parts)


def group_cells(runs: Sequence[Run]) -> dict[tuple[str, str, int, str], Cell]:
    """Runs grouped by (dataset, policy, count, method), in run order."""
    cells: dict[tuple[str, str, int, str], Cell] = {}
    for run in runs:
        cells.setdefault((run.dataset, run.policy, run.count, run.method), Cell([])).runs.append(run)
    return cells


def with_trouble(text: str, cell: Cell, first: bool = False) -> str:
    """Appends the failed/timed-out seed count to a method's first entry of a row.

    When no seed produced a result, the first entry says so in bold and the others are '-'."""
    trouble = cell.trouble()
    if not cell.ok:
        return f"**{trouble}**" if first else "-"
    return f"{text} ({trouble})" if trouble and first else text


def pr_entry(cell: Cell) -> str:
    """'mean P / mean R (min P / min R)' over seeds."""
    p, r = cell.mean("precision"), cell.mean("recall")
    text = f"{format_ratio(p)} / {format_ratio(r)}"
    if len(cell.ok) > 1:
        text += f" (min {format_ratio(cell.min('precision'))} / {format_ratio(cell.min('recall'))})"
    return with_trouble(text, cell, first=True)


def ate_entry(cell: Cell) -> str:
    """Largest ATE over seeds, and the largest ATE relative to the extent in %."""
    ate, relative = cell.max("ate_translation_rmse"), cell.max("ate_relative")
    text = format_length(ate).replace(" m", "")
    if relative is not None:
        text += f" ({100.0 * relative:.2g}%)"
    return with_trouble(text, cell)


def time_entry(cell: Cell, baseline: Cell | None) -> str:
    """Median solve time, with the ratio to pgem-em's median for other methods."""
    median = cell.median_time()
    text = format_seconds(median)
    if baseline is not None and median is not None:
        base = baseline.median_time()
        if base:
            text += f" ({median / base:.3g}x)"
    return with_trouble(text, cell)


def dataset_table(name: str, args: argparse.Namespace, cells: dict[tuple[str, str, int, str], Cell]) -> list[str]:
    """One Markdown table: rows policy x count, three columns per method."""
    headers = ["policy", "count"]
    for method in args.methods:
        ratio = f" (x {BASELINE})" if method != BASELINE and BASELINE in args.methods else ""
        headers += [f"{method} P / R", f"{method} ATE m (%)", f"{method} time{ratio}"]
    lines = ["| " + " | ".join(headers) + " |", "|---|--:|" + "--:|" * (3 * len(args.methods))]
    for policy in args.policies:
        for count in args.counts:
            row = [policy, str(count)]
            baseline = cells.get((name, policy, count, BASELINE))
            for method in args.methods:
                cell = cells.get((name, policy, count, method))
                if cell is None:
                    row += ["-", "-", "-"]
                    continue
                row += [pr_entry(cell), ate_entry(cell),
                        time_entry(cell, baseline if method != BASELINE else None)]
            lines.append("| " + " | ".join(row) + " |")
    return lines


def extent_line(name: str, runs: Sequence[Run]) -> str:
    """The reference trajectory's size, from any successful eval."""
    for run in runs:
        if run.dataset == name and run.status == "ok" and run.scores.get("extent_rms") is not None:
            return (f"Reference extent (RMS distance of the poses from their centroid): "
                    f"{float(run.scores['extent_rms']):.4g} m; poses matched: {run.scores.get('poses_matched')}.")
    return "No successful evaluation on this dataset."


def cell_label(key: tuple[str, str, int, str]) -> str:
    """'dataset policy count' of a cell key."""
    return f"{key[0]} {key[1]} {key[2]}"


def summary_lines(args: argparse.Namespace, cells: dict[tuple[str, str, int, str], Cell]) -> list[str]:
    """The pgem-em summary: perfect cells, imperfect ones, comparisons with GTSAM, speed."""
    if BASELINE not in args.methods:
        return [f"{BASELINE} was not run: no summary."]
    lines: list[str] = []
    base_keys = [key for key in cells if key[3] == BASELINE]
    perfect = [key for key in base_keys if cells[key].perfect()]
    lines.append(f"- {BASELINE} reaches precision = recall = 1 in every seed in **{len(perfect)} of "
                 f"{len(base_keys)}** cells.")
    imperfect = [key for key in base_keys if not cells[key].perfect()]
    if imperfect:
        lines.append("- Cells where it does not (mean / min over seeds):")
        for key in imperfect:
            cell = cells[key]
            detail = (f"precision {format_ratio(cell.mean('precision'))} / {format_ratio(cell.min('precision'))}, "
                      f"recall {format_ratio(cell.mean('recall'))} / {format_ratio(cell.min('recall'))}")
            if cell.trouble():
                detail += f"; {cell.trouble()}"
            lines.append(f"  - {cell_label(key)}: {detail}")

    gtsam_methods = [m for m in args.methods if m in GTSAM_METHODS]
    worse_ate, worse_pr = [], []
    for key in base_keys:
        base = cells[key]
        others = [(m, cells.get(key[:3] + (m,))) for m in gtsam_methods]
        others = [(m, c) for m, c in others if c is not None and c.ok]
        if not others or not base.ok:
            continue
        base_ate = base.max("ate_translation_rmse")
        rivals = [(c.max("ate_translation_rmse"), m) for m, c in others if c.max("ate_translation_rmse") is not None]
        if base_ate is not None and rivals:
            best_ate, best_method = min(rivals)
            if base_ate > best_ate * (1.0 + ATE_WORSE_RELATIVE) and base_ate - best_ate > ATE_WORSE_ABSOLUTE:
                worse_ate.append(f"  - {cell_label(key)}: {BASELINE} {base_ate:.3g} m, {best_method} {best_ate:.3g} m")
        for score in ("precision", "recall"):
            mine = base.mean(score)
            best = max(((c.mean(score), m) for m, c in others if c.mean(score) is not None), default=None)
            if mine is not None and best is not None and mine < best[0] - 1e-12:
                worse_pr.append(f"  - {cell_label(key)}: {score} {BASELINE} {mine:.3f}, {best[1]} {best[0]:.3f}")
    if gtsam_methods:
        lines.append(f"- Cells where {BASELINE}'s largest ATE exceeds the best GTSAM method's by more than "
                     f"{100 * ATE_WORSE_RELATIVE:g}% and {1e3 * ATE_WORSE_ABSOLUTE:g} mm: "
                     + ("none." if not worse_ate else f"{len(worse_ate)}:"))
        lines += worse_ate
        lines.append(f"- Cells where {BASELINE}'s mean precision or recall is below the best GTSAM method's: "
                     + ("none." if not worse_pr else f"{len(worse_pr)}:"))
        lines += worse_pr
    for method in gtsam_methods:
        ratios = []
        for key in base_keys:
            other = cells.get(key[:3] + (method,))
            base_time = cells[key].median_time()
            other_time = other.median_time() if other is not None else None
            if base_time and other_time:
                ratios.append(other_time / base_time)
        if ratios:
            lines.append(f"- {method} time / {BASELINE} time over {len(ratios)} cells: median "
                         f"**{statistics.median(ratios):.3g}x** (min {min(ratios):.3g}x, max {max(ratios):.3g}x).")
    return lines


def failure_lines(runs: Sequence[Run]) -> list[str]:
    """Every run that produced no result, with its message."""
    return [f"- {run.dataset} {run.policy} {run.count} seed {run.seed} {run.method}: {run.status}: {run.error}"
            for run in runs if run.status != "ok"]


def header_lines(args: argparse.Namespace, datasets: Sequence[bench_gn.Dataset]) -> list[str]:
    """Machine, versions and the grid."""
    return [
        bench_gn.machine_line(args.pgem) + ".",
        "",
        f"Grid: datasets {', '.join(d.name for d in datasets) or '(none)'}; policies {', '.join(args.policies)}; "
        f"counts {', '.join(map(str, args.counts))}; seeds {', '.join(map(str, args.seeds))}"
        + (f"; group size {args.group_size}" if args.group_size is not None else "")
        + f". Methods: {', '.join(args.methods)}. A loop counts as rejected when pruned or weighted "
        f"below {args.reject_below:g}. GTSAM: Levenberg-Marquardt, at most {LM_MAX_ITERATIONS} iterations, "
        f"relative and absolute error tolerance {LM_ERROR_TOL:g}, kernel scale {KERNEL_SCALE:g}; "
        f"timeout {args.timeout:g} s per run.",
    ]


def render_report(args: argparse.Namespace, datasets: Sequence[bench_gn.Dataset], runs: Sequence[Run],
                  notes: Sequence[str], wall: float) -> str:
    """The whole Markdown report."""
    cells = group_cells(runs)
    lines = ["# pgem robust solvers vs GTSAM: false loop closures", ""]
    lines += header_lines(args, datasets)
    lines += ["", "Entries: **P / R** = precision / recall of the rejected loops, mean over seeds (min over "
              "seeds); **ATE** = largest translation ATE over seeds against the clean graph's optimum, in metres "
              "(in % of the reference extent); **time** = median solve time over seeds"
              + (f" (GTSAM methods: the ratio to {BASELINE}'s median; above 1 means {BASELINE} is faster)"
                 if BASELINE in args.methods else "") + "."]
    for dataset in datasets:
        lines += ["", f"## {dataset.name}", "", extent_line(dataset.name, runs), ""]
        lines += dataset_table(dataset.name, args, cells)
    lines += ["", "## Summary", ""] + summary_lines(args, cells)
    if any(m in GTSAM_METHODS for m in args.methods) and any(r.scores.get("dimension") == 3 for r in runs):
        notes = [*notes, "3D: GTSAM applies the file's rotation information to its angle-axis error (about twice "
                 "g2o's quaternion-vector error), so its optimum differs slightly from the g2o-convention "
                 "reference and its ATE has a small floor even with perfect rejection."]
    failures = failure_lines(runs)
    lines += ["", "## Timeouts and failures", ""] + (failures or ["None."])
    if notes:
        lines += ["", "## Notes", ""] + [f"- {note}" for note in notes]
    lines += ["", f"Wall time of the benchmark: {format_duration(wall)}."]
    return "\n".join(lines) + "\n"


def write_runs(out: Path, runs: Sequence[Run]) -> tuple[Path, Path]:
    """Every run as CSV (flat columns) and JSON (nested), beside the report."""
    csv_path, json_path = out.with_suffix(".csv"), out.with_suffix(".json")
    columns = ["dataset", "policy", "count", "seed", "method", "status", "error", "solve_seconds",
               "wall_seconds", *SOLVER_KEYS, *EVAL_KEYS]
    with open(csv_path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for run in runs:
            row = {key: value for key, value in asdict(run).items() if key not in ("solver", "scores")}
            row.update(run.solver)
            row.update(run.scores)
            writer.writerow(row)
    json_path.write_text(json.dumps([asdict(run) for run in runs], indent=1) + "\n", encoding="utf-8")
    return csv_path, json_path


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def split_list(text: str | None, default: Sequence[Any], convert: Any = str) -> list[Any]:
    """A comma-separated option as a list (default when absent)."""
    if text is None:
        return list(default)
    return [convert(item.strip()) for item in text.split(",") if item.strip()]


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Command-line options; --quick only changes the defaults of the grid options."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--datasets-dir", type=Path, default=DEFAULT_DATASETS,
                        help="datasets folder (default: ../shared/datasets beside the repository)")
    parser.add_argument("--files", help=f"comma-separated dataset names (default {','.join(DEFAULT_FILES)})")
    parser.add_argument("--policies", help=f"comma-separated subset of {','.join(POLICIES)} (default all)")
    parser.add_argument("--counts", help="comma-separated false-loop counts (default 10,100,1000)")
    parser.add_argument("--seeds", help="comma-separated seeds (default 1,2,3)")
    parser.add_argument("--group-size", type=int, help="loops per group of the grouped policies (pgem's default: 10)")
    parser.add_argument("--methods", help=f"comma-separated subset of {','.join(ALL_METHODS)} "
                                          f"(default {','.join(DEFAULT_METHODS)})")
    parser.add_argument("--reject-below", type=float, default=DEFAULT_REJECT_BELOW,
                        help="pgem eval: a loop weighted below this counts as rejected (default 0.01)")
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT,
                        help="seconds before a GTSAM run is killed (default 300)")
    parser.add_argument("--pgem", type=Path, default=DEFAULT_PGEM,
                        help="pgem binary (default build/release/tools/pgem/pgem)")
    parser.add_argument("--work", type=Path, default=DEFAULT_WORK,
                        help="cache and result files (default build/bench/robust)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="Markdown report; the .csv and .json of every run go beside it "
                             "(default build/bench/bench_robust.md)")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: input_M3500_g2o and intel, random and local-grouped, count 100, seed 1")
    args = parser.parse_args(argv)
    quick = args.quick
    args.names = split_list(args.files, QUICK_FILES if quick else DEFAULT_FILES)
    args.policies = split_list(args.policies, QUICK_POLICIES if quick else POLICIES)
    args.methods = split_list(args.methods, DEFAULT_METHODS)
    try:
        args.counts = split_list(args.counts, QUICK_COUNTS if quick else DEFAULT_COUNTS, int)
        args.seeds = split_list(args.seeds, QUICK_SEEDS if quick else DEFAULT_SEEDS, int)
    except ValueError:
        parser.error("--counts and --seeds take comma-separated integers")
    for name, values, allowed in (("policy", args.policies, POLICIES), ("method", args.methods, ALL_METHODS)):
        unknown = [v for v in values if v not in allowed]
        if unknown:
            parser.error(f"unknown {name} {', '.join(unknown)} (choose from {', '.join(allowed)})")
    if not (args.names and args.policies and args.methods and args.counts and args.seeds):
        parser.error("the grid is empty")
    if any(c < 1 for c in args.counts) or args.timeout <= 0:
        parser.error("counts and --timeout must be positive")
    args.pgem, args.work, args.out = args.pgem.resolve(), args.work.resolve(), args.out.resolve()
    return args


def check_pgem(pgem: Path) -> None:
    """pgem must exist and have the eval verb."""
    bench_gn.check_pgem_binary(pgem)
    proc = subprocess.run([str(pgem), "eval", "--help"], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise BenchError(f"{pgem} has no working 'eval' command ({first_line(proc.stderr)}); rebuild pgem")


def run_benchmark(args: argparse.Namespace) -> None:
    """Runs the grid and writes the report and the per-run files."""
    check_pgem(args.pgem)
    datasets, missing = bench_gn.resolve_datasets(args.datasets_dir, args.names)
    notes = [f"{name}: dataset not found under the datasets folder, skipped." for name in missing]
    for note in notes:
        progress(f"note: {note}")
    if not datasets:
        raise BenchError(f"none of the datasets {', '.join(args.names)} found under {args.datasets_dir}")
    fingerprint = bench_gn.binary_fingerprint(args.pgem)
    for line in header_lines(args, datasets):
        if line:
            progress(line)
    start = time.perf_counter()
    total = len(datasets) * len(args.policies) * len(args.counts) * len(args.seeds) * len(args.methods)
    eta = Eta(total)
    runs: list[Run] = []
    for dataset in datasets:
        runs += bench_dataset(args, dataset, eta, notes)
    rebuilt = bench_gn.rebuilt_note(args.pgem, fingerprint, "results")
    if rebuilt:
        notes.append(rebuilt)
    report = render_report(args, datasets, runs, notes, time.perf_counter() - start)
    print(report)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report, encoding="utf-8")
    csv_path, json_path = write_runs(args.out, runs)
    progress(f"report written to {args.out}; runs in {csv_path.name} and {json_path.name}")


def main(argv: Sequence[str]) -> int:
    """Entry point: the benchmark."""
    args = parse_args(argv)
    try:
        run_benchmark(args)
    except BenchError as error:
        print(f"bench_robust: error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
