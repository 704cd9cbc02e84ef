#!/usr/bin/env python3
"""Robust benchmark on real false loop closures: pgem EM and its variants against GTSAM.

``python3 tools/bench/bench_real.py`` solves, from the same initial guess for every method:

* every real graph with labelled loop closures under ``DATASETS/real``: the KITTI files
  ``kitti_XX_alpha_A.g2o`` (DLoopDetector's loop closures; ``_GT_LC.txt`` lists the true ones,
  every other loop closure is false) and Vertigo's ``ring`` (26 true loops, no false one);
* synthetic cells: ``ring``, ``input_M3500_g2o``, ``intel`` and ``sphere2500`` corrupted by
  ``pgem corrupt`` under each policy, count and seed (labels: the ``.outliers`` file).

with ``pgem optimize --robust em`` (and variants given on the command line), GTSAM's GNC-TLS,
Cauchy and DCS, and an oracle (pgem Gauss-Newton with the odometry and the true loops only,
cross-checked with GTSAM's Gauss-Newton). Every result is scored by ``pgem eval``: loops
rejected (true and false), precision, recall and F1 of the rejection, ATE against the ground
truth (or the clean optimum where there is none) and against the oracle. The report says which
method is best per cell and checks the targets of pgem's default EM.

The GTSAM and oracle results depend only on their input file and parameters: they are cached in
the work folder under a hash of (input bytes, method, parameters, GTSAM version, worker code),
so a re-run after a change to pgem re-runs pgem alone. ``--no-cache`` re-runs everything.
"""

from __future__ import annotations

import argparse
import ast
import concurrent.futures
import dataclasses
import fnmatch
import hashlib
import json
import math
import os
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402  (time-to-go estimate, peer check)
import bench_gn  # noqa: E402  (machine header, binary fingerprint, pgem checks)
import bench_robust  # noqa: E402  (commands, corruption, formats)
import gtsam_worker  # noqa: E402  (the GTSAM solves, each in its own process)

BenchError = bench_gn.BenchError
RunFailure = bench_robust.RunFailure
progress = bench_gn.progress
format_ratio = bench_robust.format_ratio
format_seconds = bench_robust.format_seconds
format_duration = bench_robust.format_duration

REPO_ROOT = bench_gn.REPO_ROOT
DEFAULT_OUT = REPO_ROOT / "build" / "bench" / "bench_real.md"
DEFAULT_WORK = REPO_ROOT / "build" / "bench" / "bench_real_work"

SYNTHETIC = {  # short name: (graph under the datasets folder, ground truth or None: the clean optimum)
    "ring": ("real/vertigo/ring.g2o", "real/vertigo/ring_groundTruth.g2o"),
    "M3500": ("2d/input_M3500_g2o.g2o", None),
    "intel": ("2d/intel.g2o", None),
    "sphere2500": ("3d/sphere2500.g2o", None),
}
POLICIES = bench_robust.POLICIES
COUNTS = (100, 1000)
SEEDS = (1,)
QUICK_CELLS = ("real/kitti_09_alpha_1.00", "real/ring", "synth/ring/random/100/s1")

BASELINE = "pgem-em"  # pgem's default EM: the method the targets are checked for
DEFAULT_VARIANTS = (("dormant-off", "--dormant-threshold off"), ("literal", "--literal"))
GTSAM_METHODS = {  # name: (label, reject below this weight)
    "gtsam-gnc": ("GNC-TLS", 0.5),
    "gtsam-cauchy": ("Cauchy", bench_robust.DEFAULT_REJECT_BELOW),
    "gtsam-dcs": ("DCS", bench_robust.DEFAULT_REJECT_BELOW),
}
GNC = "gtsam-gnc"
ORACLE, ORACLE_GTSAM = "oracle", "oracle-gtsam"  # pgem and GTSAM Gauss-Newton on the true loops only
ORACLE_OPTIONS = ("--solver", "gn")
PGEM_PRUNED_ONLY = 0.0  # pgem eval --reject-below for pgem: a loop is rejected when pruned
PGEM_REPEAT_SECONDS = 2.0  # a pgem solve is repeated (up to --pgem-runs) while its runs took less in all

ATE_TIE = 1e-3  # m: ATEs this close are a tie (best method), and the slack of the ATE targets
TARGET_ATE_RATIO = 1.02  # pgem-em's ATE at most 2 % above the best GTSAM method's
TARGET_SPEEDUP = 10.0  # pgem-em at least 10x faster than GNC-TLS
TARGET_PR_COUNT = 100  # synthetic cells with this many false loops: precision = recall = 1

CACHE_FORMAT = 1  # bump when what a cache entry holds changes
OUTCOME_HIDDEN = {"input", "robust", "method", "solve_seconds", "analysis_seconds", "poses", "edges", "unknowns",
                  "loops", "analyses", "factor_nonzeros", "initial_chi2", "block_bytes", "block_bytes_per_pose",
                  "block_bytes_per_edge", "block_bytes_factor", "peak_rss_growth", "peak_reset", "rss_before",
                  "is_3d", "estimate_changed", "gtsam_error"}
OUTCOME_SHORT = {"em_iterations": "em", "gn_iterations": "gn", "final_chi2": "chi2"}
OUTCOME_DEFAULTS = {"status": "PGEM_OK", "usable": True}  # shown only when different


# --------------------------------------------------------------------------------------
# Methods
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Method:
    """One solver of the comparison: a pgem variant or a GTSAM method."""

    name: str  # pgem-em, pgem-<variant>, gtsam-gnc, ...
    label: str  # what the tables show
    options: tuple[str, ...]  # pgem: arguments after `--robust em`; GTSAM: none
    reject_below: float  # pgem eval --reject-below: the rejection rule

    @property
    def is_pgem(self) -> bool:
        return self.name.startswith("pgem-")


def parse_variant(text: str) -> tuple[str, str]:
    """'NAME=OPTIONS' of --variant, checked."""
    name, sep, options = text.partition("=")
    name = name.strip()
    if not sep or not re.fullmatch(r"[A-Za-z0-9_.+-]+", name) or name == "em":
        raise argparse.ArgumentTypeError(f"--variant '{text}': expected NAME=OPTIONS, NAME of letters, digits "
                                         "and ._+- (not 'em', the default)")
    return name, options


def chosen_methods(methods: Sequence[Method], patterns: Sequence[str]) -> list[Method]:
    """The methods named by the patterns (shell globs: 'pgem-em,gtsam-*'); every one without."""
    unknown = [p for p in patterns if not any(fnmatch.fnmatchcase(m.name, p) for m in methods)]
    if unknown:
        raise BenchError(f"no method matches {', '.join(unknown)} (with these options: "
                         f"{', '.join(m.name for m in methods)})")
    return [m for m in methods if not patterns or any(fnmatch.fnmatchcase(m.name, p) for p in patterns)]


def all_methods(variants: Sequence[tuple[str, str]], peer: str) -> list[Method]:
    """pgem-em, one pgem method per variant, then the GTSAM methods (with --peer gtsam)."""
    methods = [Method(BASELINE, BASELINE, (), PGEM_PRUNED_ONLY)]
    methods += [Method(f"pgem-{name}", f"pgem-{name}", tuple(shlex.split(options)), PGEM_PRUNED_ONLY)
                for name, options in variants]
    if peer == "gtsam":
        methods += [Method(name, label, (), reject) for name, (label, reject) in GTSAM_METHODS.items()]
    return methods


# --------------------------------------------------------------------------------------
# Cells: the graphs, their labels, initial guess, truth and oracle input
# --------------------------------------------------------------------------------------


@dataclass
class Cell:
    """One row of the benchmark: a graph with labelled loop closures."""

    name: str  # real/kitti_00_alpha_0.50, synth/M3500/random/100/s1
    kind: str  # real | synthetic
    source: Path  # the dataset file it comes from
    truth_source: Path | None  # ground truth file, or None: the clean optimum (the oracle's solve)
    policy: str = ""
    count: int = 0
    seed: int = 0
    labels: Path | None = None  # KITTI: the _GT_LC.txt list of true loops
    # filled by prepare():
    solve_input: Path | None = None  # what pgem optimize reads
    peer_input: Path | None = None  # the same graph with the initial guess as VERTEX lines (GTSAM)
    outliers: Path | None = None  # the false loops, one 'from to' per line
    oracle_input: Path | None = None  # odometry and true loops only, same initial guess
    truth: Path | None = None  # the poses ATE is measured against
    loops_true: int = 0
    loops_false: int = 0
    guess_check: str = ""  # how the peers' initial guess was checked against pgem's
    error: str = ""  # why the cell could not be prepared

    @property
    def truth_kind(self) -> str:
        return "ground truth" if self.truth_source is not None else "clean optimum"

    @property
    def slug(self) -> Path:
        return Path(*self.name.split("/"))

    @property
    def oracle_label(self) -> str:
        """What the oracle solves, for the cross-check table."""
        if self.kind == "real":
            return f"`{self.name}`: odometry and true loops"
        return f"`{self.source.name}`: the clean graph"


