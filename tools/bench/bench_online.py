#!/usr/bin/env python3
"""Online benchmark: the pgem library and GTSAM's iSAM2 fed the same stream, every update timed.

``python3 tools/bench/bench_online.py`` streams each graph as a robot's front-end would: pose
k (the file's VERTEX line, or a guess composed along the odometry for edge-only files), then
every edge whose later pose is k, in file order, then one update. pgem's side is
``pgem-online-driver`` (built with the tools): ``--mode full`` is what the LCM bridge does today
on every solve (EM on the whole graph, warm-started), ``--mode incremental`` the library's
incremental update once it has one. GTSAM's side is ``isam2_worker.py``: ISAM2 with its default
parameters, ``update()`` once per pose, plain factors (``isam2``) or Cauchy on the loop closures
(``isam2-cauchy``).

Cells: M3500 and City10000, clean and with false loops from ``pgem corrupt``, and a KITTI file
with its real false loops. Per cell and method: per-update latency (median, p99, max, the last
1000 poses, the last 10 %), total time, the final estimate's chi2 against the batch optimum
(``pgem optimize``, ``--robust em`` when there are false loops), its ATE against that optimum
and the loops it rejected (``pgem eval``); then the targets of issue 20, met or missed.

iSAM2's results depend only on the input file and the parameters: they are cached in the work
folder (like bench_real.py), so a re-run after a change to pgem re-runs pgem alone.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import hashlib
import json
import math
import shutil
import statistics
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402  (load average, peer check)
import bench_gn  # noqa: E402  (machine header, binary fingerprint, progress)
import bench_lcm  # noqa: E402  (nearest-rank percentile, the bridge's latency benchmark)
import bench_real  # noqa: E402  (KITTI cells, cell selection, the peer cache, pgem eval)
import bench_robust  # noqa: E402  (corruption, commands, formats)
import isam2_worker  # noqa: E402  (GTSAM's iSAM2 fed the stream, in its own process)

DEFAULT_OUT = bench_gn.REPO_ROOT / "build" / "bench" / "bench_online.md"
DEFAULT_WORK = DEFAULT_OUT.with_name("bench_online_work")

GRAPHS = {"M3500": "2d/input_M3500_g2o.g2o", "City10000": "2d/city10000.g2o"}  # synthetic graphs
KITTI = ("kitti_00_alpha_0.50",)  # real cells (DATASETS/real/kitti/NAME.g2o and its labels)
COUNTS = (100, 1000)
QUICK_CELLS = ("M3500/clean", "M3500/random/100/s1", "kitti/kitti_09_alpha_1.00")
QUICK_KITTI = ("kitti_09_alpha_1.00",)
QUICK_EVERY = 100  # --quick: one pgem update per 100 poses
DEFAULT_TIMEOUT = 3600.0  # s of streaming per run; the process is killed a while after
LAST_POSES = 1000  # the "last 1000 poses" column
TARGET_CELLS = ("M3500/clean", "City10000/clean")  # median and p99 at most iSAM2's
TARGET_LAST_CELL, TARGET_LAST_SECONDS = "City10000/clean", 0.010  # last-1000-pose median
TARGET_GAP = 1e-6  # relative chi2 of the final estimate against the batch optimum
TARGET_PR_COUNT = 100  # cells with this many false loops: P and R equal to the batch EM's
TARGET_LCM_P99 = 0.100  # s: the bridge's loop-closure latency on City10000 + 100 false loops
LCM_FILE, LCM_RATE = "city10000", 200.0  # bench_lcm.py's City10000 cell and its edges/s
PROGRESS_SECONDS = 10.0  # between progress lines of one run
CACHE_FORMAT = 1


# --------------------------------------------------------------------------------------
# Methods and cells
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Method:
    """One online method: a pgem-online-driver mode or an iSAM2 worker method."""

    name: str  # pgem-full, pgem-incremental, isam2, isam2-cauchy
    label: str  # what the tables show
    mode: str  # the driver's --mode, or the worker's method
    reject_below: float  # pgem eval --reject-below: pgem's pruned loops only (0), iSAM2's weights

    @property
    def is_pgem(self) -> bool:
        return self.name.startswith("pgem-")


METHODS = (
    Method("pgem-full", "pgem full re-solve (bridge)", "full", 0.0),
    Method("pgem-incremental", "pgem incremental", "incremental", 0.0),
    Method("isam2", "iSAM2", "isam2", bench_robust.DEFAULT_REJECT_BELOW),
    Method("isam2-cauchy", "iSAM2 + Cauchy", "isam2-cauchy", bench_robust.DEFAULT_REJECT_BELOW),
)
ONLINE_SUBJECTS = ("pgem-incremental", "pgem-full")  # the first with results is checked by the targets


@dataclass
class Cell:
    """One graph streamed: clean, corrupted, or a KITTI file with labelled loops."""

    name: str  # M3500/clean, City10000/random/1000/s1, kitti/kitti_00_alpha_0.50
    source: Path  # the dataset file
    count: int = 0  # false loops added (0: clean or real)
    policy: str = ""
    seed: int = 0
    labels: Path | None = None  # KITTI: the true loops
    every: int = 1  # pgem updates once per this many poses
    # filled by prepare():
    stream_input: Path | None = None  # what pgem-online-driver reads
    peer_input: Path | None = None  # the same graph with the initial guesses as VERTEX lines
    outliers: Path | None = None  # the false loops, one 'from to' per line (None: clean)
    poses: int = 0
    guess_check: str = ""
    error: str = ""

    @property
    def robust(self) -> bool:
        return self.outliers is not None

    @property
    def slug(self) -> Path:
        return Path(*self.name.split("/"))


def all_cells(args: argparse.Namespace) -> list[Cell]:
    """Every graph clean and corrupted, then the KITTI files."""
    cells = []
    for short, graph in GRAPHS.items():
        source = args.datasets / graph
        cells.append(Cell(f"{short}/clean", source))
        cells += [Cell(f"{short}/{args.policy}/{count}/s{args.seed}", source, count, args.policy, args.seed)
                  for count in args.counts]
    for name in args.kitti:
        graph = args.datasets / "real" / "kitti" / f"{name}.g2o"
        cells.append(Cell(f"kitti/{name}", graph, labels=graph.with_name(f"{name}_GT_LC.txt")))
    return cells


def every_for(cell: str, rules: Sequence[tuple[str, int]], default: int) -> int:
    """The --every value of a cell: the last PATTERN=N rule that matches it, else the default."""
    chosen = default
    for pattern, every in rules:
        if pattern == "*" or bench_real.select([Cell(cell, Path())], [pattern]):
            chosen = every
    return chosen


def prepare(args: argparse.Namespace, cell: Cell, fingerprint: str) -> None:
    """The cell's inputs: the corrupted graph, or KITTI's written guess and false loops."""
    folder = args.work / "inputs" / cell.slug
    try:
        if cell.labels is not None:
            real = bench_real.Cell(cell.name, "real", cell.source, None, labels=cell.labels)
            bench_real.prepare_real(args.pgem, real, folder, fingerprint)
            cell.stream_input, cell.peer_input, cell.outliers = cell.source, real.peer_input, real.outliers
            cell.guess_check = real.guess_check
        elif cell.count > 0:
            corrupted = bench_robust.make_corrupted(args.pgem, cell.source, folder, cell.policy, cell.count,
                                                    cell.seed, None)
            cell.stream_input = cell.peer_input = corrupted
            cell.outliers = Path(str(corrupted) + ".outliers")
            cell.guess_check = "same file"
        else:
            cell.stream_input = cell.peer_input = cell.source
            cell.guess_check = "same file"
        cell.poses = sum(1 for line in open(cell.peer_input, encoding="ascii", errors="replace")
                         if line.startswith("VERTEX"))
    except (bench_robust.RunFailure, OSError, ValueError, KeyError) as error:
        cell.error = f"not prepared: {error}"


# --------------------------------------------------------------------------------------
# Runs: one streamed process, its update lines read as they come
# --------------------------------------------------------------------------------------


@dataclass
class Run:
    """One method streaming one cell once."""

    cell: str
    method: str
    run: int
    status: str = "ok"  # ok | failed | timeout | unavailable
    error: str = ""
    updates: list[dict[str, Any]] = field(default_factory=list)  # the update lines
    summary: dict[str, Any] = field(default_factory=dict)  # the summary line
    result: str = ""  # the final estimate (g2o)
    weights: str = ""  # its weights file
    cached: bool = False
    cache_date: str = ""
    load: tuple[str, str] = ("", "")  # load average before and after

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def stopped(self) -> bool:
        return bool(self.summary.get("stopped"))


class Watch:
    """Progress of one run on stderr, every PROGRESS_SECONDS, with a time-to-go that assumes the
    cost of an update grows linearly with the poses (a full re-solve; an upper bound otherwise)."""

    def __init__(self, where: str, poses: int, eta: bench.Eta) -> None:
        self.where, self.poses, self.eta = where, max(poses, 1), eta
        self.start = self.next = time.perf_counter()
        self.next += PROGRESS_SECONDS

    def line(self, update: dict[str, Any]) -> None:
        now = time.perf_counter()
        if now < self.next:
            return
        self.next = now + PROGRESS_SECONDS
        done = int(update.get("pose", 0)) + 1
        elapsed = now - self.start
        left = elapsed * (self.poses ** 2 / done ** 2 - 1.0)
        bench_gn.progress(f"{self.where}: pose {done}/{self.poses}, {update.get('update')} updates, last "
                 f"{bench_robust.format_seconds(update.get('seconds'))}, {bench_robust.format_duration(elapsed)} so far, "
                 f"about {bench_robust.format_duration(left)} to go in this run")


def stream_process(command: Sequence[str], kill_after: float, log: Path, watch: Watch,
                   others: list[dict[str, Any]] | None = None) -> tuple[int, list, dict, bool]:
    """Runs a streaming process (JSON lines on stdout: updates, then a summary; stderr into log),
    killed after kill_after seconds; (exit status, update lines, summary, killed). Lines of any
    other type go to `others` when given."""
    log.parent.mkdir(parents=True, exist_ok=True)
    updates: list[dict[str, Any]] = []
    summary: dict[str, Any] = {}
    killed = threading.Event()
    with open(log, "w", encoding="utf-8") as errors:
        proc = subprocess.Popen(list(command), stdout=subprocess.PIPE, stderr=errors, text=True)

        def kill() -> None:
            killed.set()
            proc.kill()

        timer = threading.Timer(kill_after, kill)
        timer.start()
        try:
            for text in proc.stdout:
                try:
                    line = json.loads(text)
                except json.JSONDecodeError:
                    continue
                if line.get("type") == "update":
                    updates.append(line)
                    watch.line(line)
                elif line.get("type") == "summary":
                    summary = line
                elif others is not None:
                    others.append(line)
            code = proc.wait()
        finally:
            timer.cancel()
    return code, updates, summary, killed.is_set()


def first_error(log: Path) -> str:
    """The first line of a run's stderr log."""
    try:
        return bench_robust.first_line(log.read_text(encoding="utf-8", errors="replace"))
    except OSError:
        return "(no message)"


