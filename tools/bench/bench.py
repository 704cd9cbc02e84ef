#!/usr/bin/env python3
"""pgem against GTSAM in one command: Gauss-Newton, robust solves, memory and the targets.

``python3 tools/bench/bench.py`` runs, and reports in one Markdown document:

1. plain Gauss-Newton on the clean graphs: ``pgem optimize --solver gn`` against GTSAM's
   GaussNewtonOptimizer (bench_gn.py's solve), time, iterations, g2o-convention chi2,
   the positions' error against the clean optimum and memory;
2. robust solves of corrupted graphs (``pgem corrupt``): ``pgem optimize --robust em`` against
   GTSAM Levenberg-Marquardt with DCS on the loop closures (``--with-gnc`` adds GTSAM's GNC), time, iterations, chi2 of the kept edges, precision and
   recall of the rejected loops, ATE against the clean optimum and memory;
3. the make-up of pgem's block (bytes per pose, per edge, factor) next to GTSAM's peak
   resident-set growth on the same graph;
4. the timing spread of every measurement, and the project's speed targets, met or missed.

Every timing is the median of several runs, pgem and GTSAM interleaved. Every GTSAM solve is a
fresh process (``gtsam_worker.py METHOD FILE OUTDIR``), killed after ``--timeout`` seconds; a
failed or timed-out run is recorded and shown, not fatal.
``--peer none`` runs pgem alone and imports neither gtsam nor numpy. The report goes to stdout
and ``--out``; every run, raw, goes to the same name ending in ``.json``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import statistics
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (GTSAM Gauss-Newton worker, chi2, machine header, dataset lookup)
import bench_robust  # noqa: E402  (corruption, reference, pgem and GTSAM robust solves, pgem eval)
import gtsam_worker  # noqa: E402  (the GTSAM solves, each in its own process)

BenchError = bench_gn.BenchError
RunFailure = bench_robust.RunFailure
Run = bench_robust.Run
Cell = bench_robust.Cell
progress = bench_gn.progress
format_seconds = bench_robust.format_seconds
format_ratio = bench_robust.format_ratio
format_duration = bench_robust.format_duration

REPO_ROOT = bench_gn.REPO_ROOT
DEFAULT_OUT = REPO_ROOT / "build" / "bench" / "bench.md"

GN_FILES = ("manhattanOlson3500", "input_M3500_g2o", "intel", "city10000", "sphere2500")
ROBUST_FILES = ("input_M3500_g2o",)
POLICIES = ("random", "local-grouped")
COUNTS = (100, 1000)
SEEDS = (1,)
GN_RUNS = 5
ROBUST_RUNS = 3
QUICK = {"files": ("intel", "input_M3500_g2o"), "robust_files": ("input_M3500_g2o",),
         "policies": ("random",), "counts": (100,), "seeds": (1,)}

PGEM_GN, GTSAM_GN = "pgem-gn", gtsam_worker.GTSAM_GN
PGEM_EM, GTSAM_DCS, GTSAM_GNC = "pgem-em", "gtsam-dcs", "gtsam-gnc"
GN_OPTIONS = ("--solver", "gn", "--max-iterations", str(bench_gn.MAX_ITERATIONS))
CLEAN = "clean"  # the policy field of a Gauss-Newton run

TARGET_GN_SPEEDUP = 5.0    # GTSAM GN time / pgem GN time, on every dataset
TARGET_EM_SPEEDUP = 10.0   # GTSAM DCS time / pgem EM time, with precision = recall = 1
TARGET_EM_OVER_GN = 3.0    # pgem EM time / pgem GN time on the clean graph, at most
TARGET_CELL = ("input_M3500_g2o", "random", 1000)

NO_NUMBER = "-"


# --------------------------------------------------------------------------------------
# One run
# --------------------------------------------------------------------------------------


@dataclass
class Record:
    """One solve: the phase ('gn' or 'robust'), its repetition (1-based) and the run."""

    phase: str
    repeat: int
    run: Run


def score_against(pgem: Path, result: Path, reference: Path) -> dict[str, Any]:
    """`pgem eval RESULT --reference REF --json`: ATE and RPE against the clean optimum."""
    command = [str(pgem), "eval", str(result), "--reference", str(reference), "--json"]
    return bench_robust.parse_json(bench_robust.run_command(command, "pgem eval"), "pgem eval")


def run_gn(args: argparse.Namespace, run: Run, clean: Path, reference: Path, outdir: Path) -> None:
    """One Gauss-Newton solve of the clean graph, scored against the reference, in place."""
    if run.method == PGEM_GN:
        def solve() -> dict[str, Any]:
            summary = bench_robust.pgem_optimize(args.pgem, clean, GN_OPTIONS, outdir)
            # the analysis the command ran while loading is the solve's: count it, as GTSAM's
            # ordering and symbolic elimination count on its side
            summary["solve_seconds"] = (float(summary["solve_seconds"]) +
                                        float(summary.get("analysis_seconds", 0.0)))
            return summary
    else:
        def solve() -> dict[str, Any]:
            command = gtsam_worker.command(GTSAM_GN, clean, outdir)
            output = bench_robust.run_command(command, f"GTSAM worker {GTSAM_GN}", args.timeout)
            return bench_robust.parse_json(output, "GTSAM worker")
    bench_robust.execute(run, outdir, solve,
                         lambda: score_against(args.pgem, outdir / bench_robust.RESULT_FILE, reference))


class Eta:
    """Time-to-go from the mean wall time (solve, process start and scoring) of the runs done so
    far, per solver (a GTSAM robust run costs a hundred pgem ones); a solver not seen yet counts
    at the mean of all runs, so the estimate is rough until every solver has run once."""

    def __init__(self, planned: Sequence[str]) -> None:
        self.left = list(planned)
        self.total = len(planned)
        self.spent: dict[str, list[float]] = {}

    def skip(self, methods: Sequence[str]) -> None:
        """Forgets runs that will not happen (their dataset or cell could not be prepared)."""
        for method in methods:
            if method in self.left:
                self.left.remove(method)

    def step(self, method: str, seconds: float) -> str:
        """Counts one run of method that took seconds; returns 'i/N runs, ETA ...'."""
        if method in self.left:
            self.left.remove(method)
        self.spent.setdefault(method, []).append(seconds)
        every = [s for runs in self.spent.values() for s in runs]
        fallback = statistics.fmean(every)
        remaining = sum(statistics.fmean(self.spent[m]) if m in self.spent else fallback for m in self.left)
        return f"{self.total - len(self.left)}/{self.total} runs, ETA {format_duration(remaining)}"


def run_line(record: Record, runs: int, eta: str) -> str:
    """One progress line (stderr) per run."""
    run = record.run
    where = f"[{run.dataset}]" if record.phase == "gn" else f"[{run.dataset} {run.policy} {run.count} seed {run.seed}]"
    head = f"{where} run {record.repeat}/{runs} {run.method}"
    if run.status != "ok":
        return f"{head}: {run.status.upper()}: {run.error} ({eta})"
    text = f"{head}: {format_seconds(run.solve_seconds)}, iterations {iterations_text(run.method, [run])}"
    if record.phase == "robust":
        text += f", precision {format_ratio(run.scores.get('precision'))} recall {format_ratio(run.scores.get('recall'))}"
    ate = run.scores.get("ate_translation_rmse")
    text += f", ATE {format_length(ate)}"
    return f"{text} ({eta})"


# --------------------------------------------------------------------------------------
# The benchmark
# --------------------------------------------------------------------------------------


def gn_methods(args: argparse.Namespace) -> list[str]:
    return [PGEM_GN] + ([GTSAM_GN] if args.peer == "gtsam" else [])


def robust_methods(args: argparse.Namespace) -> list[str]:
    methods = [PGEM_EM]
    if args.peer == "gtsam":
        methods += [GTSAM_DCS] + ([GTSAM_GNC] if args.with_gnc else [])
    return methods


def cell_folder(policy: str, count: int, seed: int) -> str:
    """The cache folder of one corruption (bench_robust's naming)."""
    return f"{policy}-{count}-seed{seed}"


def plan(args: argparse.Namespace, gn_sets: Sequence[bench_gn.Dataset],
         robust_sets: Sequence[bench_gn.Dataset]) -> list[str]:
    """The solver of every run to come, for the time-to-go estimate."""
    planned = [m for _ in gn_sets for _ in range(args.runs) for m in gn_methods(args)]
    cells = len(robust_sets) * len(args.policies) * len(args.counts) * len(args.seeds)
    return planned + [m for _ in range(cells * args.robust_runs) for m in robust_methods(args)]


def reference_for(args: argparse.Namespace, dataset: bench_gn.Dataset, notes: list[str]) -> Path | None:
    """The clean graph's optimum (pgem Gauss-Newton, written with -o), cached in the work folder."""
    try:
        return bench_robust.make_reference(args.pgem, dataset.path, args.work / dataset.name)
    except RunFailure as failure:
        notes.append(f"{dataset.name}: no reference optimum, skipped: {failure}")
        progress(f"[{dataset.name}] skipped: {failure}")
        return None


def bench_gn_phase(args: argparse.Namespace, datasets: Sequence[bench_gn.Dataset], eta: Eta,
                   notes: list[str]) -> list[Record]:
    """Gauss-Newton on every clean graph, pgem and GTSAM interleaved, args.runs times each."""
    records: list[Record] = []
    for dataset in datasets:
        reference = reference_for(args, dataset, notes)
        if reference is None:
            eta.skip(gn_methods(args) * args.runs)
            continue
        for repeat in range(1, args.runs + 1):
            for method in gn_methods(args):
                start = time.perf_counter()
                run = Run(dataset.name, CLEAN, 0, 0, method)
                run_gn(args, run, dataset.path, reference, args.work / dataset.name / "gn" / method)
                records.append(Record("gn", repeat, run))
                progress(run_line(records[-1], args.runs, eta.step(method, time.perf_counter() - start)))
    return records


def bench_robust_phase(args: argparse.Namespace, datasets: Sequence[bench_gn.Dataset], eta: Eta,
                       notes: list[str]) -> list[Record]:
    """Every corrupted graph, pgem EM and the GTSAM methods interleaved, args.robust_runs times."""
    records: list[Record] = []
    per_cell = robust_methods(args) * args.robust_runs
    for dataset in datasets:
        reference = reference_for(args, dataset, notes)
        for policy in args.policies:
            for count in args.counts:
                for seed in args.seeds:
                    if reference is None:
                        eta.skip(per_cell)
                        continue
                    try:
                        corrupted = bench_robust.make_corrupted(
                            args.pgem, dataset.path, args.work / dataset.name / cell_folder(policy, count, seed),
                            policy, count, seed, None)
                    except RunFailure as failure:
                        notes.append(f"{dataset.name} {policy} {count} seed {seed}: not corrupted: {failure}")
                        eta.skip(per_cell)
                        continue
                    for repeat in range(1, args.robust_runs + 1):
                        for method in robust_methods(args):
                            start = time.perf_counter()
                            run = Run(dataset.name, policy, count, seed, method)
                            bench_robust.run_method(args, run, corrupted, reference)
                            records.append(Record("robust", repeat, run))
                            spent = time.perf_counter() - start
                            progress(run_line(records[-1], args.robust_runs, eta.step(method, spent)))
    return records


# --------------------------------------------------------------------------------------
# Statistics over the runs of one measurement
# --------------------------------------------------------------------------------------

Key = tuple[str, str, str, int, int, str]  # phase, dataset, policy, count, seed, method


def group(records: Sequence[Record]) -> dict[Key, Cell]:
    """Runs grouped by measurement (phase, dataset, policy, count, seed, method), in run order."""
    cells: dict[Key, Cell] = {}
    for record in records:
        run = record.run
        key = (record.phase, run.dataset, run.policy, run.count, run.seed, run.method)
        cells.setdefault(key, Cell([])).runs.append(run)
    return cells


def solver_median(cell: Cell | None, key: str) -> float | None:
    """Median over the successful runs of one number of the solver's summary."""
    if cell is None:
        return None
    values = [float(run.solver[key]) for run in cell.ok
              if isinstance(run.solver.get(key), (int, float)) and not isinstance(run.solver.get(key), bool)]
    return statistics.median(values) if values else None


def score_median(cell: Cell | None, key: str) -> float | None:
    """Median over the successful runs of one pgem eval score."""
    values = bench_robust.numbers(cell.ok, key) if cell is not None else []
    return statistics.median(values) if values else None


def times(cell: Cell | None) -> list[float]:
    return [run.solve_seconds for run in cell.ok if run.solve_seconds is not None] if cell is not None else []


def spread_percent(values: Sequence[float]) -> float | None:
    """(max - min) / median in %, or None with fewer than two runs."""
    if len(values) < 2:
        return None
    return bench_gn.spread_percent(list(values))


def ratio(numerator: float | None, denominator: float | None) -> float | None:
    if numerator is None or not denominator:
        return None
    return numerator / denominator


def format_times_ratio(value: float | None) -> str:
    return NO_NUMBER if value is None else f"{value:.3g}x"


def format_length(value: Any) -> str:
    """bench_robust's length format, with an exact zero as '0 m'."""
    return "0 m" if value is not None and float(value) == 0.0 else bench_robust.format_length(value)


def format_bytes(value: float | None) -> str:
    if value is None:
        return NO_NUMBER
    if value >= 2**20:
        return bench_gn.mib(value)
    if value >= 2**10:
        return f"{value / 2**10:.1f} KiB"
    return f"{value:.0f} B"


def format_chi2(value: float | None) -> str:
    return NO_NUMBER if value is None else f"{value:.6g}"


def format_count(value: float | None) -> str:
    return NO_NUMBER if value is None else f"{value:.0f}"


def dimension_of(cell: Cell | None) -> str:
    """'2D' or '3D', from pgem eval's dimension of a successful run."""
    for run in cell.ok if cell is not None else []:
        if run.scores.get("dimension") in (2, 3):
            return f"{run.scores['dimension']}D"
    return NO_NUMBER


def entry(cell: Cell | None, text: str, first: bool = False) -> str:
    """A table entry, or what happened to the runs when none succeeded."""
    if cell is None:
        return NO_NUMBER
    return bench_robust.with_trouble(text, cell, first)


def iterations_text(method: str, runs: Sequence[Run]) -> str:
    """Iterations as each solver counts them (median over runs)."""
    def median(key: str) -> float | None:
        values = [float(r.solver[key]) for r in runs if isinstance(r.solver.get(key), (int, float))]
        return statistics.median(values) if values else None

    if method == PGEM_EM:
        em, gn = median("em_iterations"), median("gn_iterations")
        return NO_NUMBER if em is None else f"{em:g} EM / {gn:g} GN"
    count = median("iterations")
    if count is None:
        return NO_NUMBER
    return f"{count:g} LM" if method in (GTSAM_DCS, GTSAM_GNC) else f"{count:g}"


def per_iteration(method: str, cell: Cell | None) -> float | None:
    """Median time per iteration: GN iterations for pgem EM (one per M-step, plus the final
    re-solve), LM iterations for GTSAM's robust solves."""
    key = "gn_iterations" if method == PGEM_EM else "iterations"
    count = solver_median(cell, key)
    median = cell.median_time() if cell is not None else None
    return median / count if median is not None and count else None


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def table(headers: Sequence[str], align: str, rows: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown table; align has one character per column, 'l' or 'r'."""
    rule = "|" + "|".join("---" if a == "l" else "--:" for a in align) + "|"
    return ["| " + " | ".join(headers) + " |", rule] + ["| " + " | ".join(row) + " |" for row in rows]


@dataclass
class Context:
    """What every part of the report needs."""

    args: argparse.Namespace
    header: str  # machine, versions, binary hash, date (taken at the start)
    cells: dict[Key, Cell]
    gn_sets: list[bench_gn.Dataset]
    robust_sets: list[bench_gn.Dataset]

    def gn(self, dataset: str, method: str) -> Cell | None:
        return self.cells.get(("gn", dataset, CLEAN, 0, 0, method))

    def robust(self, dataset: str, policy: str, count: int, seed: int, method: str) -> Cell | None:
        return self.cells.get(("robust", dataset, policy, count, seed, method))

    def robust_keys(self) -> list[tuple[str, str, int, int]]:
        return [(d.name, p, c, s) for d in self.robust_sets for p in self.args.policies
                for c in self.args.counts for s in self.args.seeds]

    @property
    def peer(self) -> bool:
        return self.args.peer == "gtsam"


def gn_section(ctx: Context) -> list[str]:
    """Gauss-Newton on the clean graphs: time table, then accuracy and memory table."""
    lines = ["## Gauss-Newton on the clean graphs", ""]
    time_rows, accuracy_rows = [], []
    for dataset in ctx.gn_sets:
        p, g = ctx.gn(dataset.name, PGEM_GN), ctx.gn(dataset.name, GTSAM_GN)
        p_time, g_time = (p.median_time() if p else None), (g.median_time() if g else None)
        time_rows.append([
            dataset.name, dimension_of(p), format_count(solver_median(p, "poses")),
            format_count(solver_median(p, "edges")),
            entry(p, format_seconds(p_time), True), entry(g, format_seconds(g_time), True),
            f"**{format_times_ratio(ratio(g_time, p_time))}**" if ratio(g_time, p_time) else NO_NUMBER,
            entry(p, iterations_text(PGEM_GN, p.ok if p else [])) + " / " + entry(g, iterations_text(GTSAM_GN, g.ok if g else [])),
            entry(p, format_seconds(ratio(p_time, solver_median(p, "iterations")))),
            entry(g, format_seconds(ratio(g_time, solver_median(g, "iterations")))),
        ])
        p_block, g_growth = solver_median(p, "block_bytes"), solver_median(g, "peak_rss_growth")
        accuracy_rows.append([
            dataset.name, entry(p, format_chi2(solver_median(p, "final_chi2"))),
            entry(g, format_chi2(solver_median(g, "final_chi2"))),
            entry(p, format_length(score_median(p, "ate_translation_rmse"))),
            entry(g, format_length(score_median(g, "ate_translation_rmse"))),
            entry(p, format_bytes(p_block)), entry(g, format_bytes(g_growth)),
            format_times_ratio(ratio(g_growth, p_block)),
        ])
    lines += table(["dataset", "dim", "poses", "edges", "pgem time", "GTSAM time", "GTSAM/pgem time",
                    "iterations pgem / GTSAM", "pgem per iter", "GTSAM per iter"], "llrrrrrrrr", time_rows)
    lines += ["", *table(["dataset", "pgem final chi2", "GTSAM final chi2", "pgem position RMSE",
                          "GTSAM position RMSE", "pgem block", "GTSAM peak RSS growth", "GTSAM/pgem memory"],
                         "lrrrrrrr", accuracy_rows)]
    lines += ["", f"Times are medians of {ctx.args.runs} run(s) per solver. **GTSAM/pgem time** is how many "
              "times faster pgem is (below 1: GTSAM is faster); **per iter** divides the median time by the "
              "median iteration count. **Final chi2** is in g2o's convention for both. **Position RMSE** "
              "is `pgem eval`'s ATE against the clean optimum (pgem's own Gauss-Newton solve of the file, "
              "written with `-o`): the RMS position error after a rigid alignment, which changes little "
              "since both solvers hold the first pose at the same value. The reference is pgem's own "
              "solve, so pgem's RMSE is 0 (or rounding) by construction; GTSAM's says how far its "
              "optimum is from pgem's. **pgem block** is pgem's whole fixed memory block; **GTSAM peak "
              "RSS growth** is its process's resident-set growth during the solve."]
    return lines


def robust_section(ctx: Context) -> list[str]:
    """Robust solves of the corrupted graphs: one row per cell and solver."""
    lines = ["## Robust solves on corrupted graphs", ""]
    rows = []
    for dataset, policy, count, seed in ctx.robust_keys():
        base = ctx.robust(dataset, policy, count, seed, PGEM_EM)
        base_time = base.median_time() if base else None
        clean_gn = ctx.gn(dataset, PGEM_GN)
        clean_time = clean_gn.median_time() if clean_gn else None
        base_block = solver_median(base, "block_bytes")
        for method in robust_methods(ctx.args):
            cell = ctx.robust(dataset, policy, count, seed, method)
            median = cell.median_time() if cell else None
            memory = solver_median(cell, "block_bytes" if method == PGEM_EM else "peak_rss_growth")
            rows.append([
                dataset, policy, str(count), str(seed), method,
                entry(cell, format_seconds(median), True),
                NO_NUMBER if method == PGEM_EM else entry(cell, f"**{format_times_ratio(ratio(median, base_time))}**"),
                entry(cell, format_times_ratio(ratio(median, clean_time))) if clean_time else NO_NUMBER,
                entry(cell, iterations_text(method, cell.ok if cell else [])),
                entry(cell, format_seconds(per_iteration(method, cell))),
                entry(cell, format_chi2(solver_median(cell, "final_chi2"))),
                entry(cell, f"{format_ratio(score_median(cell, 'precision'))} / "
                            f"{format_ratio(score_median(cell, 'recall'))}"),
                entry(cell, format_length(score_median(cell, "ate_translation_rmse"))),
                entry(cell, format_bytes(memory)),
                NO_NUMBER if method == PGEM_EM else entry(cell, format_times_ratio(ratio(memory, base_block))),
            ])
    lines += table(["dataset", "policy", "false loops", "seed", "solver", "time", "x pgem-em time",
                    "/ clean GN", "iterations", "per iter", "final chi2", "P / R", "ATE", "memory",
                    "x pgem-em memory"],
                   "llrrlrrrrrrrrrr", rows)
    clean = {d.name: solver_median(ctx.gn(d.name, PGEM_GN), "final_chi2") for d in ctx.robust_sets}
    clean_text = "; ".join(f"{name} {value:.6g}" for name, value in clean.items() if value is not None)
    lines += ["", f"Times are medians of {ctx.args.robust_runs} run(s) per solver and cell. **x pgem-em time** "
              "is the solver's median time over pgem EM's (above 1: pgem is faster). **/ clean GN** is the solver's "
              "median time over pgem's Gauss-Newton solve of the clean graph (the same dataset without the "
              "false loops, from the Gauss-Newton table): what robustness costs over a solve that needs none. "
              "**Iterations**: pgem EM's "
              "E/M iterations and Gauss-Newton iterations (M-steps and the final re-solve; **per iter** is per "
              "GN iteration), GTSAM's Levenberg-Marquardt iterations (per LM iteration). **Final chi2**: g2o "
              "convention over the edges kept at weight 1, i.e. odometry and the loop closures not rejected "
              "(pgem: not pruned; GTSAM: weight at least "
              f"{bench_robust.DEFAULT_REJECT_BELOW:g})"
              + (f"; the clean graph's optimum has {clean_text}" if clean_text else "")
              + ". **P / R**: precision / recall of the rejected loops, from `pgem eval` (1.000 / 1.000 = "
              "exactly the false loops rejected). **ATE**: translation ATE against the clean optimum. "
              "**Memory**: pgem's block, GTSAM's peak RSS growth during the solve."]
    if ctx.peer and not ctx.args.with_gnc:
        lines += ["", "GTSAM's GNC (graduated non-convexity, TLS loss) was not run: it re-runs a whole "
                  "Levenberg-Marquardt solve at each of its outer iterations and takes minutes per cell "
                  "(it did not finish in 600 s on M3500 with 1000 random false loops); add `--with-gnc`."]
    return lines


def memory_section(ctx: Context) -> list[str]:
    """pgem's block made up per pose, per edge and factor, next to GTSAM's growth."""
    rows = []
    sizes: dict[str, tuple[float, float]] = {}
    items: list[tuple[str, Cell | None, Cell | None]] = [
        (d.name, ctx.gn(d.name, PGEM_GN), ctx.gn(d.name, GTSAM_GN)) for d in ctx.gn_sets]
    items += [(f"{d} + {c} {p} (seed {s})", ctx.robust(d, p, c, s, PGEM_EM), ctx.robust(d, p, c, s, GTSAM_DCS))
              for d, p, c, s in ctx.robust_keys()]
    for label, p, g in items:
        if p is None or not p.ok:
            continue
        poses, edges = solver_median(p, "poses"), solver_median(p, "edges")
        block, per_pose = solver_median(p, "block_bytes"), solver_median(p, "block_bytes_per_pose")
        per_edge, factor = solver_median(p, "block_bytes_per_edge"), solver_median(p, "block_bytes_factor")
        if None in (poses, edges, block, per_pose, per_edge, factor):
            continue
        dimension = dimension_of(p)
        sizes.setdefault(dimension, (per_pose, per_edge))
        rest = block - poses * per_pose - edges * per_edge - factor
        growth = solver_median(g, "peak_rss_growth")
        rows.append([
            label, dimension, format_count(poses), format_count(edges), format_bytes(block), f"{per_pose:g} B",
            f"{per_edge:g} B", format_bytes(factor), format_bytes(rest), format_bytes(block / poses),
            format_bytes(block / edges), entry(g, format_bytes(growth)),
            entry(g, format_bytes(ratio(growth, poses))), entry(g, format_bytes(ratio(growth, edges))),
            format_times_ratio(ratio(growth, block)),
        ])
    lines = ["## Memory", ""]
    lines += table(["graph", "dim", "poses", "edges", "pgem block", "per pose", "per edge", "factor part",
                    "rest", "block / pose", "block / edge", "GTSAM growth", "growth / pose", "growth / edge",
                    "GTSAM/pgem"], "llrrrrrrrrrrrrr", rows)
    summary = "; ".join(f"{dim}: {pp:g} B per pose and {pe:g} B per edge of capacity"
                        for dim, (pp, pe) in sorted(sizes.items()))
    lines += ["", "pgem's block = poses x **per pose** + edges x **per edge** + **factor part** + **rest**. "
              "The three figures are `pgem optimize --json`'s `block_bytes_per_pose`, `block_bytes_per_edge` "
              "and `block_bytes_factor`, from `pgem_memory_size()` on the instance's configuration: the cost "
              "of one more pose or edge of capacity (averaged over 16 to leave out alignment padding), and "
              "the bytes that scale with the factor's budget (8 bytes per nonzero plus 4 per b x b block; "
              "the command sizes the budget to the factor it analyses, for a robust solve the factor with "
              "every loop closure active). The rest is the instance itself and the id map (a power of two "
              "of 4-byte slots, 8 to 16 bytes per pose). "
              + (f"Per dimension: {summary}. " if summary else "")
              + "GTSAM's growth is its process's peak RSS during the solve minus the RSS before it "
              "(graph already built), divided by the graph's poses or edges for the per-pose and per-edge "
              "columns: an average, not a marginal cost, and page-granular with allocator caching, so "
              "compare orders of magnitude. Robust rows: GTSAM DCS's growth on the corrupted graph."]
    return lines


def spread_section(ctx: Context) -> list[str]:
    """min / median / max per measurement and side, and one sentence on the noise."""
    rows, spreads = [], []
    for key, cell in ctx.cells.items():
        phase, dataset, policy, count, seed, method = key
        label = dataset if phase == "gn" else f"{dataset} {policy} {count} seed {seed}"
        values = times(cell)
        spread = spread_percent(values)
        if spread is not None:
            spreads.append((spread, label, method))
        rows.append([label, method, f"{len(values)}/{len(cell.runs)}",
                     format_seconds(min(values)) if values else NO_NUMBER,
                     format_seconds(statistics.median(values)) if values else NO_NUMBER,
                     format_seconds(max(values)) if values else NO_NUMBER,
                     NO_NUMBER if spread is None else f"{spread:.0f}%"])
    lines = ["## Timing spread", ""]
    lines += table(["measurement", "solver", "runs ok", "min", "median", "max", "spread"], "llrrrrr", rows)
    lines += ["", "Spread = (max - min) / median. " + noise_sentence(spreads, ctx.args.load)]
    return lines


def noise_sentence(spreads: Sequence[tuple[float, str, str]], load: tuple[str, str]) -> str:
    """How noisy the runs were, in one or two sentences."""
    load_text = f"Load average (1 min) {load[0]} at the start and {load[1]} at the end."
    if not spreads:
        return ("Every measurement is a single run: there is no spread, and one run on a shared machine "
                f"says little; do not quote these timings. {load_text}")
    values = [s for s, _, _ in spreads]
    worst = max(spreads)
    median = statistics.median(values)
    verdict = ("quiet" if worst[0] < 10 else "moderately noisy" if worst[0] < 30 else "noisy")
    return (f"The runs were {verdict}: median spread {median:.0f}%, largest {worst[0]:.0f}% ({worst[2]} on "
            f"{worst[1]}). {load_text} Quote medians and ratios of medians, not single runs; more runs "
            "(`--runs`, `--robust-runs`) narrow them.")


def target_lines(ctx: Context) -> list[str]:
    """The targets, met or missed, with this run's ratios."""
    lines = ["## Targets", ""]

    def verdict(ok: bool | None) -> str:
        return "not measured" if ok is None else ("**met**" if ok else "**missed**")

    # 1. GN speed-up on every dataset.
    parts, states = [], []
    for dataset in ctx.gn_sets:
        p, g = ctx.gn(dataset.name, PGEM_GN), ctx.gn(dataset.name, GTSAM_GN)
        value = ratio(g.median_time() if g else None, p.median_time() if p else None)
        state = None if value is None else value >= TARGET_GN_SPEEDUP
        states.append(state)
        parts.append(f"{dataset.name} {format_times_ratio(value)} ({verdict(state).strip('*')})")
    overall = None if not states or any(s is None for s in states) else all(states)
    head = f"- Gauss-Newton at least {TARGET_GN_SPEEDUP:g}x faster than GTSAM on every dataset: "
    if not ctx.peer:
        lines.append(head + "not measured (GTSAM not run).")
    else:
        met = sum(bool(s) for s in states)
        lines.append(head + f"{verdict(overall)} (met on {met} of {len(states)}). GTSAM/pgem time: "
                     + ("; ".join(parts) or "no dataset") + ".")

    # 2 and 3. The robust cell.
    dataset, policy, count = TARGET_CELL
    gn_time = ctx.gn(dataset, PGEM_GN).median_time() if ctx.gn(dataset, PGEM_GN) else None
    seeds = [s for s in ctx.args.seeds if ctx.robust(dataset, policy, count, s, PGEM_EM) is not None]
    if not seeds:
        lines.append(f"- pgem EM at least {TARGET_EM_SPEEDUP:g}x faster than GTSAM DCS on {dataset} with {count} "
                     f"{policy} false loops, precision = recall = 1: not measured (the cell was not run).")
        lines.append(f"- pgem EM on that cell at most {TARGET_EM_OVER_GN:g}x pgem's Gauss-Newton time on the clean "
                     f"{dataset}: not measured.")
        return lines
    for seed in seeds:
        em = ctx.robust(dataset, policy, count, seed, PGEM_EM)
        dcs = ctx.robust(dataset, policy, count, seed, GTSAM_DCS)
        em_time = em.median_time()
        speedup = ratio(dcs.median_time() if dcs else None, em_time)
        perfect = em.perfect()
        state = None if speedup is None else (speedup >= TARGET_EM_SPEEDUP and perfect)
        pr = f"{format_ratio(em.min('precision'))} / {format_ratio(em.min('recall'))}"
        lines.append(f"- pgem EM at least {TARGET_EM_SPEEDUP:g}x faster than GTSAM DCS on {dataset} with {count} "
                     f"{policy} false loops (seed {seed}), precision = recall = 1: {verdict(state)}. "
                     f"DCS/pgem time {format_times_ratio(speedup)}; pgem precision / recall (worst run) {pr}"
                     + ("" if ctx.peer else " (GTSAM not run)") + ".")
        over = ratio(em_time, gn_time)
        state = None if over is None else over <= TARGET_EM_OVER_GN
        lines.append(f"- pgem EM on that cell (seed {seed}) at most {TARGET_EM_OVER_GN:g}x pgem's Gauss-Newton time "
                     f"on the clean {dataset}: {verdict(state)}. EM {format_seconds(em_time)} / GN "
                     f"{format_seconds(gn_time)} = {format_times_ratio(over)}.")
    return lines


def caveat_lines(ctx: Context) -> list[str]:
    """What is and is not timed, and the known differences between the two sides."""
    lines = ["## What is timed", "",
             "- pgem: `solve_seconds` of `pgem optimize --json`, the `pgem_optimize` or `pgem_robust_optimize` "
             "call. Gauss-Newton: plus `analysis_seconds`, the symbolic analysis (fill-reducing ordering "
             "and symbolic factorisation) the command runs while loading to size its block, which the "
             "solve then reuses. Robust: the solve's own analyses are in `solve_seconds`; the one at "
             "loading (over every loop, to size the block) is left out, since EM rebuilds the structure "
             "for the loops it keeps. Not timed: reading the file and building the instance.",
             "- GTSAM: optimizer construction plus `optimize()` in a fresh process. Not timed: reading the "
             "file and building the factor graph in Python. Its ordering and symbolic elimination are "
             "timed, redone at every iteration.",
             "- Both stop at 100 iterations; pgem when chi2 decreases by less than 1e-9 relatively, GTSAM at "
             "relative and absolute error tolerance 1e-9. GTSAM holds the first pose with a prior of sigma "
             "1e-6, as pgem holds its gauge. Robust GTSAM: Levenberg-Marquardt with DCS (phi = 1) on every "
             "loop closure (|from - to| != 1), odometry Gaussian; a loop weighted below "
             f"{bench_robust.DEFAULT_REJECT_BELOW:g} counts as rejected.",
             "- 3D: GTSAM applies the file's rotation information to its angle-axis error (about twice g2o's "
             "quaternion-vector error), so it minimises a different cost: its g2o-convention chi2 and its "
             "distance to pgem's optimum are not zero even when converged."]
    return lines


def header_lines(ctx: Context) -> list[str]:
    args = ctx.args
    lines = ["# pgem vs GTSAM", "", ctx.header + ".", ""]
    grid = (f"Clean graphs: {', '.join(d.name for d in ctx.gn_sets) or 'none'}. Corrupted: "
            f"{', '.join(d.name for d in ctx.robust_sets) or 'none'}; policies {', '.join(args.policies)}; "
            f"false loops {', '.join(map(str, args.counts))}; seeds {', '.join(map(str, args.seeds))}. "
            f"Solvers: {', '.join(gn_methods(args) + robust_methods(args))}; GTSAM runs time out after "
            f"{args.timeout:g} s.")
    return lines + [grid]


def failure_lines(records: Sequence[Record]) -> list[str]:
    return [f"- {r.run.dataset} {'' if r.phase == 'gn' else f'{r.run.policy} {r.run.count} seed {r.run.seed} '}"
            f"{r.run.method} run {r.repeat}: {r.run.status}: {r.run.error}"
            for r in records if r.run.status != "ok"]


def render(ctx: Context, records: Sequence[Record], notes: Sequence[str], wall: float) -> str:
    lines = header_lines(ctx)
    for section in (gn_section, robust_section, memory_section, spread_section, caveat_lines):
        lines += [""] + section(ctx)
    lines += ["", "## Failures and timeouts", ""] + (failure_lines(records) or ["None."])
    if notes:
        lines += ["", "## Notes", ""] + [f"- {note}" for note in notes]
    lines += [""] + target_lines(ctx)
    lines += ["", f"Wall time of the benchmark: {format_duration(wall)}."]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def load_average() -> str:
    try:
        with open("/proc/loadavg", encoding="ascii") as handle:
            return handle.read().split()[0]
    except OSError:
        return "unknown"


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, help=f"Gauss-Newton runs per solver and graph (default {GN_RUNS}; "
                                                 "--quick: 1)")
    parser.add_argument("--robust-runs", type=int, help=f"robust runs per solver and cell (default {ROBUST_RUNS}; "
                                                        "--quick: 1)")
    parser.add_argument("--datasets", type=Path, default=bench_gn.DEFAULT_DATASETS,
                        help="datasets folder with 2d/ and 3d/ (default ../shared/datasets beside the repository)")
    parser.add_argument("--pgem", type=Path, default=bench_gn.DEFAULT_PGEM,
                        help="pgem binary (default build/release/tools/pgem/pgem)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="Markdown report; the raw runs go beside it as .json (default build/bench/bench.md)")
    parser.add_argument("--work", type=Path, help="references, corrupted graphs and results "
                                                  "(default: beside --out, <name>_work)")
    parser.add_argument("--files", help=f"clean graphs for Gauss-Newton (default {','.join(GN_FILES)})")
    parser.add_argument("--robust-files", help=f"graphs to corrupt (default {','.join(ROBUST_FILES)})")
    parser.add_argument("--policies", help=f"false-loop policies (default {','.join(POLICIES)}; any of "
                                           f"{','.join(bench_robust.POLICIES)})")
    parser.add_argument("--counts", help=f"false-loop counts (default {','.join(map(str, COUNTS))})")
    parser.add_argument("--seeds", help=f"corruption seeds (default {','.join(map(str, SEEDS))})")
    parser.add_argument("--with-gnc", action="store_true", help="also run GTSAM's GNC on the corrupted graphs "
                                                                "(slow: minutes per cell)")
    parser.add_argument("--peer", choices=("gtsam", "none"), default="gtsam",
                        help="the library to compare with; none: pgem alone, no gtsam or numpy needed")
    parser.add_argument("--timeout", type=float, default=bench_robust.DEFAULT_TIMEOUT,
                        help="seconds before a GTSAM run is killed and recorded as a timeout (default 300)")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: 1 run; Gauss-Newton on intel and input_M3500_g2o, EM on input_M3500_g2o "
                             "with 100 random false loops")
    args = parser.parse_args(argv)
    quick = QUICK if args.quick else {"files": GN_FILES, "robust_files": ROBUST_FILES, "policies": POLICIES,
                                      "counts": COUNTS, "seeds": SEEDS}
    split = bench_robust.split_list
    args.names = split(args.files, quick["files"])
    args.robust_names = split(args.robust_files, quick["robust_files"])
    args.policies = split(args.policies, quick["policies"])
    try:
        args.counts = split(args.counts, quick["counts"], int)
        args.seeds = split(args.seeds, quick["seeds"], int)
    except ValueError:
        parser.error("--counts and --seeds take comma-separated integers")
    unknown = [p for p in args.policies if p not in bench_robust.POLICIES]
    if unknown:
        parser.error(f"unknown policy {', '.join(unknown)} (choose from {', '.join(bench_robust.POLICIES)})")
    args.runs = args.runs if args.runs is not None else (1 if args.quick else GN_RUNS)
    args.robust_runs = args.robust_runs if args.robust_runs is not None else (1 if args.quick else ROBUST_RUNS)
    if args.runs < 1 or args.robust_runs < 1 or args.timeout <= 0 or any(c < 1 for c in args.counts):
        parser.error("--runs, --robust-runs, --timeout and --counts must be positive")
    if not (args.names or args.robust_names):
        parser.error("no dataset asked for")
    args.pgem, args.out = args.pgem.resolve(), args.out.resolve()
    args.work = (args.work or args.out.parent / f"{args.out.stem}_work").resolve()
    args.reject_below = bench_robust.DEFAULT_REJECT_BELOW  # what bench_robust.run_method reads
    return args


def check_peer(args: argparse.Namespace) -> None:
    """With --peer gtsam, the GTSAM workers need gtsam and numpy in this Python."""
    if args.peer != "gtsam":
        return
    missing = [name for name in ("gtsam", "numpy") if importlib.util.find_spec(name) is None]
    if missing:
        raise BenchError(f"{' and '.join(missing)} cannot be imported by {sys.executable}: "
                         f"{pip_install(missing)}; or run pgem alone with --peer none")


def pip_install(packages: list[str]) -> str:
    """What to run to install packages into this Python: its venv's pip, or on Debian 12 (whose
    Python is externally managed, PEP 668) pip beside apt's packages as tools/setup-debian does."""
    names = " ".join(packages)
    if sys.prefix != sys.base_prefix:
        return f"run {sys.executable} -m pip install {names}"
    pip = "" if importlib.util.find_spec("pip") else "apt-get install python3-pip, then "
    return (f"run tools/setup-debian (as root or with sudo), or by hand {pip}python3 -m pip install "
            f"--break-system-packages {names}; or in a venv: apt-get install python3-venv, then "
            f"python3 -m venv ~/venv && ~/venv/bin/pip install {names} and run "
            f"~/venv/bin/python3 {sys.argv[0]}")


def resolve(args: argparse.Namespace, notes: list[str]) -> tuple[list[bench_gn.Dataset], list[bench_gn.Dataset]]:
    """The clean and the to-be-corrupted datasets found; a missing one is a note."""
    gn_sets, gn_missing = bench_gn.resolve_datasets(args.datasets, args.names)
    robust_sets, robust_missing = bench_gn.resolve_datasets(args.datasets, args.robust_names)
    for name in dict.fromkeys(gn_missing + robust_missing):
        notes.append(f"{name}: dataset not found, skipped.")
        progress(f"note: dataset {name} not found under {args.datasets}, skipping it")
    if not gn_sets and not robust_sets:
        raise BenchError(f"none of the datasets {', '.join(dict.fromkeys(args.names + args.robust_names))} "
                         f"found under {args.datasets} (pass --datasets DIR)")
    return gn_sets, robust_sets


def write_raw(path: Path, args: argparse.Namespace, header: str, records: Sequence[Record]) -> None:
    """Every run as JSON: the options, the header line and each run's summary and scores."""
    options = {key: (str(value) if isinstance(value, Path) else value) for key, value in vars(args).items()}
    runs = [{"phase": r.phase, "repeat": r.repeat, **asdict(r.run)} for r in records]
    path.write_text(json.dumps({"header": header, "options": options, "runs": runs}, indent=1) + "\n",
                    encoding="utf-8")


def run_benchmark(args: argparse.Namespace) -> None:
    bench_robust.check_pgem(args.pgem)
    check_peer(args)
    notes: list[str] = []
    gn_sets, robust_sets = resolve(args, notes)
    fingerprint = bench_gn.binary_fingerprint(args.pgem)
    start_load = load_average()
    runs = (f"{args.runs} run(s) per solver per clean graph, {args.robust_runs} per solver per corrupted "
            "graph, interleaved")
    header = bench_gn.machine_line(args.pgem, runs, gtsam=args.peer == "gtsam")
    progress(header)
    start = time.perf_counter()
    eta = Eta(plan(args, gn_sets, robust_sets))
    records = bench_gn_phase(args, gn_sets, eta, notes)
    records += bench_robust_phase(args, robust_sets, eta, notes)
    args.load = (start_load, load_average())
    rebuilt = bench_gn.rebuilt_note(args.pgem, fingerprint, "the results")
    if rebuilt:
        notes.append(rebuilt)
    ctx = Context(args, header, group(records), gn_sets, robust_sets)
    report = render(ctx, records, notes, time.perf_counter() - start)
    print(report)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report, encoding="utf-8")
    raw = args.out.with_suffix(".json")
    write_raw(raw, args, header, records)
    progress(f"report written to {args.out}; raw runs in {raw.name}")


def main(argv: Sequence[str]) -> int:
    args = parse_args(argv)
    try:
        run_benchmark(args)
    except BenchError as error:
        print(f"bench: error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