def real_cells(datasets: Path) -> list[Cell]:
    """Every KITTI alpha file with its labels and ground truth, and Vertigo's ring."""
    cells = []
    for graph in sorted((datasets / "real" / "kitti").glob("kitti_*_alpha_*.g2o")):
        sequence = graph.name.split("_alpha_")[0]
        cells.append(Cell(f"real/{graph.stem}", "real", graph, graph.parent / f"{sequence}_GT.g2o",
                          labels=graph.with_name(f"{graph.stem}_GT_LC.txt")))
    ring, ring_truth = (datasets / path for path in SYNTHETIC["ring"])
    if ring.is_file():
        cells.append(Cell("real/ring", "real", ring, ring_truth))
    return cells


def synthetic_cells(datasets: Path, policies: Sequence[str], counts: Sequence[int],
                    seeds: Sequence[int]) -> list[Cell]:
    """Every synthetic dataset x policy x count x seed."""
    cells = []
    for short, (graph, truth) in SYNTHETIC.items():
        for policy in policies:
            for count in counts:
                for seed in seeds:
                    cells.append(Cell(f"synth/{short}/{policy}/{count}/s{seed}", "synthetic", datasets / graph,
                                      datasets / truth if truth else None, policy, count, seed))
    return cells


def select(cells: Sequence[Cell], patterns: Sequence[str]) -> list[Cell]:
    """The cells whose name matches one pattern, as a shell glob (whole name) or a regular
    expression (searched); no patterns: every cell."""
    if not patterns:
        return list(cells)

    def matches(name: str, pattern: str) -> bool:
        if fnmatch.fnmatchcase(name, pattern):
            return True
        try:
            return re.search(pattern, name) is not None
        except re.error:
            return False

    return [cell for cell in cells if any(matches(cell.name, pattern) for pattern in patterns)]


def edge_pairs(path: Path) -> list[tuple[int, int]]:
    """(from, to) of every EDGE line of a g2o file, in file order."""
    pairs = []
    with open(path, encoding="ascii", errors="replace") as handle:
        for line in handle:
            fields = line.split()
            if fields and fields[0].startswith("EDGE"):
                pairs.append((int(fields[1]), int(fields[2])))
    return pairs


def is_loop(pair: tuple[int, int]) -> bool:
    """The odometry rule of pgem's reader: an edge between consecutive ids is odometry."""
    return abs(pair[0] - pair[1]) != 1