def run_stream(args: argparse.Namespace, cell: Cell, method: Method, run: int, outdir: Path,
               eta: bench.Eta) -> Run:
    """One run of pgem-online-driver or the iSAM2 worker on a cell, its files in outdir."""
    if outdir.exists():
        shutil.rmtree(outdir)
    outdir.mkdir(parents=True)
    result = outdir / "result.g2o"
    weights = outdir / "weights.txt"
    if method.is_pgem:
        command = [str(args.driver), str(cell.stream_input), "--mode", method.mode, "--every", str(cell.every),
                   "--time-limit", repr(args.timeout), "--quiet", "-o", str(result), "--weights", str(weights)]
    else:
        command = isam2_worker.command(method.mode, cell.peer_input, outdir, args.timeout, "anchored")
    record = Run(cell.name, method.name, run, load=(bench.load_average(), ""))
    watch = Watch(f"[{cell.name}] {method.name} run {run}", cell.poses, eta)
    code, record.updates, record.summary, killed = stream_process(command, args.timeout * 1.2 + 120.0,
                                                                  outdir / "stderr.log", watch)
    record.load = (record.load[0], bench.load_average())
    if killed:
        record.status, record.error = "timeout", f"killed after {args.timeout * 1.2 + 120.0:g} s"
    elif code == 2 and method.is_pgem and not record.updates:
        record.status, record.error = "unavailable", first_error(outdir / "stderr.log")
    elif code != 0 or not record.summary:
        record.status, record.error = "failed", f"exit {code}: {first_error(outdir / 'stderr.log')}"
    elif not (result.is_file() and weights.is_file()):
        record.status, record.error = "failed", "no result or weights file written"
    record.result, record.weights = str(result), str(weights)
    with open(outdir / "updates.jsonl", "w", encoding="utf-8") as handle:
        handle.writelines(json.dumps(line) + "\n" for line in record.updates)
    return record


# --------------------------------------------------------------------------------------
# The peer cache (bench_real's): iSAM2 runs keyed by input, method, parameters, GTSAM, code
# --------------------------------------------------------------------------------------


def peer_code() -> str:
    """What the iSAM2 worker's results depend on in code: it and the modules it imports."""
    digest = hashlib.sha256(bench_real.worker_code().encode())
    digest.update(Path(isam2_worker.__file__).read_bytes())
    return digest.hexdigest()


def peer_job(cell: Cell, method: Method, run: int, gtsam_version: str, code: str) -> bench_real.PeerJob:
    params = (("format", CACHE_FORMAT), ("gtsam", gtsam_version), ("code", code),
              ("parameters", isam2_worker.PARAMETERS), ("guess", "anchored"), ("run", run))
    return bench_real.PeerJob(cell.name, method.name, cell.peer_input, params)


def cached_run(cache: bench_real.Cache, job: bench_real.PeerJob, run: int, timeout: float) -> Run | None:
    """A stored iSAM2 run, unless it stopped at a shorter time limit than asked for now."""
    solve = cache.lookup(job)
    if solve is None:
        return None
    limit = solve.summary.get("time_limit")
    if solve.summary.get("stopped") and limit is not None and float(limit) < timeout:
        return None
    folder = cache.folder(job)
    updates_file = folder / "updates.jsonl"
    updates = [json.loads(line) for line in updates_file.read_text(encoding="utf-8").splitlines()] \
        if updates_file.is_file() else []
    entry = json.loads((folder / "entry.json").read_text(encoding="utf-8"))
    return Run(job.cell, job.method, run, solve.status, solve.error, updates, solve.summary,
               str(folder / "result.g2o"), str(folder / "weights.txt"), True, solve.cache_date,
               tuple(entry.get("load", ("", ""))))


def store_run(cache: bench_real.Cache, job: bench_real.PeerJob, record: Run, outdir: Path) -> Run:
    """Moves a finished iSAM2 run into the cache; the record then points at the cached files."""
    seconds = record.summary.get("update_seconds")
    solve = bench_real.Solve(job.cell, job.method, record.status, record.error, seconds, summary=record.summary)
    solve = cache.store(job, solve, outdir)
    folder = cache.folder(job)
    entry_path = folder / "entry.json"
    entry = json.loads(entry_path.read_text(encoding="utf-8"))
    entry["load"] = list(record.load)
    entry_path.write_text(json.dumps(entry, indent=1) + "\n", encoding="utf-8")
    record.result, record.weights = str(folder / "result.g2o"), str(folder / "weights.txt")
    record.cache_date = solve.cache_date
    return record


# --------------------------------------------------------------------------------------
# Latency statistics
# --------------------------------------------------------------------------------------


@dataclass
class Latency:
    """Per-update wall times of one run (seconds)."""

    updates: int
    median: float
    p99: float
    maximum: float
    max_pose: int  # the pose after which the slowest update ran
    last_poses: float | None  # median over the updates of the last LAST_POSES poses (None: not reached)
    last_tenth: float | None  # median over the updates of the last 10 % of the poses
    total: float
    complete: bool  # the run streamed every pose


def latency(updates: Sequence[dict[str, Any]], poses: int, with_estimate: bool = False) -> Latency | None:
    """Statistics of the update lines; with_estimate adds iSAM2's calculateEstimate() time."""
    if not updates:
        return None
    times = [float(u["seconds"]) + (float(u.get("estimate_seconds", 0.0)) if with_estimate else 0.0)
             for u in updates]
    at = [int(u["pose"]) for u in updates]
    complete = at[-1] == poses - 1
    slowest = max(range(len(times)), key=times.__getitem__)

    def median_from(first_pose: int) -> float | None:
        tail = [t for t, pose in zip(times, at) if pose >= first_pose]
        return statistics.median(tail) if complete and tail else None

    return Latency(len(times), statistics.median(times), bench_lcm.percentile(times, 99), times[slowest],
                   at[slowest], median_from(poses - LAST_POSES), median_from(poses - math.ceil(poses / 10)),
                   math.fsum(times), complete)


def combined(runs: Sequence[Latency]) -> tuple[Latency, float | None]:
    """The median of every statistic over the runs, and the spread of the medians ((max - min)
    as a fraction of their median; None for one run)."""
    if len(runs) == 1:
        return runs[0], None

    def mid(values: Sequence[float | None]) -> float | None:
        known = [v for v in values if v is not None]
        return statistics.median(known) if len(known) == len(values) else None

    medians = [r.median for r in runs]
    merged = Latency(runs[0].updates, *(mid([getattr(r, name) for r in runs])
                                        for name in ("median", "p99", "maximum")), runs[0].max_pose,
                     mid([r.last_poses for r in runs]), mid([r.last_tenth for r in runs]),
                     statistics.median(r.total for r in runs), all(r.complete for r in runs))
    return merged, (max(medians) - min(medians)) / statistics.median(medians)


# --------------------------------------------------------------------------------------
# Scoring: chi2 by pgem itself (one function for every method), pgem eval
# --------------------------------------------------------------------------------------


def read_weights(path: Path) -> dict[tuple[int, int], collections.deque]:
    """'from to weight state' lines by pair, in file order."""
    entries: dict[tuple[int, int], collections.deque] = collections.defaultdict(collections.deque)
    with open(path, encoding="ascii", errors="replace") as handle:
        for line in handle:
            fields = line.split()
            if len(fields) >= 4 and not fields[0].startswith("#"):
                entries[(int(fields[0]), int(fields[1]))].append((float(fields[2]), fields[3]))
    return entries


def kept_edges(pairs: Sequence[tuple[int, int]], weights: Path, reject_below: float) -> list[bool]:
    """Per edge of the graph: odometry, or a loop closure the weights file keeps (not pruned and
    weighted at least reject_below). Pairs are matched in order, as pgem eval does; a loop
    missing from the weights (a run stopped early) is not kept."""
    entries = read_weights(weights)
    kept = []
    for pair in pairs:
        if not bench_real.is_loop(pair):
            kept.append(True)
            continue
        queue = entries.get(pair)
        weight, state = queue.popleft() if queue else (0.0, "absent")
        kept.append(state != "pruned" and state != "absent" and weight >= reject_below)
    return kept


def chi2_on(args: argparse.Namespace, cell: Cell, estimate: Path, kept: Sequence[bool], name: str) -> float:
    """g2o-convention chi2 of an estimate's poses on the cell's kept edges (those whose poses the
    estimate has), computed by pgem itself: the initial chi2 of `pgem optimize` on a file of the
    estimate's VERTEX lines, the graph's FIX lines and those EDGE lines."""
    vertices = [line for line in open(estimate, encoding="ascii", errors="replace") if line.startswith("VERTEX")]
    ids = {int(line.split()[1]) for line in vertices}
    lines, index = list(vertices), 0
    with open(cell.stream_input, encoding="ascii", errors="replace") as handle:
        for line in handle:
            fields = line.split()
            if fields and fields[0] == "FIX":
                lines.append(line)
            elif fields and fields[0].startswith("EDGE"):
                if kept[index] and int(fields[1]) in ids and int(fields[2]) in ids:
                    lines.append(line)
                index += 1
    path = args.work / "eval" / cell.slug / f"{name}.g2o"
    bench_real.write_atomic(path, "".join(lines))
    text = bench_robust.run_command([str(args.pgem), "optimize", str(path), "--solver", "gn", "--max-iterations",
                                     "1", "--json", "--quiet"], "pgem optimize (chi2 of an estimate)")
    path.unlink()
    return float(bench_robust.parse_json(text, "pgem optimize")["initial_chi2"])


@dataclass
class Scores:
    """The final estimate of one method on one cell, against the batch optimum."""

    chi2: float | None = None  # on the edges the method keeps
    chi2_batch_edges: float | None = None  # on the edges the batch optimum keeps
    gap: float | None = None  # (chi2_batch_edges - batch chi2) / batch chi2
    ate: float | None = None  # translation ATE against the batch optimum, m
    precision: float | None = None
    recall: float | None = None
    rejected: int | None = None
    error: str = ""


@dataclass
class Batch:
    """The batch optimum of a cell: pgem optimize on the whole file."""

    options: tuple[str, ...]
    summary: dict[str, Any] = field(default_factory=dict)
    result: Path | None = None
    weights: Path | None = None
    kept: list[bool] = field(default_factory=list)
    chi2: float | None = None  # by chi2_on, on its kept edges
    scores: Scores = field(default_factory=Scores)
    error: str = ""