def read_pairs(path: Path) -> list[tuple[int, int]]:
    """'i j' lines ('#' lines and blank lines ignored)."""
    pairs = []
    with open(path, encoding="ascii", errors="replace") as handle:
        for number, line in enumerate(handle, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            if len(fields) < 2:
                raise RunFailure(f"{path}:{number}: expected 'from to'")
            pairs.append((int(fields[0]), int(fields[1])))
    return pairs


def split_loops(graph: Path, true_pairs: Sequence[tuple[int, int]]) -> tuple[list[bool], int, int]:
    """For every edge of graph: kept in the oracle (odometry or a true loop); and the true and
    false loop counts. The true pairs are matched as a multiset, in file order."""
    remaining: dict[tuple[int, int], int] = {}
    for pair in true_pairs:
        remaining[pair] = remaining.get(pair, 0) + 1
    keep, true_count, false_count = [], 0, 0
    for pair in edge_pairs(graph):
        if not is_loop(pair):
            keep.append(True)
        elif remaining.get(pair, 0) > 0:
            remaining[pair] -= 1
            keep.append(True)
            true_count += 1
        else:
            keep.append(False)
            false_count += 1
    unmatched = [pair for pair, n in remaining.items() if n > 0]
    if unmatched:
        raise RunFailure(f"{graph}: {len(unmatched)} true loop(s) of the labels are not in the graph, "
                         f"e.g. {unmatched[0][0]} {unmatched[0][1]}")
    return keep, true_count, false_count


def write_filtered(graph: Path, keep: Sequence[bool], out: Path) -> None:
    """graph without the EDGE lines whose keep flag is False (other lines unchanged)."""
    lines, index = [], 0
    with open(graph, encoding="ascii", errors="replace") as handle:
        for line in handle:
            fields = line.split()
            if fields and fields[0].startswith("EDGE"):
                index += 1
                if not keep[index - 1]:
                    continue
            lines.append(line)
    write_atomic(out, "".join(lines))


def write_atomic(path: Path, text: str) -> None:
    """Writes text through a temporary file, so that a killed run leaves no half file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(text, encoding="ascii")
    temporary.replace(path)


def written_guess(pgem: Path, graph: Path, out: Path, rewrite: bool = False) -> Path:
    """The graph with the initial guess pgem starts from as VERTEX lines (`pgem corrupt --count
    0` composes it along the odometry as `pgem optimize` does and writes every number with 17
    digits), cached while newer than the graph unless rewrite."""
    if rewrite or not bench_robust.is_fresh(out, graph):
        out.parent.mkdir(parents=True, exist_ok=True)
        bench_robust.run_command([str(pgem), "corrupt", str(graph), "-o", str(out), "--policy", "random",
                                  "--count", "0", "--seed", "1"], "pgem corrupt --count 0")
    return out


def check_guess(pgem: Path, graph: Path, guess: Path, folder: Path, fingerprint: str) -> str:
    """Checks that pgem starts from the same poses on graph and on its written guess: the same
    initial chi2 and byte-identical Gauss-Newton results. Kept per pgem binary."""
    marker = folder / "guess_check.json"
    if bench_robust.is_fresh(marker, guess):
        saved = json.loads(marker.read_text(encoding="utf-8"))
        if saved.get("pgem") == fingerprint:
            return str(saved["verdict"])
    summaries, outputs = [], []
    for name, path in (("original", graph), ("guess", guess)):
        out = folder / f"check_{name}.g2o"
        text = bench_robust.run_command([str(pgem), "optimize", str(path), *ORACLE_OPTIONS, "--json", "--quiet",
                                         "-o", str(out)], "pgem optimize (initial guess check)")
        summaries.append(bench_robust.parse_json(text, "pgem optimize"))
        outputs.append(out.read_bytes())
        out.unlink()
    same_chi2 = summaries[0].get("initial_chi2") == summaries[1].get("initial_chi2")
    if same_chi2 and outputs[0] == outputs[1]:
        verdict = "bit-identical (same initial chi2, byte-identical Gauss-Newton results)"
    else:
        verdict = (f"DIFFERENT: initial chi2 {summaries[0].get('initial_chi2')} vs "
                   f"{summaries[1].get('initial_chi2')}, Gauss-Newton results "
                   f"{'identical' if outputs[0] == outputs[1] else 'differ'}")
    write_atomic(marker, json.dumps({"pgem": fingerprint, "verdict": verdict}) + "\n")
    return verdict


def prepare_real(pgem: Path, cell: Cell, folder: Path, fingerprint: str) -> None:
    """A real graph: its written initial guess, the false loops, the oracle input and the truth."""
    cell.solve_input = cell.source
    cell.peer_input = written_guess(pgem, cell.source, folder / "guess.g2o")
    cell.guess_check = check_guess(pgem, cell.source, cell.peer_input, folder, fingerprint)
    if cell.guess_check.startswith("DIFFERENT"):  # written by an older pgem? write it again
        written_guess(pgem, cell.source, cell.peer_input, rewrite=True)
        cell.guess_check = check_guess(pgem, cell.source, cell.peer_input, folder, fingerprint)
    true_pairs = read_pairs(cell.labels) if cell.labels is not None else [
        pair for pair in edge_pairs(cell.source) if is_loop(pair)]
    keep, cell.loops_true, cell.loops_false = split_loops(cell.peer_input, true_pairs)
    pairs = edge_pairs(cell.peer_input)
    cell.outliers = folder / "false_loops.txt"
    write_atomic(cell.outliers, "# the false loop closures (from to), file order\n" +
                 "".join(f"{a} {b}\n" for (a, b), kept in zip(pairs, keep) if not kept))
    cell.oracle_input = folder / "oracle_input.g2o"
    write_filtered(cell.peer_input, keep, cell.oracle_input)
    if cell.truth_source is not None and next(vertex_lines(cell.truth_source), None) is None:
        cell.truth = written_guess(pgem, cell.truth_source, folder / "truth.g2o")  # a chain of relative edges
    else:
        cell.truth = cell.truth_source


def vertex_lines(path: Path) -> Iterable[str]:
    """The VERTEX lines of a graph file."""
    with open(path, encoding="ascii", errors="replace") as handle:
        for line in handle:
            if line.startswith("VERTEX"):
                yield line


def prepare_synthetic(pgem: Path, cell: Cell, folder: Path) -> None:
    """A corrupted graph (regenerated when missing or older than its input); the clean graph is
    the oracle input, and the truth when there is no ground truth (its optimum, set later)."""
    corrupted = bench_robust.make_corrupted(pgem, cell.source, folder, cell.policy, cell.count, cell.seed, None)
    cell.solve_input = cell.peer_input = corrupted
    cell.outliers = Path(str(corrupted) + ".outliers")
    cell.guess_check = "same file (the corrupted graph has its VERTEX lines)"
    cell.loops_false = len(read_pairs(cell.outliers))
    cell.loops_true = sum(is_loop(pair) for pair in edge_pairs(cell.source))
    cell.oracle_input = cell.source
    cell.truth = cell.truth_source


def prepare(args: argparse.Namespace, cell: Cell, fingerprint: str) -> None:
    """Fills the cell's inputs; a failure is the cell's error."""
    folder = args.work / "inputs" / cell.slug
    try:
        if cell.kind == "real":
            prepare_real(args.pgem, cell, folder, fingerprint)
        else:
            prepare_synthetic(args.pgem, cell, folder)
    except (RunFailure, OSError, ValueError, KeyError) as error:
        cell.error = f"not prepared: {error}"


# --------------------------------------------------------------------------------------
# Cached solves (GTSAM methods and the oracles)
# --------------------------------------------------------------------------------------


@dataclass
class Solve:
    """One solver's result on one cell."""

    cell: str
    method: str
    status: str = "ok"  # ok | failed | timeout
    error: str = ""
    seconds: float | None = None  # the solve's time (pgem: median over its runs)
    times: list[float] = field(default_factory=list)  # pgem: every run's solve time
    summary: dict[str, Any] = field(default_factory=dict)  # the solver's JSON
    result: str = ""  # the estimate (g2o), the weights file beside it for robust methods
    cached: bool = False
    cache_date: str = ""
    scores: dict[str, Any] = field(default_factory=dict)  # pgem eval against the truth (and the labels)
    oracle_scores: dict[str, Any] = field(default_factory=dict)  # pgem eval against the oracle

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def weights(self) -> Path:
        return Path(self.result).with_name(gtsam_worker.WEIGHTS_FILE)


@dataclass(frozen=True)
class PeerJob:
    """A cacheable solve: a method on an input file, with the parameters its result depends on."""

    cell: str
    method: str  # gtsam-gnc, ..., oracle, oracle-gtsam
    input: Path
    params: tuple[tuple[str, Any], ...]


def sha256_file(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


class Cache:
    """Results of the peers and oracles under work/cache/KEY, KEY a hash of what they depend on."""

    def __init__(self, root: Path, enabled: bool, timeout: float) -> None:
        self.root, self.enabled, self.timeout = root, enabled, timeout
        self.hashes: dict[Path, str] = {}
        self.hits = self.misses = 0

    def key(self, job: PeerJob) -> str:
        if job.input not in self.hashes:
            self.hashes[job.input] = sha256_file(job.input)
        material = {"format": CACHE_FORMAT, "input": self.hashes[job.input], "method": job.method,
                    "params": dict(job.params)}
        return hashlib.sha256(json.dumps(material, sort_keys=True).encode()).hexdigest()

    def folder(self, job: PeerJob) -> Path:
        key = self.key(job)
        return self.root / key[:2] / key

    def lookup(self, job: PeerJob) -> Solve | None:
        """The stored result, unless disabled, absent, or a timeout shorter than asked for now."""
        entry_path = self.folder(job) / "entry.json"
        if not self.enabled or not entry_path.is_file():
            return None
        entry = json.loads(entry_path.read_text(encoding="utf-8"))
        if entry["status"] == "timeout" and float(entry.get("timeout", 0.0)) < self.timeout:
            return None
        solve = Solve(job.cell, job.method, entry["status"], entry.get("error", ""), entry.get("seconds"),
                      summary=entry.get("summary", {}), cached=True, cache_date=entry.get("date", ""))
        if solve.ok:
            solve.result = str(self.folder(job) / gtsam_worker.RESULT_FILE)
        return solve

    def store(self, job: PeerJob, solve: Solve, produced: Path) -> Solve:
        """Moves the produced folder (result files) into the cache with its entry; returns the
        solve pointing at the cached files."""
        folder = self.folder(job)
        entry = {"status": solve.status, "error": solve.error, "seconds": solve.seconds, "summary": solve.summary,
                 "timeout": self.timeout, "date": time.strftime("%Y-%m-%d %H:%M:%S"), "method": job.method,
                 "input": str(job.input), "params": dict(job.params)}
        (produced / "entry.json").write_text(json.dumps(entry, indent=1) + "\n", encoding="utf-8")
        if folder.exists():
            shutil.rmtree(folder)
        folder.parent.mkdir(parents=True, exist_ok=True)
        produced.replace(folder)
        solve.cache_date = entry["date"]
        if solve.ok:
            solve.result = str(folder / gtsam_worker.RESULT_FILE)
        return solve


def peer_params(method: str, gtsam_version: str, code: str) -> tuple[tuple[str, Any], ...]:
    """What a cached result depends on besides its input file."""
    if method == ORACLE:
        return (("solver", "pgem"), ("options", list(ORACLE_OPTIONS)))
    return (("gtsam", gtsam_version), ("code", code), ("kernel_scale", gtsam_worker.KERNEL_SCALE),
            ("lm_max_iterations", gtsam_worker.LM_MAX_ITERATIONS), ("lm_error_tol", gtsam_worker.LM_ERROR_TOL))


def worker_code() -> str:
    """SHA-256 of the GTSAM worker's code (gtsam_worker.py and the bench_gn.py it uses), as
    syntax trees without docstrings: editing a comment or a docstring keeps the cache."""
    digest = hashlib.sha256()
    for module in (gtsam_worker.__file__, bench_gn.__file__):
        tree = ast.parse(Path(module).read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            body = getattr(node, "body", None)
            if (isinstance(body, list) and body and isinstance(body[0], ast.Expr)
                    and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str)):
                node.body = body[1:] or [ast.Pass()]
        digest.update(ast.dump(tree).encode())
    return digest.hexdigest()


def peer_command(args: argparse.Namespace, job: PeerJob, outdir: Path) -> list[str]:
    """The command of one cacheable solve, writing its result into outdir."""
    if job.method == ORACLE:
        return [str(args.pgem), "optimize", str(job.input), *ORACLE_OPTIONS, "--json", "--quiet",
                "-o", str(outdir / gtsam_worker.RESULT_FILE)]
    worker_method = gtsam_worker.GTSAM_GN if job.method == ORACLE_GTSAM else job.method
    return gtsam_worker.command(worker_method, job.input, outdir)


def run_peer(args: argparse.Namespace, cache: Cache, job: PeerJob) -> Solve:
    """Runs one cacheable solve in a fresh process (killed after --timeout) and stores it;
    a failure or a timeout is stored and returned as the solve's status."""
    produced = cache.root / "tmp" / f"{os.getpid()}-{cache.key(job)}"
    if produced.exists():
        shutil.rmtree(produced)
    produced.mkdir(parents=True)
    solve = Solve(job.cell, job.method)
    try:
        text = bench_robust.run_command(peer_command(args, job, produced), job.method, args.timeout)
        solve.summary = bench_robust.parse_json(text, job.method)
        solve.seconds = float(solve.summary["solve_seconds"])
        if job.method == ORACLE and not all(bench_gn.pgem_solve_status(solve.summary)):
            raise RunFailure(f"status {solve.summary.get('status')}, usable {solve.summary.get('usable')}")
    except RunFailure as failure:
        solve.status, solve.error = failure.status, str(failure)
        if failure.status == "timeout":
            solve.summary = {"killed_after": args.timeout}
    except (KeyError, TypeError, ValueError) as error:
        solve.status, solve.error = "failed", f"{type(error).__name__}: {error}"
    return cache.store(job, solve, produced)


def run_parallel(jobs: int, work: Sequence[Any], run: Callable[[Any], Any],
                 done: Callable[[Any, Any, float], None]) -> None:
    """Runs run(item) for every item on up to `jobs` threads (each runs a subprocess); done(item,
    result, seconds) is called in this thread as each finishes."""
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        started = {}
        for item in work:
            started[pool.submit(timed, run, item)] = item
        for future in concurrent.futures.as_completed(started):
            result, seconds = future.result()
            done(started[future], result, seconds)


def timed(run: Callable[[Any], Any], item: Any) -> tuple[Any, float]:
    """(run(item), its wall time)."""
    start = time.perf_counter()
    return run(item), time.perf_counter() - start


# --------------------------------------------------------------------------------------
# pgem's solves (timed alone, never beside another job)
# --------------------------------------------------------------------------------------


def pgem_summary(command: Sequence[str], timeout: float) -> dict[str, Any]:
    """Runs one `pgem optimize --json`; its JSON summary, with the exit status under "exit" when
    it is not 0 but a summary was printed (a solve pgem reports as failed still has an outcome)."""
    try:
        proc = subprocess.run(list(command), capture_output=True, text=True, check=False, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise RunFailure(f"pgem optimize: killed after {timeout:g} s", "timeout") from None
    try:
        summary = json.loads(proc.stdout)
    except json.JSONDecodeError:
        summary = None
    if not isinstance(summary, dict):
        raise RunFailure(f"pgem optimize (exit {proc.returncode}): "
                         f"{bench_robust.first_line(proc.stderr or proc.stdout)}")
    if proc.returncode != 0:
        summary["exit"] = proc.returncode
    return summary


def run_pgem(args: argparse.Namespace, cell: Cell, method: Method) -> Solve:
    """`pgem optimize --robust em OPTIONS --json` up to args.pgem_runs times, stopping once the
    runs took PGEM_REPEAT_SECONDS in all (a long solve is timed once); the time is the median of
    the runs' solve_seconds, the files those of the last run."""
    outdir = args.work / "pgem" / cell.slug / method.name
    outdir.mkdir(parents=True, exist_ok=True)
    result, weights = outdir / gtsam_worker.RESULT_FILE, outdir / gtsam_worker.WEIGHTS_FILE
    command = [str(args.pgem), "optimize", str(cell.solve_input), "--robust", "em", *method.options,
               "--json", "--quiet", "-o", str(result), "--weights", str(weights)]
    solve = Solve(cell.name, method.name)
    try:
        while len(solve.times) < args.pgem_runs and sum(solve.times) < PGEM_REPEAT_SECONDS:
            for stale in (result, weights):
                stale.unlink(missing_ok=True)  # never score a previous run's files
            solve.summary = pgem_summary(command, args.timeout)
            solve.times.append(float(solve.summary["solve_seconds"]))
        if not (result.is_file() and weights.is_file()):
            raise RunFailure(f"pgem optimize wrote no result or no weights ({outcome_text(solve.summary)})")
        solve.seconds = statistics.median(solve.times)
        solve.result = str(result)
    except RunFailure as failure:
        solve.status, solve.error = failure.status, str(failure)
    except (KeyError, TypeError, ValueError) as error:
        solve.status, solve.error = "failed", f"{type(error).__name__}: {error}"
    return solve


# --------------------------------------------------------------------------------------
# Scoring (pgem eval)
# --------------------------------------------------------------------------------------


def pgem_eval(pgem: Path, result: str | Path, reference: str | Path, outliers: Path | None = None,
              weights: Path | None = None, reject_below: float | None = None) -> dict[str, Any]:
    """`pgem eval --json`: ATE against reference, and the rejection scores when labels are given."""
    command = [str(pgem), "eval", str(result), "--reference", str(reference), "--json"]
    if outliers is not None and weights is not None:
        command += ["--outliers", str(outliers), "--weights", str(weights), "--reject-below", repr(reject_below)]
    return bench_robust.parse_json(bench_robust.run_command(command, "pgem eval"), "pgem eval")


def f1_score(scores: dict[str, Any]) -> float | None:
    """F1 of the rejection from pgem eval's precision and recall (0 when both are 0)."""
    p, r = scores.get("precision"), scores.get("recall")
    if p is None or r is None:
        return None
    return 0.0 if p + r == 0 else 2.0 * p * r / (p + r)


@dataclass
class CellResult:
    """Everything measured on one cell."""

    cell: Cell
    odometry: dict[str, Any] = field(default_factory=dict)  # the initial guess scored against the truth
    oracle: Solve | None = None
    oracle_gtsam: Solve | None = None
    solves: dict[str, Solve] = field(default_factory=dict)  # by method name
    error: str = ""  # why the truth or the oracle is missing

    def ate(self, method: str) -> float | None:
        solve = self.solves.get(method)
        return solve.scores.get("ate_translation_rmse") if solve is not None and solve.ok else None

    def f1(self, method: str) -> float | None:
        solve = self.solves.get(method)
        return solve.scores.get("f1") if solve is not None and solve.ok else None


def score_solve(args: argparse.Namespace, res: CellResult, method: Method, solve: Solve) -> None:
    """Scores one solve in place: against the truth with the labels, and against the oracle."""
    if not solve.ok:
        return
    cell = res.cell
    try:
        solve.scores = pgem_eval(args.pgem, solve.result, cell.truth, cell.outliers, solve.weights,
                                 method.reject_below)
        solve.scores["f1"] = f1_score(solve.scores)
        if res.oracle is not None and res.oracle.ok:
            solve.oracle_scores = pgem_eval(args.pgem, solve.result, res.oracle.result)
    except RunFailure as failure:
        solve.status, solve.error = "failed", f"scoring: {failure}"


def score_cell(args: argparse.Namespace, res: CellResult, methods: Sequence[Method]) -> None:
    """The truth (the oracle's solve for the clean-optimum cells), the odometry and oracle
    scores, then every method's."""
    cell = res.cell
    if cell.truth is None:
        if res.oracle is None or not res.oracle.ok:
            res.error = "no truth: the clean graph's optimum (oracle) failed"
            return
        cell.truth = Path(res.oracle.result)
    try:
        res.odometry = pgem_eval(args.pgem, cell.peer_input, cell.truth)
        for oracle in (res.oracle, res.oracle_gtsam):
            if oracle is not None and oracle.ok:
                oracle.scores = pgem_eval(args.pgem, oracle.result, cell.truth)
                if oracle is res.oracle_gtsam and res.oracle.ok:
                    oracle.oracle_scores = pgem_eval(args.pgem, oracle.result, res.oracle.result)
    except RunFailure as failure:
        res.error = f"scoring the odometry or the oracle: {failure}"
    for method in methods:
        if method.name in res.solves:
            score_solve(args, res, method, res.solves[method.name])


# --------------------------------------------------------------------------------------
# Best method and targets
# --------------------------------------------------------------------------------------


def best_method(res: CellResult, methods: Sequence[Method]) -> str | None:
    """Lowest ATE against the truth; ATEs within ATE_TIE of the lowest tie, broken by the higher
    F1, then the shorter time."""
    ranked = [(res.ate(m.name), m.name) for m in methods if res.ate(m.name) is not None]
    if not ranked:
        return None
    lowest = min(ate for ate, _ in ranked)
    tied = [name for ate, name in ranked if ate <= lowest + ATE_TIE]
    return min(tied, key=lambda name: (-(res.f1(name) or 0.0), res.solves[name].seconds or math.inf))


@dataclass
class Verdict:
    """One target on one cell."""

    state: str  # met | missed | not measured | n/a
    detail: str = ""


def best_gtsam(res: CellResult, value: Callable[[str], float | None], lowest: bool) -> tuple[float, str] | None:
    """(best value, method) over the GTSAM methods with a result."""
    found = [(value(name), name) for name in GTSAM_METHODS if value(name) is not None]
    if not found:
        return None
    return min(found) if lowest else max(found)


def compare(mine: float | None, reference: float | None, absent: str, holds: Callable[[float, float], bool],
            detail: Callable[[float, float], str]) -> Verdict:
    """A target comparing pgem-em's value with a reference: not measured without the reference
    (absent says why), missed without pgem-em's value."""
    if reference is None:
        return Verdict("not measured", absent)
    if mine is None:
        return Verdict("missed", f"{BASELINE} has no result")
    return Verdict("met" if holds(mine, reference) else "missed", detail(mine, reference))


def target_ate_peers(res: CellResult) -> Verdict:
    best = best_gtsam(res, res.ate, lowest=True)
    return compare(res.ate(BASELINE), best[0] if best else None, "no GTSAM result",
                   lambda ate, peer: ate <= max(peer * TARGET_ATE_RATIO, peer + ATE_TIE),
                   lambda ate, peer: f"{format_ate(ate)} vs {GTSAM_METHODS[best[1]][0]} {format_ate(peer)} m")


def target_ate_odometry(res: CellResult) -> Verdict:
    return compare(res.ate(BASELINE), res.odometry.get("ate_translation_rmse"), "no odometry score",
                   lambda ate, odometry: ate <= odometry + ATE_TIE,
                   lambda ate, odometry: f"{format_ate(ate)} vs odometry {format_ate(odometry)} m")


def target_f1(res: CellResult) -> Verdict:
    best = best_gtsam(res, res.f1, lowest=False)
    return compare(res.f1(BASELINE), best[0] if best else None, "no GTSAM result",
                   lambda f1, peer: f1 >= peer - 1e-12,
                   lambda f1, peer: f"{format_ratio(f1)} vs {GTSAM_METHODS[best[1]][0]} {format_ratio(peer)}")


def target_speed(res: CellResult, timeout: float) -> Verdict:
    """A GNC-TLS timeout counts as the time it was killed after (a lower bound)."""
    base, gnc = res.solves.get(BASELINE), res.solves.get(GNC)
    if gnc is None or gnc.status == "failed" or base is None:
        return Verdict("not measured", "GNC-TLS failed" if gnc is not None else "GNC-TLS not run")
    if not base.ok or not base.seconds:
        return Verdict("missed", f"{BASELINE} has no result")
    if gnc.status == "timeout":
        ratio = float(gnc.summary.get("killed_after", timeout)) / base.seconds
        return Verdict("met" if ratio >= TARGET_SPEEDUP else "missed", f"> {ratio:.3g}x (GNC-TLS timed out)")
    ratio = (gnc.seconds or 0.0) / base.seconds
    return Verdict("met" if ratio >= TARGET_SPEEDUP else "missed", f"{ratio:.3g}x")


def target_pr(res: CellResult) -> Verdict:
    cell = res.cell
    if cell.kind != "synthetic" or cell.count != TARGET_PR_COUNT:
        return Verdict("n/a")
    solve = res.solves.get(BASELINE)
    if solve is None or not solve.ok:
        return Verdict("missed", f"{BASELINE} has no result")
    p, r = solve.scores.get("precision"), solve.scores.get("recall")
    return Verdict("met" if p == 1.0 and r == 1.0 else "missed", f"P {format_ratio(p)}, R {format_ratio(r)}")


TARGETS = (  # (short title, description, check)
    ("ATE vs GTSAM", f"ATE at most {TARGET_ATE_RATIO:g} x the best GTSAM method's (or within "
                     f"{ATE_TIE * 1e3:g} mm of it)", lambda res, args: target_ate_peers(res)),
    ("ATE vs odometry", f"ATE no worse than the initial guess's (within {ATE_TIE * 1e3:g} mm)",
     lambda res, args: target_ate_odometry(res)),
    ("F1", "rejection F1 at least the best GTSAM method's", lambda res, args: target_f1(res)),
    ("speed", f"at least {TARGET_SPEEDUP:g}x faster than GNC-TLS", lambda res, args: target_speed(res, args.timeout)),
    ("P = R = 1", f"precision = recall = 1 on the synthetic cells with {TARGET_PR_COUNT} false loops",
     lambda res, args: target_pr(res)),
)


def check_targets(args: argparse.Namespace, res: CellResult) -> list[Verdict]:
    """Every target for pgem-em on one cell (not measured when pgem-em was not run)."""
    if BASELINE not in res.solves:
        return [Verdict("not measured", f"{BASELINE} not run") for _ in TARGETS]
    return [check(res, args) for _, _, check in TARGETS]


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def format_ate(value: Any) -> str:
    """A length in metres with four significant digits."""
    return "-" if value is None or not math.isfinite(float(value)) else f"{float(value):.4g}"


def format_number(value: Any) -> str:
    """An outcome value: integers as they are, reals with four significant digits."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def outcome_text(summary: dict[str, Any]) -> str:
    """The solver's outcome fields (every key of its JSON but the bookkeeping), compact."""
    parts = []
    for key, value in summary.items():
        if key in OUTCOME_HIDDEN or (key in OUTCOME_DEFAULTS and value == OUTCOME_DEFAULTS[key]):
            continue
        parts.append(f"{OUTCOME_SHORT.get(key, key)} {format_number(value)}")
    return ", ".join(parts)


def solve_row(res: CellResult, method: Method, solve: Solve | None, best: str | None, first: bool) -> str:
    """One method's row of a results table; the cell's columns only on its first row."""
    cell = res.cell
    head = ([f"`{cell.name}`", f"{cell.loops_true} / {cell.loops_false}",
             format_ate(res.odometry.get("ate_translation_rmse"))] if first else ["", "", ""])
    label = f"**{method.label}**" if method.name == best else method.label
    if solve is None:
        return "| " + " | ".join(head + [label, "not run"] + ["-"] * 8) + " |"
    if not solve.ok:
        return "| " + " | ".join(head + [label, f"**{solve.status}**"] + ["-"] * 7 + [solve.error[:80]]) + " |"
    s = solve.scores
    cached = " (cached)" if solve.cached else ""
    return "| " + " | ".join(head + [
        label, str(s.get("false_positives", "-")), str(s.get("false_negatives", "-")),
        format_ratio(s.get("precision")), format_ratio(s.get("recall")), format_ratio(s.get("f1")),
        format_ate(s.get("ate_translation_rmse")), format_ate(solve.oracle_scores.get("ate_translation_rmse")),
        format_seconds(solve.seconds) + cached + over_oracle(solve, res.oracle),
        outcome_text(solve.summary)]) + " |"


def over_oracle(solve: Solve, oracle: Solve | None) -> str:
    """The solve's time as a multiple of the oracle's (Gauss-Newton on the clean graph: the
    odometry and the true loops), what robustness costs over a solve that needs none."""
    if oracle is None or not oracle.ok or not oracle.seconds or solve.seconds is None:
        return ""
    return f" ({solve.seconds / oracle.seconds:.3g}x GN)"


def oracle_row(res: CellResult) -> str:
    """The oracle's row (the first of a cell)."""
    cell, oracle = res.cell, res.oracle
    head = [f"`{cell.name}`", f"{cell.loops_true} / {cell.loops_false}",
            format_ate(res.odometry.get("ate_translation_rmse"))]
    if oracle is None or not oracle.ok:
        status = oracle.status if oracle is not None else "not run"
        return "| " + " | ".join(head + ["oracle", f"**{status}**"] + ["-"] * 8) + " |"
    return "| " + " | ".join(head + ["oracle", "-", "-", "-", "-", "-",
                                     format_ate(oracle.scores.get("ate_translation_rmse")), "0",
                                     format_seconds(oracle.seconds) + (" (cached)" if oracle.cached else ""),
                                     outcome_text(oracle.summary)]) + " |"


RESULT_HEADER = ["cell", "loops true / false", "odometry ATE m", "method", "true rejected", "false kept", "P", "R",
                 "F1", "ATE vs truth m", "ATE vs oracle m", "time", "outcome"]


def results_table(results: Sequence[CellResult], methods: Sequence[Method]) -> list[str]:
    """Rows: per cell, the oracle then every method; the best method in bold."""
    lines = ["| " + " | ".join(RESULT_HEADER) + " |", "|---|--:|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|---|"]
    for res in results:
        if res.cell.error or res.error:
            lines.append(f"| `{res.cell.name}` | - | - | - | **{res.cell.error or res.error}** |" + " - |" * 8)
            continue
        best = best_method(res, methods)
        lines.append(oracle_row(res))
        for method in methods:
            lines.append(solve_row(res, method, res.solves.get(method.name), best, first=False))
    return lines


def verdict_mark(verdict: Verdict) -> str:
    return {"met": "yes", "missed": "**NO**", "not measured": "-", "n/a": ""}[verdict.state]


def summary_table(args: argparse.Namespace, results: Sequence[CellResult], methods: Sequence[Method],
                  verdicts: dict[str, list[Verdict]]) -> list[str]:
    """One row per cell: truth, odometry and oracle ATE, best method, pgem-em against the best
    GTSAM method, and the targets."""
    labels = {m.name: m.label for m in methods}
    header = ["cell", "truth", "odometry ATE", "oracle ATE", "best method", f"{BASELINE} ATE", "best GTSAM ATE",
              f"{BASELINE} F1", "best GTSAM F1", f"{BASELINE} time", "GNC-TLS time"]
    header += [title for title, _, _ in TARGETS]
    lines = ["| " + " | ".join(header) + " |", "|---|---|--:|--:|---|" + "--:|" * 6 + ":-:|" * len(TARGETS)]
    for res in results:
        cell = res.cell
        if cell.error or res.error:
            lines.append(f"| `{cell.name}` | **{cell.error or res.error}** |" + " |" * (len(header) - 2))
            continue
        best = best_method(res, methods)
        gtsam_ate, gtsam_f1 = best_gtsam(res, res.ate, True), best_gtsam(res, res.f1, False)
        base, gnc = res.solves.get(BASELINE), res.solves.get(GNC)
        oracle_ate = format_ate(res.oracle.scores.get("ate_translation_rmse")) if res.oracle is not None else "-"
        row = [f"`{cell.name}`", cell.truth_kind, format_ate(res.odometry.get("ate_translation_rmse")), oracle_ate,
               labels.get(best, "-") if best else "-", format_ate(res.ate(BASELINE)),
               f"{format_ate(gtsam_ate[0])} ({GTSAM_METHODS[gtsam_ate[1]][0]})" if gtsam_ate else "-",
               format_ratio(res.f1(BASELINE)),
               f"{format_ratio(gtsam_f1[0])} ({GTSAM_METHODS[gtsam_f1[1]][0]})" if gtsam_f1 else "-",
               format_seconds(base.seconds) if base is not None and base.ok else "-",
               time_or_status(gnc)]
        row += [verdict_mark(v) for v in verdicts[cell.name]]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def time_or_status(solve: Solve | None) -> str:
    if solve is None:
        return "-"
    return format_seconds(solve.seconds) if solve.ok else solve.status


def targets_lines(results: Sequence[CellResult], verdicts: dict[str, list[Verdict]]) -> list[str]:
    """Per target: how many cells meet it, and the cells that miss it with the figures."""
    lines = []
    for index, (title, description, _) in enumerate(TARGETS):
        states = [(res.cell.name, verdicts[res.cell.name][index]) for res in results if res.cell.name in verdicts]
        applicable = [(name, v) for name, v in states if v.state in ("met", "missed")]
        missed = [(name, v) for name, v in applicable if v.state == "missed"]
        unmeasured = sum(v.state == "not measured" for _, v in states)
        text = (f"- **{title}** ({description}): met on **{len(applicable) - len(missed)} of {len(applicable)}** "
                f"cells" + (f" ({unmeasured} not measured)" if unmeasured else "") + (":" if missed else "."))
        lines.append(text)
        lines += [f"  - missed on `{name}`: {v.detail}" for name, v in missed]
    return lines


def cross_check_lines(results: Sequence[CellResult]) -> list[str]:
    """pgem's and GTSAM's Gauss-Newton on the oracle inputs, once per distinct input."""
    lines = ["| oracle input | pgem GN ATE vs truth m | GTSAM GN ATE vs truth m | GTSAM vs pgem ATE m "
             "| pgem time | GTSAM time |", "|---|--:|--:|--:|--:|--:|"]
    seen = set()
    for res in results:
        oracle, other = res.oracle, res.oracle_gtsam
        if other is None or res.cell.oracle_input in seen:
            continue
        seen.add(res.cell.oracle_input)
        if oracle is None or not oracle.ok or not other.ok:
            lines.append(f"| {res.cell.oracle_label} | {time_or_status(oracle)} | {time_or_status(other)} "
                         "| - | - | - |")
            continue
        lines.append(f"| {res.cell.oracle_label} | {format_ate(oracle.scores.get('ate_translation_rmse'))} | "
                     f"{format_ate(other.scores.get('ate_translation_rmse'))} | "
                     f"{format_ate(other.oracle_scores.get('ate_translation_rmse'))} | "
                     f"{format_seconds(oracle.seconds)} | {format_seconds(other.seconds)} |")
    return lines if len(lines) > 2 else ["Not run (`--peer none`)."]


def failure_lines(results: Sequence[CellResult]) -> list[str]:
    """Every cell, oracle and solve that produced no result, with its message."""
    lines = []
    for res in results:
        if res.cell.error or res.error:
            lines.append(f"- `{res.cell.name}`: {res.cell.error or res.error}")
        for solve in [res.oracle, res.oracle_gtsam, *res.solves.values()]:
            if solve is not None and not solve.ok:
                cached = f" (cached {solve.cache_date})" if solve.cached else ""
                lines.append(f"- `{res.cell.name}` {solve.method}: {solve.status}{cached}: {solve.error}")
    return lines or ["None."]


def definitions(args: argparse.Namespace, methods: Sequence[Method]) -> list[str]:
    """How to read the tables."""
    variants = "; ".join(f"`{m.name}`: `{' '.join(('--robust', 'em') + m.options)}`" for m in methods if m.is_pgem)
    return [
        f"- **Methods**: {variants} (pgem's time: its `solve_seconds`, median of up to {args.pgem_runs} run(s), "
        f"fewer once they took {PGEM_REPEAT_SECONDS:g} s in all; run alone). GTSAM: GNC-TLS = `GncLMOptimizer`, "
        "truncated least squares, gauge prior and odometry known inliers, GTSAM's defaults otherwise (inlier "
        "threshold: the 0.99 chi-square quantile); Cauchy and DCS = "
        f"Levenberg-Marquardt with the kernel (scale {gtsam_worker.KERNEL_SCALE:g}) on the loop closures only. "
        f"LM: at most {gtsam_worker.LM_MAX_ITERATIONS} iterations, error tolerances {gtsam_worker.LM_ERROR_TOL:g}. "
        "GTSAM's time: optimizer construction plus `optimize()`, one fresh process per solve. "
        "**(N x GN)** after a time: that time over the oracle's (pgem Gauss-Newton on the odometry and "
        "the true loops alone, the clean graph), what robustness costs over a solve that needs none "
        "(the oracle's time may be a cached run's).",
        "- **Same start**: every method starts from the initial guess pgem composes: KITTI files have no VERTEX "
        "lines, so `pgem corrupt --count 0` writes the graph with that guess (17 digits) for GTSAM, and the "
        "guess is checked (same initial chi2, byte-identical Gauss-Newton results on both files); synthetic "
        "cells are one corrupted file for all.",
        "- **Odometry / loops**: an edge between consecutive ids is odometry, every other edge a loop closure. "
        "True loops: KITTI's `_GT_LC.txt`, every loop of `ring`, the original loops of a corrupted graph; the "
        "false ones are the rest (KITTI) or the `.outliers` list of `pgem corrupt`.",
        "- **Rejected**: pgem: state `pruned` in its weights file; GTSAM Cauchy and DCS: final weight below "
        f"{bench_robust.DEFAULT_REJECT_BELOW:g} (as `pgem eval --reject-below`); GNC-TLS: weight below 0.5 (its "
        "weights end near 0 or 1). GNC-TLS returns the estimate of its last inner solve, made with the weights "
        "before their last update, so its ATE can differ from a solve with the loops it reports as kept.",
        "- **true rejected** = FP, **false kept** = FN; positives are the false loops rejected (TP). "
        "**P** = TP / rejected, 1 when nothing is rejected; **R** = TP / false loops, 1 when there are none; "
        "**F1** = 2PR / (P + R), 0 when P = R = 0. So a cell without false loops has F1 = 1 only when nothing is "
        "rejected, and a method that rejects nothing where there are false loops has F1 = 0. P, R, F1 are "
        "truncated to three decimals (only an exact 1 shows as 1.000).",
        "- **ATE**: `pgem eval`'s translation RMSE after a rigid alignment, in metres. **vs truth**: the "
        "ground truth (KITTI: `_GT.g2o` composed from pose 0; ring: `ring_groundTruth.g2o`) or, for M3500, "
        "intel and sphere2500, which have none, the clean optimum (pgem Gauss-Newton on the uncorrupted graph, "
        "the same solve as the oracle, whose ATE is then 0). **vs oracle**: against the oracle's estimate. "
        "**odometry ATE**: the initial guess against the truth.",
        "- **oracle**: pgem Gauss-Newton on the odometry and the true loops only, from the same initial guess; "
        "cross-checked with GTSAM's Gauss-Newton below.",
        "- **3D** (sphere2500): GTSAM applies the file's rotation information to its angle-axis error (about twice "
        "g2o's quaternion-vector error), so its optimum differs slightly from the g2o-convention truth and its ATE "
        "has a small floor even when it rejects exactly the false loops.",
        f"- **best method** (bold): lowest ATE vs truth; ATEs within {ATE_TIE * 1e3:g} mm tie, broken by the higher "
        "F1, then the shorter time. The oracle is not a candidate.",
        "- **outcome**: pgem's JSON fields (`status` and `usable` only when not PGEM_OK / true); GTSAM: LM "
        "iterations. `(cached)`: the result comes from the cache (GTSAM and the oracles depend only on their "
        "input file and parameters).",
    ]


def header_lines(args: argparse.Namespace, methods: Sequence[Method], results: Sequence[CellResult],
                 cache: Cache) -> list[str]:
    """Machine, versions, the selection and the cache."""
    real = sum(res.cell.kind == "real" for res in results)
    return [
        bench_gn.machine_line(args.pgem, gtsam=args.peer == "gtsam") + f"; load average {args.load[0]} at the start, "
        f"{args.load[1]} at the end.",
        "",
        f"Cells: {len(results)} ({real} real, {len(results) - real} synthetic: policies {', '.join(args.policies)}; "
        f"counts {', '.join(map(str, args.counts))}; seeds {', '.join(map(str, args.seeds))}). Methods: "
        f"{', '.join(m.name for m in methods)}. Timeout {args.timeout:g} s per solve; {args.jobs} parallel "
        f"GTSAM job(s). Cache: {cache.hits} result(s) reused, {cache.misses} computed"
        + ("" if cache.enabled else " (--no-cache)") + ".",
    ]


def render(args: argparse.Namespace, methods: Sequence[Method], results: Sequence[CellResult], cache: Cache,
           verdicts: dict[str, list[Verdict]], notes: Sequence[str], wall: float) -> str:
    """The whole Markdown report."""
    lines = ["# pgem robust benchmark: real and synthetic false loop closures", ""]
    lines += header_lines(args, methods, results, cache)
    lines += ["", "## Summary", ""] + summary_table(args, results, methods, verdicts)
    lines += ["", f"## Targets ({BASELINE})", ""] + targets_lines(results, verdicts)
    groups = [("Real graphs", [r for r in results if r.cell.kind == "real"])]
    groups += [(f"Synthetic: {short}", [r for r in results if r.cell.name.startswith(f"synth/{short}/")])
               for short in SYNTHETIC]
    for title, group in groups:
        if group:
            lines += ["", f"## {title}", ""] + results_table(group, methods)
    lines += ["", "## Oracle cross-check (Gauss-Newton on the true loops only)", ""] + cross_check_lines(results)
    lines += ["", "## Initial guess", ""] + [f"- `{r.cell.name}`: {r.cell.guess_check}" for r in results
                                            if r.cell.kind == "real" and r.cell.guess_check]
    lines += ["", "## Definitions", ""] + definitions(args, methods)
    lines += ["", "## Failures and timeouts", ""] + failure_lines(results)
    if notes:
        lines += ["", "## Notes", ""] + [f"- {note}" for note in notes]
    lines += ["", f"Wall time: {format_duration(wall)}."]
    return "\n".join(lines) + "\n"


def raw_results(args: argparse.Namespace, results: Sequence[CellResult], verdicts: dict[str, list[Verdict]],
                methods: Sequence[Method], header: str, wall: float) -> dict[str, Any]:
    """Everything measured, as JSON."""
    cells = []
    for res in results:
        entry = {key: (str(value) if isinstance(value, Path) else value)
                 for key, value in dataclasses.asdict(res.cell).items()}
        entry.update({"truth_kind": res.cell.truth_kind, "error": res.cell.error or res.error,
                      "odometry": res.odometry,
                      "oracle": dataclasses.asdict(res.oracle) if res.oracle else None,
                      "oracle_gtsam": dataclasses.asdict(res.oracle_gtsam) if res.oracle_gtsam else None,
                      "solves": {name: dataclasses.asdict(solve) for name, solve in res.solves.items()},
                      "best": best_method(res, methods),
                      "targets": {title: dataclasses.asdict(v)
                                  for (title, _, _), v in zip(TARGETS, verdicts.get(res.cell.name, []))}})
        cells.append(entry)
    options = {key: (str(value) if isinstance(value, Path) else value) for key, value in vars(args).items()}
    return {"header": header, "options": options, "methods": [dataclasses.asdict(m) for m in methods],
            "cells": cells, "wall_seconds": wall}


# --------------------------------------------------------------------------------------
# The benchmark
# --------------------------------------------------------------------------------------


def peer_jobs(args: argparse.Namespace, results: Sequence[CellResult], methods: Sequence[Method],
              gtsam_version: str) -> list[PeerJob]:
    """Every cacheable solve: the oracle (and its GTSAM cross-check) and the GTSAM methods."""
    code = worker_code() if args.peer == "gtsam" else ""
    jobs = []
    for res in results:
        cell = res.cell
        if cell.error:
            continue
        names = [ORACLE] + ([ORACLE_GTSAM] if args.peer == "gtsam" else [])
        for name in names:
            jobs.append(PeerJob(cell.name, name, cell.oracle_input, peer_params(name, gtsam_version, code)))
        jobs += [PeerJob(cell.name, m.name, cell.peer_input, peer_params(m.name, gtsam_version, code))
                 for m in methods if not m.is_pgem]
    return jobs


def attach(res: CellResult, solve: Solve) -> None:
    """Files a solve under its cell."""
    if solve.method == ORACLE:
        res.oracle = solve
    elif solve.method == ORACLE_GTSAM:
        res.oracle_gtsam = solve
    else:
        res.solves[solve.method] = solve


def solve_line(solve: Solve, eta: str) -> str:
    """One progress line per solve."""
    where = f"[{solve.cell}] {solve.method}"
    if not solve.ok:
        return f"{where}: {solve.status.upper()}: {solve.error} ({eta})"
    return f"{where}: {format_seconds(solve.seconds)}{' (cached)' if solve.cached else ''} ({eta})"


def take_cached(cache: Cache, by_name: dict[str, CellResult], jobs: Sequence[PeerJob]) -> dict[str, list[PeerJob]]:
    """Files every cached result under its cell; returns the other jobs by cache key (jobs with
    one key, such as the oracle of every synthetic cell of one graph, run once)."""
    pending: dict[str, list[PeerJob]] = {}
    for job in jobs:
        cached = cache.lookup(job)
        if cached is not None:
            cache.hits += 1
            attach(by_name[job.cell], cached)
        else:
            pending.setdefault(cache.key(job), []).append(job)
    cache.misses += len(pending)
    return pending


def run_peers(args: argparse.Namespace, cache: Cache, by_name: dict[str, CellResult],
              pending: dict[str, list[PeerJob]], eta: bench.Eta) -> None:
    """The jobs not in the cache, on args.jobs threads; each result filed under its cells."""

    def done(job: PeerJob, solve: Solve, seconds: float) -> None:
        for twin in pending[cache.key(job)]:
            attach(by_name[twin.cell], dataclasses.replace(solve, cell=twin.cell))
        progress(solve_line(solve, eta.step(job.method, seconds)))

    run_parallel(args.jobs, [group[0] for group in pending.values()], lambda job: run_peer(args, cache, job), done)


def run_pgem_phase(args: argparse.Namespace, results: Sequence[CellResult], methods: Sequence[Method],
                   eta: bench.Eta) -> None:
    """Every pgem method on every cell, one process at a time."""
    for res in results:
        if res.cell.error:
            continue
        for method in methods:
            if method.is_pgem:
                start = time.perf_counter()
                solve = run_pgem(args, res.cell, method)
                attach(res, solve)
                progress(solve_line(solve, eta.step(method.name, time.perf_counter() - start)))


def score_all(args: argparse.Namespace, results: Sequence[CellResult], methods: Sequence[Method]) -> None:
    """pgem eval on every result, on args.jobs threads (nothing is timed any more)."""
    run_parallel(args.jobs, [res for res in results if not res.cell.error],
                 lambda res: score_cell(args, res, methods), lambda res, _, seconds: None)


def build_cells(args: argparse.Namespace, notes: list[str]) -> list[Cell]:
    """The selected cells whose dataset files exist; a missing file is a note."""
    cells = select(real_cells(args.datasets) + synthetic_cells(args.datasets, args.policies, args.counts, args.seeds),
                   args.cells)
    found = []
    for cell in cells:
        needed = [cell.source] + [p for p in (cell.truth_source, cell.labels) if p is not None]
        missing = [str(p) for p in needed if not p.is_file()]
        if missing:
            notes.append(f"`{cell.name}`: skipped, {', '.join(missing)} not found.")
        else:
            found.append(cell)
    if not found:
        missing = f"; {len(notes)} skipped, e.g. {notes[0]}" if notes else ""
        raise BenchError(f"no cell selected or found under {args.datasets} (--cells {','.join(args.cells) or '*'})"
                         + missing)
    return found


def run_benchmark(args: argparse.Namespace) -> int:
    """Prepares the cells, runs the peers (cached), then pgem alone, scores and reports."""
    bench_robust.check_pgem(args.pgem)
    bench.check_peer(args)
    start, start_load = time.perf_counter(), bench.load_average()
    notes: list[str] = []
    fingerprint = bench_gn.binary_fingerprint(args.pgem)
    gtsam_version = bench_gn.gtsam_version() if args.peer == "gtsam" else ""
    methods = chosen_methods(all_methods(args.variants, args.peer), args.methods)
    cells = build_cells(args, notes)
    header = bench_gn.machine_line(args.pgem, gtsam=args.peer == "gtsam")
    progress(header)
    progress(f"{len(cells)} cell(s), methods {', '.join(m.name for m in methods)}; work folder {args.work}")
    for cell in cells:
        prepare(args, cell, fingerprint)
        if cell.error:
            progress(f"[{cell.name}] {cell.error}")
    progress(f"prepared {len(cells)} cell(s) in {format_duration(time.perf_counter() - start)}")
    results = [CellResult(cell) for cell in cells]
    by_name = {res.cell.name: res for res in results}
    cache = Cache(args.work / "cache", not args.no_cache, args.timeout)
    pending = take_cached(cache, by_name, peer_jobs(args, results, methods, gtsam_version))
    eta = bench.Eta([group[0].method for group in pending.values()] +
                    [m.name for res in results if not res.cell.error for m in methods if m.is_pgem])
    run_peers(args, cache, by_name, pending, eta)
    run_pgem_phase(args, results, methods, eta)
    progress("scoring with pgem eval ...")
    score_all(args, results, methods)
    verdicts = {res.cell.name: check_targets(args, res) for res in results if not (res.cell.error or res.error)}
    args.load = (start_load, bench.load_average())
    rebuilt = bench_gn.rebuilt_note(args.pgem, fingerprint, "the results")
    if rebuilt:
        notes.append(rebuilt)
    wall = time.perf_counter() - start
    report = render(args, methods, results, cache, verdicts, notes, wall)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report, encoding="utf-8")
    print(report)
    raw = args.out.with_suffix(".json")
    raw.write_text(json.dumps(raw_results(args, results, verdicts, methods, header, wall), indent=1) + "\n",
                   encoding="utf-8")
    for line in targets_lines(results, verdicts):
        progress(line)
    progress(f"report written to {args.out}, raw results to {raw.name} ({format_duration(wall)})")
    return 0


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    """Command-line options; --quick only changes the defaults of the selection."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--datasets", type=Path, default=bench_gn.DEFAULT_DATASETS,
                        help="datasets folder holding real/, 2d/ and 3d/ (default ../shared/datasets beside the "
                             "repository)")
    parser.add_argument("--pgem", type=Path, default=bench_gn.DEFAULT_PGEM,
                        help="pgem binary (default build/release/tools/pgem/pgem)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="Markdown report; the raw results go beside it as .json "
                             "(default build/bench/bench_real.md)")
    parser.add_argument("--work", type=Path, default=DEFAULT_WORK,
                        help="inputs, cache and results (default build/bench/bench_real_work)")
    parser.add_argument("--cells", help="comma-separated patterns over cell names (shell globs matched against the "
                                        "whole name, or regular expressions searched in it), e.g. 'real/*' or "
                                        "kitti_09 or 'synth/ring/local/*' (default every cell)")
    parser.add_argument("--methods", help="comma-separated methods to run, shell globs allowed (default all: "
                                          "pgem-em, the variants, gtsam-gnc, gtsam-cauchy, gtsam-dcs; e.g. "
                                          "'pgem-em,gtsam-*')")
    parser.add_argument("--variant", action="append", type=parse_variant, metavar="NAME=OPTIONS",
                        help="a pgem method pgem-NAME: `pgem optimize --robust em OPTIONS`; repeatable; replaces the "
                             "default variants " + ", ".join(f"'{n}={o}'" for n, o in DEFAULT_VARIANTS))
    parser.add_argument("--policies", help=f"synthetic cells' policies (default {','.join(POLICIES)})")
    parser.add_argument("--counts", help=f"synthetic cells' false-loop counts (default {','.join(map(str, COUNTS))})")
    parser.add_argument("--seeds", help=f"synthetic cells' seeds (default {','.join(map(str, SEEDS))})")
    parser.add_argument("--peer", choices=("gtsam", "none"), default="gtsam",
                        help="the library to compare with; none: pgem alone (no gtsam or numpy needed)")
    parser.add_argument("--timeout", type=float, default=bench_robust.DEFAULT_TIMEOUT,
                        help="seconds before a solve is killed and recorded as a timeout (default 300)")
    parser.add_argument("--jobs", type=int, default=1,
                        help="GTSAM solves run at the same time (default 1); pgem is always timed alone")
    parser.add_argument("--pgem-runs", type=int, help="runs of each pgem solve, the median time reported; fewer "
                                                      f"once they took {PGEM_REPEAT_SECONDS:g} s in all "
                                                      "(default 3; --quick: 1)")
    parser.add_argument("--no-cache", action="store_true", help="re-run the GTSAM methods and the oracles")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke run: cells {', '.join(QUICK_CELLS)}; one pgem run each")
    args = parser.parse_args(argv)
    split = bench_robust.split_list
    args.cells = split(args.cells, QUICK_CELLS if args.quick else ())
    args.methods = split(args.methods, ())
    args.policies = split(args.policies, POLICIES)
    try:
        args.counts = split(args.counts, COUNTS, int)
        args.seeds = split(args.seeds, SEEDS, int)
    except ValueError:
        parser.error("--counts and --seeds take comma-separated integers")
    unknown = [p for p in args.policies if p not in POLICIES]
    if unknown:
        parser.error(f"unknown policy {', '.join(unknown)} (choose from {', '.join(POLICIES)})")
    args.variants = args.variant if args.variant is not None else list(DEFAULT_VARIANTS)
    args.pgem_runs = args.pgem_runs if args.pgem_runs is not None else (1 if args.quick else 3)
    if args.timeout <= 0 or args.jobs < 1 or args.pgem_runs < 1 or any(c < 1 for c in args.counts):
        parser.error("--timeout, --jobs, --pgem-runs and --counts must be positive")
    args.pgem, args.out, args.work, args.datasets = (p.resolve() for p in (args.pgem, args.out, args.work,
                                                                           args.datasets))
    del args.variant
    return args


def main(argv: Sequence[str]) -> int:
    args = parse_args(argv)
    try:
        return run_benchmark(args)
    except BenchError as error:
        print(f"bench_real: error: {error}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