def solve_batch(args: argparse.Namespace, cell: Cell) -> Batch:
    """`pgem optimize` (`--robust em` with false loops) on the whole file, and its scores."""
    batch = Batch(("--robust", "em") if cell.robust else ())
    try:
        outdir = args.work / "batch" / cell.slug
        batch.summary = bench_robust.pgem_optimize(args.pgem, cell.stream_input, batch.options, outdir)
        batch.result, batch.weights = outdir / bench_robust.RESULT_FILE, outdir / bench_robust.WEIGHTS_FILE
        batch.kept = kept_edges(bench_real.edge_pairs(cell.stream_input), batch.weights, 0.0)
        batch.chi2 = chi2_on(args, cell, batch.result, batch.kept, "batch")
        batch.scores = Scores(batch.chi2, batch.chi2, 0.0, 0.0)
        if cell.robust:
            found = bench_real.pgem_eval(args.pgem, batch.result, batch.result, cell.outliers, batch.weights, 0.0)
            batch.scores.precision, batch.scores.recall = found.get("precision"), found.get("recall")
            batch.scores.rejected = found.get("rejected")
    except (bench_robust.RunFailure, OSError, KeyError, ValueError) as error:
        batch.error = f"batch optimum: {error}"
    return batch


def score(args: argparse.Namespace, cell: Cell, batch: Batch, method: Method, record: Run) -> Scores:
    """chi2 on its own and on the batch's kept edges, ATE and rejection against the batch optimum."""
    found = Scores()
    try:
        pairs = bench_real.edge_pairs(cell.stream_input)
        own = kept_edges(pairs, Path(record.weights), method.reject_below)
        found.chi2 = chi2_on(args, cell, Path(record.result), own, method.name)
        found.chi2_batch_edges = found.chi2 if own == batch.kept else chi2_on(args, cell, Path(record.result),
                                                                              batch.kept, f"{method.name}-batch")
        if batch.chi2 and not record.stopped:  # a stopped run's estimate has fewer poses
            found.gap = (found.chi2_batch_edges - batch.chi2) / batch.chi2
        scores = bench_real.pgem_eval(args.pgem, record.result, batch.result,
                                      cell.outliers if cell.robust else None, Path(record.weights),
                                      method.reject_below)
        found.ate = scores.get("ate_translation_rmse")
        found.precision, found.recall, found.rejected = (scores.get(k) for k in ("precision", "recall", "rejected"))
    except (bench_robust.RunFailure, OSError, KeyError, ValueError) as error:
        found.error = f"scoring: {error}"
    return found


# --------------------------------------------------------------------------------------
# Results of the whole run
# --------------------------------------------------------------------------------------


@dataclass
class Row:
    """One table row: a method on a cell (iSAM2 twice: update() alone and with the estimate)."""

    method: Method
    label: str
    runs: list[Run]
    latency: Latency | None = None
    spread: float | None = None
    scores: Scores | None = None

    @property
    def last(self) -> Run:
        return self.runs[-1]


@dataclass
class CellResult:
    cell: Cell
    batch: Batch | None = None
    runs: dict[str, list[Run]] = field(default_factory=dict)  # by method name
    rows: list[Row] = field(default_factory=list)
    stream_check: str = ""

    def row(self, name: str, with_estimate: bool = False) -> Row | None:
        for row in self.rows:
            if row.method.name == name and row.label.endswith("+ estimate") == with_estimate:
                return row
        return None


def build_rows(args: argparse.Namespace, res: CellResult, methods: Sequence[Method]) -> None:
    """Latency per run, combined; scores of the last good run of each method."""
    for method in methods:
        runs = res.runs.get(method.name, [])
        if not runs:
            continue
        variants = [(method.label, False)] + ([(f"{method.label} + estimate", True)] if not method.is_pgem else [])
        good = [r for r in runs if r.ok]
        scores = score(args, res.cell, res.batch, method, good[-1]) if good and res.batch and not res.batch.error \
            else None
        for label, with_estimate in variants:
            row = Row(method, label, runs, scores=scores)
            stats = [latency(r.updates, res.cell.poses, with_estimate) for r in good]
            if stats and all(s is not None for s in stats):
                row.latency, row.spread = combined(stats)
            res.rows.append(row)


def check_stream(res: CellResult) -> str:
    """Whether pgem and iSAM2 were fed the same stream: at every pose pgem updated after, the same
    poses and edges in the graph."""
    pgem, peer = res.runs.get("pgem-full"), res.runs.get("isam2") or res.runs.get("isam2-cauchy")
    if not pgem or not peer or not pgem[0].updates or not peer[0].updates:
        return "not checked (pgem-full or iSAM2 not run)"
    seen = {int(u["id"]): (int(u["poses"]), int(u["edges"])) for u in peer[0].updates}
    for update in pgem[0].updates:
        key = int(update["id"])
        if key not in seen:
            if peer[0].stopped:
                break
            return f"DIFFERENT: iSAM2 made no update after pose {key}"
        if seen[key] != (int(update["poses"]), int(update["edges"])):
            return (f"DIFFERENT after pose {key}: pgem {update['poses']} poses / {update['edges']} edges, "
                    f"iSAM2 {seen[key][0]} / {seen[key][1]}")
    return (f"same ({len(pgem[0].updates)} pgem updates checked against {len(peer[0].updates)} iSAM2 updates: "
            "the same poses and edges at each)")


# --------------------------------------------------------------------------------------
# Targets (issue 20)
# --------------------------------------------------------------------------------------

Verdict = bench_real.Verdict


def subject(results: Sequence[CellResult]) -> str | None:
    """The pgem method the targets judge: the incremental update once it runs, else the full
    re-solve."""
    for name in ONLINE_SUBJECTS:
        if any((row := res.row(name)) is not None and row.latency is not None for res in results):
            return name
    return None


def find(results: Sequence[CellResult], cell: str) -> CellResult | None:
    return next((res for res in results if res.cell.name == cell), None)


def partial_note(row: Row) -> str:
    last = row.last
    if last.stopped:
        return f" (stopped after {last.summary.get('poses')} of {last.summary.get('poses_total')} poses)"
    return ""


def target_latency(results: Sequence[CellResult], name: str, cell: str, field_name: str) -> Verdict:
    """pgem's per-update median (p99) at most iSAM2's update() on a clean cell."""
    res = find(results, cell)
    mine, peer = (res.row(name), res.row("isam2")) if res is not None else (None, None)
    if mine is None or mine.latency is None:
        return Verdict("not measured", f"{cell}: {name} not run")
    if peer is None or peer.latency is None:
        return Verdict("not measured", f"{cell}: iSAM2 not run")
    a, b = getattr(mine.latency, field_name), getattr(peer.latency, field_name)
    detail = f"{cell}: {ms(a)} vs iSAM2 {ms(b)} ({a / b:.3g}x){partial_note(mine)}"
    # a run stopped early has seen only the smaller graphs: its figures bound the whole run's
    # from below when an update's cost grows with the graph
    if mine.latency.complete and peer.latency.complete:
        return Verdict("met" if a <= b else "missed", detail)
    if not mine.latency.complete and a > b:
        return Verdict("missed", detail)
    if not peer.latency.complete and mine.latency.complete and a <= b:
        return Verdict("met", detail + " (iSAM2 stopped early)")
    return Verdict("not measured", detail + " (a run stopped early)")


def target_last(results: Sequence[CellResult], name: str) -> Verdict:
    res = find(results, TARGET_LAST_CELL)
    row = res.row(name) if res is not None else None
    if row is None or row.latency is None:
        return Verdict("not measured", f"{TARGET_LAST_CELL}: {name} not run")
    value = row.latency.last_poses
    if value is None:
        return Verdict("missed", f"{TARGET_LAST_CELL}: the last {LAST_POSES} poses not reached{partial_note(row)}")
    return Verdict("met" if value < TARGET_LAST_SECONDS else "missed", f"{TARGET_LAST_CELL}: {ms(value)}")


def target_gap(res: CellResult, name: str) -> Verdict:
    row = res.row(name)
    if row is None or row.scores is None or row.scores.gap is None:
        return Verdict("not measured", f"{res.cell.name}: no final estimate")
    gap = row.scores.gap
    met = abs(gap) <= TARGET_GAP and not row.last.stopped
    return Verdict("met" if met else "missed", f"{res.cell.name}: {gap:+.3g}{partial_note(row)}")


def target_pr(res: CellResult, name: str) -> Verdict:
    row = res.row(name)
    if row is None or row.scores is None or res.batch is None:
        return Verdict("not measured", f"{res.cell.name}: no final estimate")
    mine, batch = row.scores, res.batch.scores
    same = (mine.precision, mine.recall) == (batch.precision, batch.recall) and not row.last.stopped
    return Verdict("met" if same else "missed",
                   f"{res.cell.name}: P {bench_robust.format_ratio(mine.precision)} R {bench_robust.format_ratio(mine.recall)} vs batch "
                   f"P {bench_robust.format_ratio(batch.precision)} R {bench_robust.format_ratio(batch.recall)}{partial_note(row)}")


def target_lcm(lcm: dict[str, Any] | None) -> Verdict:
    if lcm is None:
        return Verdict("not measured", "run with --with-lcm (root: bench_lcm.py needs a network namespace)")
    if lcm.get("error"):
        return Verdict("not measured", lcm["error"])
    p99 = lcm["p99"] / 1e3
    return Verdict("met" if p99 < TARGET_LCM_P99 else "missed", f"p99 {ms(p99)}, median {ms(lcm['median'] / 1e3)}")


def check_targets(results: Sequence[CellResult], lcm: dict[str, Any] | None) -> list[tuple[str, list[Verdict]]]:
    """Every target of issue 20 with one verdict per cell it applies to."""
    name = subject(results)
    if name is None:
        return []
    ok = [res for res in results if not res.cell.error and res.batch is not None]
    return [
        ("per-update median at most iSAM2's", [target_latency(results, name, c, "median") for c in TARGET_CELLS]),
        ("per-update p99 at most iSAM2's", [target_latency(results, name, c, "p99") for c in TARGET_CELLS]),
        (f"last-{LAST_POSES}-pose median under {ms(TARGET_LAST_SECONDS)} on {TARGET_LAST_CELL}",
         [target_last(results, name)]),
        (f"final estimate within {TARGET_GAP:g} relative chi2 of the batch optimum",
         [target_gap(res, name) for res in ok]),
        (f"with {TARGET_PR_COUNT} false loops, the batch EM's precision and recall",
         [target_pr(res, name) for res in ok if res.cell.count == TARGET_PR_COUNT]),
        (f"bridge loop-closure latency p99 under {ms(TARGET_LCM_P99)} (City10000 + 100 false loops)",
         [target_lcm(lcm)]),
    ]


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def ms(seconds: float | None) -> str:
    """A time with three significant digits: milliseconds below 1 s, else seconds."""
    if seconds is None or not math.isfinite(seconds):
        return "-"
    return f"{seconds:.3g} s" if seconds >= 1.0 else f"{seconds * 1e3:.3g} ms"


def chi2_text(value: float | None) -> str:
    return "-" if value is None else f"{value:.6f}" if value < 1e6 else f"{value:.4g}"


def gap_text(value: float | None) -> str:
    return "-" if value is None else "0" if value == 0.0 else f"{value:+.2e}"


def outcome(row: Row) -> str:
    """What the run ended with: stops, failures, pgem's final outcome and pruned loops."""
    last = row.last
    if not last.ok:
        return f"**{last.status}**: {last.error[:100]}"
    s = last.summary
    parts = []
    if last.stopped:
        parts.append(f"**stopped** after {s.get('poses')} of {s.get('poses_total')} poses (time limit "
                     f"{float(s.get('time_limit') or 0):g} s)")
    if row.method.is_pgem:
        parts.append(f"{s.get('outcome')}, {s.get('pruned')} of {s.get('loops')} loops pruned")
        if s.get("failed_updates"):
            parts.append(f"**{s['failed_updates']} updates failed**, {s.get('restarts')} restarts")
        parts.append(f"every {s.get('every')}, block {s.get('block_bytes', 0) / 2**20:.1f} MiB, "
                     f"factor peak {s.get('factor_nonzeros_peak')} / {s.get('fill_budget')}")
    else:
        parts.append(f"{s.get('rejected')} of {s.get('loops')} loops below {row.method.reject_below:g}")
    if last.cached:
        parts.append(f"cached {last.cache_date}")
    return "; ".join(parts)


def latency_cells(row: Row) -> list[str]:
    lat = row.latency
    if lat is None:
        return ["-"] * 7
    total = ms(lat.total) + (f" (±{100 * row.spread / 2:.0f}%)" if row.spread is not None else "")
    return [str(lat.updates), ms(lat.median), ms(lat.p99), f"{ms(lat.maximum)} ({lat.max_pose})",
            ms(lat.last_poses), ms(lat.last_tenth), total]


def score_cells(cell: Cell, scores: Scores | None) -> list[str]:
    if scores is None:
        return ["-"] * 4
    pr = f"{bench_robust.format_ratio(scores.precision)} / {bench_robust.format_ratio(scores.recall)}" if cell.robust else "-"
    return [chi2_text(scores.chi2), gap_text(scores.gap), bench_real.format_ate(scores.ate), pr]


HEADER = ["cell", "method", "updates", "median", "p99", "max (pose)", f"last {LAST_POSES} poses", "last 10 %",
          "total", "final chi2", "gap to batch", "ATE vs batch m", "P / R", "outcome"]


def results_table(results: Sequence[CellResult]) -> list[str]:
    lines = ["| " + " | ".join(HEADER) + " |", "|---|---|" + "--:|" * 11 + "---|"]
    for res in results:
        cell = res.cell
        if cell.error or res.batch is None or res.batch.error:
            why = cell.error or (res.batch.error if res.batch else "not run")
            lines.append(f"| `{cell.name}` | **{why}** |" + " - |" * 12)
            continue
        batch = res.batch
        what = "pgem optimize" + ("".join(f" {o}" for o in batch.options))
        lines.append("| " + " | ".join([f"`{cell.name}`", f"batch: `{what}`", "-", "-", "-", "-", "-", "-",
                                        ms(batch.summary.get("solve_seconds"))] + score_cells(cell, batch.scores)
                                       + [f"{cell.poses} poses; {batch.summary.get('pruned', 0)} pruned"]) + " |")
        for row in res.rows:
            lines.append("| " + " | ".join(["", row.label] + latency_cells(row) + score_cells(cell, row.scores)
                                           + [outcome(row)]) + " |")
    return lines


def targets_lines(targets: Sequence[tuple[str, list[Verdict]]], name: str | None) -> list[str]:
    if name is None:
        return ["Not checked: no pgem method ran."]
    before = "" if name == "pgem-incremental" else "; \"before\" figures: the incremental update did not run"
    lines = [f"Checked for `{name}`{before}.", ""]
    for title, verdicts in targets:
        counted = [v for v in verdicts if v.state in ("met", "missed")]
        met = sum(v.state == "met" for v in counted)
        state = "not measured" if not counted else "**met**" if met == len(counted) else "**missed**"
        lines.append(f"- {title}: {state}" + (f" ({met} of {len(counted)})" if len(counted) > 1 else ""))
        lines += [f"  - {v.state}: {v.detail}" for v in verdicts]
    return lines


def lcm_lines(lcm: dict[str, Any] | None) -> list[str]:
    if lcm is None:
        return ["Not run. `--with-lcm` runs `tools/bench/bench_lcm.py --files city10000:200 --outliers 100 "
                "--phases latency` (root: it needs a network namespace) and reports here each loop closure's "
                "latency, sent by `pgem-lcm-send` to the first `pgem.graph_t` that contains it."]
    if lcm.get("error"):
        return [f"Failed: {lcm['error']}"]
    return [f"`{lcm['file']}` with {lcm['outliers']} random false loops streamed at {lcm['rate']:g} edges/s to "
            f"`pgem-lcm-bridge` (its debounce and rate limit: it batches), every loop closure's send to the first "
            "published graph containing it:", "",
            "| loops seen / sent | median | p90 | p99 | max | solves | solve median | solve max |",
            "|--:|--:|--:|--:|--:|--:|--:|--:|",
            f"| {lcm['loops']} / {lcm['sent']} | {lcm['median']:.1f} ms | {lcm['p90']:.1f} ms | {lcm['p99']:.1f} ms | "
            f"{lcm['max']:.1f} ms | {lcm['solves']} | {lcm['solve_median']:.1f} ms | {lcm['solve_max']:.1f} ms |"]


def definitions(args: argparse.Namespace) -> list[str]:
    return [
        "- **Stream**: the poses in file order (KITTI: by id, the guess composed along the odometry), each "
        "followed by every edge whose later pose it is, in file order; after each pose's edges one update (pgem: "
        "once per `--every` poses, the cell's value in the outcome column). A new pose joined by odometry to a "
        "solved pose is placed by that measurement from it, on both sides (what the LCM bridge does).",
        "- **pgem full re-solve (bridge)**: `pgem-online-driver --mode full`, what `bridge_graph_solve` runs on "
        "every solve: `pgem_robust_optimize` with EM's defaults on the whole graph, warm-started from the previous "
        "estimate and loop states; the core re-analyses when the topology grew; one memory block sized for the "
        "whole file before the stream (the core's default fill budget, as the bridge). **pgem incremental**: "
        "`--mode incremental`, the library's update call (`pgem_update` after every pose, new loop closures "
        "through its gate; at the end of the stream, timed apart, `pgem_update_settle` with EM).",
        f"- **iSAM2**: GTSAM's `ISAM2` with `ISAM2Params()` defaults ({', '.join(f'{k} {v}' for k, v in isam2_worker.PARAMETERS.items())}), "
        "`update()` once per pose, every edge a Gaussian `BetweenFactor` (iSAM2 has no robust layer by default), "
        "the gauge a prior of sigma 1e-6 on the first pose. **iSAM2 + Cauchy**: the loop closures with "
        f"`noiseModel.Robust` and `mEstimator.Cauchy({isam2_worker.gtsam_worker.KERNEL_SCALE:g})`. "
        "**+ estimate**: each update's `update()` plus a `calculateEstimate()` of the whole estimate (pgem's "
        "estimate is always whole after an update).",
        "- **Latency**: wall time of the library call alone (pgem: `pgem_robust_optimize`, monotonic clock in the "
        "driver; iSAM2: `update()`, `time.perf_counter`), not building the factors. median, p99 (nearest rank), "
        "max (after which pose), the median over the updates of the last "
        f"{LAST_POSES} poses and of the last 10 % of the poses (`-` when the run stopped earlier), total. With "
        "`--runs` above 1: the median of each statistic over the runs, and half the spread of the runs' medians.",
        "- **final chi2**: g2o's convention, computed for every method by pgem itself (the initial chi2 of "
        "`pgem optimize` on the estimate's poses) over the edges the method keeps: odometry and the loop "
        "closures not pruned (pgem) or weighted at least 0.01 (iSAM2 + Cauchy; plain iSAM2 keeps every loop). "
        "**gap to batch**: (chi2 of the estimate over the edges the batch optimum keeps - the batch optimum's) / "
        "the batch optimum's. **batch**: `pgem optimize` on the whole file, `--robust em` when it has false loops.",
        "- **ATE vs batch**: `pgem eval`'s translation RMSE against the batch optimum after a rigid alignment. "
        "**P / R**: `pgem eval --outliers --weights` precision and recall of the rejected loops (pgem: pruned; "
        "iSAM2: weight below 0.01), truncated to three decimals.",
        f"- Each run streams at most `--timeout` ({args.timeout:g} s) and then stops cleanly (the outcome says "
        "so: its figures are partial); iSAM2 runs are cached by input, parameters, GTSAM version and worker code.",
    ]


def failure_lines(results: Sequence[CellResult]) -> list[str]:
    lines = []
    for res in results:
        if res.cell.error:
            lines.append(f"- `{res.cell.name}`: {res.cell.error}")
        if res.batch is not None and res.batch.error:
            lines.append(f"- `{res.cell.name}`: {res.batch.error}")
        for row in res.rows:
            if row.scores is not None and row.scores.error:
                lines.append(f"- `{res.cell.name}` {row.method.name}: {row.scores.error}")
        for runs in res.runs.values():
            lines += [f"- `{res.cell.name}` {r.method} run {r.run}: {r.status}: {r.error}" for r in runs
                      if r.status in ("failed", "timeout")]
    return sorted(set(lines), key=lines.index) or ["None."]


def render(args: argparse.Namespace, header: str, results: Sequence[CellResult],
           targets: Sequence[tuple[str, list[Verdict]]], lcm: dict[str, Any] | None, notes: Sequence[str],
           wall: float, cache: bench_real.Cache, unavailable: dict[str, str]) -> str:
    name = subject(results)
    lines = ["# pgem online benchmark: per-update latency against iSAM2", "", header, "",
             f"Cells: {', '.join(f'`{r.cell.name}`' for r in results)}. Timeout {args.timeout:g} s per run, "
             f"{args.runs} run(s) per method. Peer cache: {cache.hits} run(s) reused, {cache.misses} computed"
             + ("" if cache.enabled else " (--no-cache)") + ".",
             "", "## Results", ""]
    lines += [f"`{method}` is not in the table: {why.split(': ', 2)[-1]}." for method, why in unavailable.items()]
    lines += [""] * bool(unavailable) + results_table(results)
    lines += ["", "## Targets (issue 20)", ""] + targets_lines(targets, name)
    lines += ["", "## Bridge loop-closure latency", ""] + lcm_lines(lcm)
    lines += ["", "## Same stream and initial guess", ""]
    lines += [f"- `{r.cell.name}`: stream {r.stream_check}; guess {r.cell.guess_check}" for r in results
              if not r.cell.error]
    lines += ["", "## Definitions", ""] + definitions(args)
    lines += ["", "## Failures and timeouts", ""] + failure_lines(results)
    if notes:
        lines += ["", "## Notes", ""] + [f"- {note}" for note in notes]
    lines += ["", f"Wall time: {bench_robust.format_duration(wall)}."]
    return "\n".join(lines) + "\n"


def raw_results(args: argparse.Namespace, header: str, results: Sequence[CellResult],
                targets: Sequence[tuple[str, list[Verdict]]], lcm: dict[str, Any] | None, wall: float,
                unavailable: dict[str, str]) -> dict:
    cells = []
    for res in results:
        rows = [{"method": row.method.name, "label": row.label,
                 "latency": dataclasses.asdict(row.latency) if row.latency else None, "spread": row.spread,
                 "scores": dataclasses.asdict(row.scores) if row.scores else None,
                 "runs": [{"run": r.run, "status": r.status, "error": r.error, "summary": r.summary,
                           "cached": r.cached, "load": list(r.load), "result": r.result} for r in row.runs]}
                for row in res.rows]
        batch = res.batch
        cells.append({"cell": res.cell.name, "poses": res.cell.poses, "every": res.cell.every,
                      "error": res.cell.error, "stream_check": res.stream_check, "guess_check": res.cell.guess_check,
                      "batch": None if batch is None else {"options": list(batch.options), "summary": batch.summary,
                                                           "chi2": batch.chi2, "error": batch.error,
                                                           "scores": dataclasses.asdict(batch.scores)},
                      "rows": rows})
    options = {key: (str(value) if isinstance(value, Path) else value) for key, value in vars(args).items()}
    return {"header": header, "options": options, "cells": cells, "lcm": lcm, "wall_seconds": wall,
            "unavailable": unavailable,
            "targets": [{"target": title, "verdicts": [dataclasses.asdict(v) for v in verdicts]}
                        for title, verdicts in targets]}


# --------------------------------------------------------------------------------------
# The bridge's loop-closure latency (bench_lcm.py, optional)
# --------------------------------------------------------------------------------------


def run_lcm(args: argparse.Namespace) -> dict[str, Any]:
    """bench_lcm.py's latency phase on City10000 with 100 random false loops; its figures."""
    folder = args.work / "lcm"
    folder.mkdir(parents=True, exist_ok=True)
    raw = folder / "bench_lcm.json"
    raw.unlink(missing_ok=True)
    command = [sys.executable, bench_lcm.__file__, "--files", f"{LCM_FILE}:{args.lcm_rate:g}", "--outliers", "100",
               "--phases", "latency", "--json", str(raw), "--out", str(folder / "bench_lcm.md"),
               "--build", str(args.pgem.parents[2]), "--datasets", str(args.datasets)]
    bench_gn.progress(f"bridge latency: {' '.join(command[1:])}")
    try:
        proc = subprocess.run(command, capture_output=True, text=True, timeout=args.timeout + 600.0)
    except subprocess.TimeoutExpired:
        return {"error": f"bench_lcm.py killed after {args.timeout + 600.0:g} s"}
    if proc.returncode != 0 or not raw.is_file():
        return {"error": f"bench_lcm.py (exit {proc.returncode}): {bench_robust.first_line(proc.stderr)}"}
    found = json.loads(raw.read_text(encoding="utf-8"))[0]
    found["latency"].update({"file": LCM_FILE, "outliers": 100})
    return found["latency"]


# --------------------------------------------------------------------------------------
# The benchmark
# --------------------------------------------------------------------------------------


def plan(args: argparse.Namespace, cells: Sequence[Cell], methods: Sequence[Method], cache: bench_real.Cache,
         gtsam_version: str) -> tuple[dict[str, CellResult], list[tuple[Cell, Method, int]]]:
    """Cached iSAM2 runs filed under their cells; the runs still to make, cell by cell, methods
    interleaved within each repeat."""
    code = peer_code() if args.peer == "gtsam" else ""
    results = {cell.name: CellResult(cell) for cell in cells}
    todo = []
    for cell in cells:
        if cell.error:
            continue
        for run in range(1, args.runs + 1):
            for method in methods:
                found = None if method.is_pgem else cached_run(cache, peer_job(cell, method, run, gtsam_version,
                                                                               code), run, args.timeout)
                if found is not None:
                    cache.hits += 1
                    results[cell.name].runs.setdefault(method.name, []).append(found)
                else:
                    cache.misses += not method.is_pgem
                    todo.append((cell, method, run))
    return results, todo


def execute(args: argparse.Namespace, results: dict[str, CellResult], todo: Sequence[tuple[Cell, Method, int]],
            cache: bench_real.Cache, gtsam_version: str) -> dict[str, str]:
    """Every run not cached, one process at a time; iSAM2's stored in the cache. Returns the
    methods this build lacks, with the driver's message (tried once)."""
    code = peer_code() if args.peer == "gtsam" else ""
    eta = bench.Eta([f"{cell.name}:{method.name}" for cell, method, _ in todo])
    unavailable: dict[str, str] = {}
    for cell, method, run in todo:
        key = f"{cell.name}:{method.name}"
        if method.name in unavailable:
            eta.skip([key])
            continue
        start = time.perf_counter()
        outdir = args.work / "runs" / cell.slug / method.name / f"run{run}"
        record = run_stream(args, cell, method, run, outdir, eta)
        if record.status == "unavailable":
            unavailable[method.name] = record.error  # the same build: the same answer for every cell
            bench_gn.progress(f"{method.name}: {record.error}")
            continue
        if not method.is_pgem:  # failures too: the same input fails the same way
            record = store_run(cache, peer_job(cell, method, run, gtsam_version, code), record, outdir)
        results[cell.name].runs.setdefault(method.name, []).append(record)
        spent = time.perf_counter() - start
        done = eta.step(key, spent)
        bench_gn.progress(f"[{cell.name}] {method.name} run {run}: {run_line(record)} ({done})")
    return unavailable


def run_line(record: Run) -> str:
    if not record.ok:
        return f"{record.status.upper()}: {record.error}"
    lat = latency(record.updates, max((int(u["pose"]) for u in record.updates), default=0) + 1)
    if lat is None:
        return "no updates"
    text = f"{lat.updates} updates, median {ms(lat.median)}, p99 {ms(lat.p99)}, total {ms(lat.total)}"
    return text + (" (stopped by the time limit)" if record.stopped else "")


def build_cells(args: argparse.Namespace, notes: list[str]) -> list[Cell]:
    """The selected cells whose files exist, each with its --every."""
    found = []
    for cell in bench_real.select(all_cells(args), args.cells):
        missing = [str(p) for p in (cell.source, cell.labels) if p is not None and not p.is_file()]
        if missing:
            notes.append(f"`{cell.name}`: skipped, {', '.join(missing)} not found.")
            continue
        cell.every = every_for(cell.name, args.every_rules, args.every_default)
        found.append(cell)
    if not found:
        raise bench_gn.BenchError(f"no cell selected or found under {args.datasets} (--cells {','.join(args.cells) or '*'})"
                         + (f"; {notes[0]}" if notes else ""))
    return found


def check_tools(args: argparse.Namespace) -> None:
    bench_robust.check_pgem(args.pgem)
    if not args.driver.is_file():
        raise bench_gn.BenchError(f"pgem-online-driver not found at {args.driver}: build it with `cmake --build --preset "
                         "release` (target pgem_online_driver) or pass --driver")
    bench.check_peer(args)


def run_benchmark(args: argparse.Namespace) -> int:
    check_tools(args)
    start, notes = time.perf_counter(), []
    fingerprint = bench_gn.binary_fingerprint(args.pgem)
    gtsam_version = bench_gn.gtsam_version() if args.peer == "gtsam" else ""
    methods = bench_real.chosen_methods([m for m in METHODS if m.is_pgem or args.peer == "gtsam"], args.methods)
    cells = build_cells(args, notes)
    header = bench_gn.machine_line(args.pgem, f"driver sha256 {bench_gn.binary_fingerprint(args.driver)}",
                                   gtsam=args.peer == "gtsam") + f"; load average {bench.load_average()} at the start"
    bench_gn.progress(header)
    bench_gn.progress(f"{len(cells)} cell(s), methods {', '.join(m.name for m in methods)}; work folder {args.work}")
    for cell in cells:
        prepare(args, cell, fingerprint)
    cache = bench_real.Cache(args.work / "cache", not args.no_cache, args.timeout)
    results, todo = plan(args, cells, methods, cache, gtsam_version)
    for res in results.values():
        if not res.cell.error:
            bench_gn.progress(f"[{res.cell.name}] batch optimum ...")
            res.batch = solve_batch(args, res.cell)
    bench_gn.progress(f"{len(todo)} run(s) to make, {cache.hits} iSAM2 run(s) from the cache")
    unavailable = execute(args, results, todo, cache, gtsam_version)
    ordered = [results[cell.name] for cell in cells]
    bench_gn.progress("scoring ...")
    for res in ordered:
        if not res.cell.error:
            build_rows(args, res, methods)
            res.stream_check = check_stream(res)
    lcm = run_lcm(args) if args.with_lcm else None
    targets = check_targets(ordered, lcm)
    rebuilt = bench_gn.rebuilt_note(args.pgem, fingerprint, "the results")
    if rebuilt:
        notes.append(rebuilt)
    header += f", {bench.load_average()} at the end"
    wall = time.perf_counter() - start
    report = render(args, header, ordered, targets, lcm, notes, wall, cache, unavailable)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report, encoding="utf-8")
    print(report)
    raw = args.out.with_suffix(".json")
    raw.write_text(json.dumps(raw_results(args, header, ordered, targets, lcm, wall, unavailable), indent=1) + "\n",
                   encoding="utf-8")
    for line in targets_lines(targets, subject(ordered)):
        bench_gn.progress(line)
    bench_gn.progress(f"report written to {args.out}, raw results to {raw.name} ({bench_robust.format_duration(wall)})")
    return 0


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def parse_every(text: str) -> tuple[str, int]:
    """--every N (every cell) or PATTERN=N."""
    pattern, sep, value = text.rpartition("=")
    try:
        every = int(value)
    except ValueError:
        every = 0
    if every < 1:
        raise argparse.ArgumentTypeError(f"--every '{text}': expected N or PATTERN=N with N at least 1")
    return (pattern if sep else "*"), every


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--datasets", type=Path, default=bench_gn.DEFAULT_DATASETS,
                        help="datasets folder holding 2d/ and real/ (default ../shared/datasets beside the repository)")
    parser.add_argument("--pgem", type=Path, default=bench_gn.DEFAULT_PGEM,
                        help="pgem binary (default build/release/tools/pgem/pgem)")
    parser.add_argument("--driver", type=Path, help="pgem-online-driver (default: beside pgem, ../bench/)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="Markdown report; the raw results go beside it as .json (default build/bench/bench_online.md)")
    parser.add_argument("--work", type=Path, default=DEFAULT_WORK,
                        help="inputs, runs and the iSAM2 cache (default build/bench/bench_online_work)")
    parser.add_argument("--cells", help="comma-separated patterns over cell names (shell globs or regular "
                                        "expressions), e.g. 'M3500/*' or City10000/clean (default every cell)")
    parser.add_argument("--methods", help="comma-separated shell globs over pgem-full, pgem-incremental, isam2, "
                                          "isam2-cauchy (default all)")
    parser.add_argument("--counts", help=f"false loops of the corrupted cells (default {','.join(map(str, COUNTS))})")
    parser.add_argument("--policy", default="random", choices=bench_robust.POLICIES,
                        help="pgem corrupt's policy (default random)")
    parser.add_argument("--seed", type=int, default=1, help="pgem corrupt's seed (default 1)")
    parser.add_argument("--kitti", help=f"KITTI files under real/kitti (default {','.join(KITTI)}; 'none': no KITTI cell)")
    parser.add_argument("--every", action="append", type=parse_every, metavar="[PATTERN=]N",
                        help="pgem updates once per N poses (default 1; --quick: 100), for every cell or the cells "
                             "PATTERN matches; repeatable, the last match wins")
    parser.add_argument("--runs", type=int, default=1, help="runs of each method per cell, interleaved (default 1)")
    parser.add_argument("--peer", choices=("gtsam", "none"), default="gtsam",
                        help="iSAM2 (gtsam) or pgem alone (none: no gtsam or numpy needed)")
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT,
                        help="seconds a run may stream; then it stops and its figures are partial (default 3600)")
    parser.add_argument("--no-cache", action="store_true", help="re-run iSAM2")
    parser.add_argument("--with-lcm", action="store_true",
                        help="also run bench_lcm.py's loop-closure latency on City10000 + 100 false loops (root)")
    parser.add_argument("--lcm-rate", type=float, default=LCM_RATE, help="its edges per second (default 200)")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke run: cells {', '.join(QUICK_CELLS)}; pgem updates every {QUICK_EVERY} poses")
    args = parser.parse_args(argv)
    split = bench_robust.split_list
    args.cells = split(args.cells, QUICK_CELLS if args.quick else ())
    args.methods = split(args.methods, ())
    try:
        args.counts = split(args.counts, COUNTS, int)
    except ValueError:
        parser.error("--counts takes comma-separated integers")
    args.kitti = [] if args.kitti == "none" else split(args.kitti, QUICK_KITTI if args.quick else KITTI)
    args.every_default = QUICK_EVERY if args.quick else 1
    args.every_rules = args.every or []
    del args.every
    if args.timeout <= 0 or args.runs < 1 or any(c < 1 for c in args.counts):
        parser.error("--timeout, --runs and --counts must be positive")
    resolve_paths(args)
    return args


def resolve_paths(args: argparse.Namespace) -> None:
    """The tools, outputs and datasets as absolute paths; the driver beside the build's tools
    unless --driver names one (bench_online.py and bench_live.py)."""
    args.pgem, args.out, args.work, args.datasets = (p.resolve() for p in (args.pgem, args.out, args.work,
                                                                           args.datasets))
    args.driver = (args.driver or args.pgem.parent.parent / "bench" / "pgem-online-driver").resolve()


def run_main(name: str, parse, run, argv: Sequence[str]) -> int:
    """Parses, runs, and turns a BenchError into a line on stderr and exit code 1."""
    args = parse(argv)
    try:
        return run(args)
    except bench_gn.BenchError as error:
        print(f"{name}: error: {error}", file=sys.stderr)
        return 1


def main(argv: Sequence[str]) -> int:
    return run_main("bench_online", parse_args, run_benchmark, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
