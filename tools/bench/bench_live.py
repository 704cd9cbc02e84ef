#!/usr/bin/env python3
"""Live-map benchmark (issue 30): the incremental estimate while poses arrive, against batch EM.

``python3 tools/bench/bench_live.py`` streams graphs with false loop closures into
``pgem-online-driver --mode incremental`` as a robot's front-end would, with a whole-graph EM
pass every N poses adopted while the updates go on (``--live-em N``) and without it (today's
incremental update alone), and, fed the same stream, GTSAM's iSAM2 with a Cauchy or DCS kernel on
the loop closures (``isam2_live_worker.py``). At every tenth of the stream (by poses) and at its
end, before any settle solve, each live estimate is written and scored: its ATE against the ground
truth (KITTI, Vertigo's ring) or the clean graph's optimum (corrupted M3500 and City10000), its
ATE against batch EM on the graph received so far (``pgem optimize --robust em`` on that prefix,
from the file's initial estimates), and its loop decisions against that batch EM's. The target:
the live ATE at most batch EM's x 1.05 + 0.05 m at every checkpoint of every stream.

iSAM2's runs depend only on their input, the kernel, the checkpoints and GTSAM: they are cached
in the work folder as bench_online.py caches its iSAM2 runs. The report is rewritten after every
stream, so a run cut short still leaves the streams done so far.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import hashlib
import json
import math
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402  (load average, peer check, time-to-go)
import bench_gn  # noqa: E402  (machine header, binary fingerprint, progress)
import bench_online  # noqa: E402  (streamed processes, their progress)
import bench_real  # noqa: E402  (cells and their inputs, the peer cache, pgem eval)
import bench_robust  # noqa: E402  (corruption, commands, formats)
import isam2_live_worker  # noqa: E402  (iSAM2 with Cauchy or DCS, checkpoints)
import isam2_worker  # noqa: E402  (its parameters)

DEFAULT_OUT = bench_gn.REPO_ROOT / "build" / "bench" / "bench_live.md"
DEFAULT_WORK = DEFAULT_OUT.with_name("bench_live_work")

LIVE_EM = 10  # poses between passes: 1 s of a 10 Hz stream, about the LCM bridge's own schedule here (README)
CHECKPOINTS = 10  # every tenth of the stream, the last at its end
TARGET_RATIO, TARGET_SLACK = 1.05, 0.05  # live ATE <= batch EM's ATE x 1.05 + 0.05 m
SEEDS = (1, 2, 3, 4)  # M3500's corruptions
CITY_SEEDS = (1,)
M3500_COUNTS = (100, 1000)
KITTI = ("00", "05", "09")
KITTI_ALPHA = "0.00"  # DLoopDetector's most permissive threshold: the most false loops
QUICK_CELLS = ("M3500/random/100/s4",)  # a stream the incremental update alone drifts on
QUICK_SEEDS = (4,)
DEFAULT_TIMEOUT = 600.0  # s of streaming per run; then it stops and its later checkpoints are missing
CACHE_FORMAT = 1
GRAPHS = {"M3500": "2d/input_M3500_g2o.g2o", "City10000": "2d/city10000.g2o", "ring": "real/vertigo/ring.g2o"}
RING_TRUTH = "real/vertigo/ring_groundTruth.g2o"


@dataclass(frozen=True)
class Method:
    """One live estimate: a driver configuration or an iSAM2 kernel."""

    name: str
    label: str
    reject_below: float  # a loop is rejected when pruned or weighted below this (pgem: pruned only)

    @property
    def is_pgem(self) -> bool:
        return self.name.startswith("pgem-")


METHODS = (
    Method("pgem-live", "pgem live (--live-em)", 0.0),
    Method("pgem-live-no-pending", "pgem live, --no-pending", 0.0),
    Method("pgem-incremental", "pgem incremental alone", 0.0),
    Method("isam2-cauchy", "iSAM2 + Cauchy", isam2_live_worker.gtsam_worker.REJECT_BELOW),
    Method("isam2-dcs", "iSAM2 + DCS", isam2_live_worker.gtsam_worker.REJECT_BELOW),
)
OPTIONAL_METHODS = ("pgem-live-no-pending",)  # run only when --methods names them
SUBJECT = "pgem-live"  # the method the target is checked for


# --------------------------------------------------------------------------------------
# Streams
# --------------------------------------------------------------------------------------


def all_cells(args: argparse.Namespace) -> list[bench_real.Cell]:
    """M3500 with 100 and 1000 random false loops per seed, City10000 with 100, the KITTI files
    with their real false loops, Vertigo's ring (no false loop) and the ring with 100 random ones."""
    data, cells = args.datasets, []
    m3500, city, ring = (data / GRAPHS[name] for name in ("M3500", "City10000", "ring"))
    for count in args.counts:
        cells += [bench_real.Cell(f"M3500/random/{count}/s{seed}", "synthetic", m3500, None, "random", count, seed)
                  for seed in args.seeds]
    cells += [bench_real.Cell(f"City10000/random/100/s{seed}", "synthetic", city, None, "random", 100, seed)
              for seed in args.city_seeds]
    for sequence in KITTI:
        name = f"kitti_{sequence}_alpha_{args.kitti_alpha}"
        graph = data / "real" / "kitti" / f"{name}.g2o"
        cells.append(bench_real.Cell(f"kitti/{name}", "real", graph, graph.with_name(f"kitti_{sequence}_GT.g2o"),
                                     labels=graph.with_name(f"{name}_GT_LC.txt")))
    cells.append(bench_real.Cell("ring", "real", ring, data / RING_TRUTH))
    cells.append(bench_real.Cell("ring/random/100/s1", "synthetic", ring, data / RING_TRUTH, "random", 100, 1))
    return cells


def build_cells(args: argparse.Namespace, notes: list[str]) -> list[bench_real.Cell]:
    """The selected streams whose files exist."""
    found = []
    for cell in bench_real.select(all_cells(args), args.cells):
        missing = [str(p) for p in (cell.source, cell.truth_source, cell.labels) if p is not None and not p.is_file()]
        if missing:
            notes.append(f"`{cell.name}`: skipped, {', '.join(missing)} not found.")
        else:
            found.append(cell)
    if not found:
        raise bench_gn.BenchError(f"no stream selected or found under {args.datasets} (--cells "
                                  f"{','.join(args.cells) or '*'})" + (f"; {notes[0]}" if notes else ""))
    return found


def vertex_ids(path: Path) -> list[int]:
    """The ids of a graph's VERTEX lines, in file order: the stream's order of the poses."""
    return [int(line.split()[1]) for line in bench_real.vertex_lines(path)]


def checkpoint_poses(total: int, count: int) -> list[int]:
    """The poses the stream holds at each checkpoint: ceil(i total / count), the last at the end."""
    return [isam2_live_worker.checkpoint_poses(i, count, total) for i in range(1, count + 1)]


@dataclass
class Stream:
    """One stream's inputs and everything measured on it."""

    cell: bench_real.Cell
    ids: list[int] = field(default_factory=list)  # poses in stream order
    checkpoints: list[int] = field(default_factory=list)  # poses at each checkpoint
    truth_kind: str = ""
    batch: list[dict[str, Any]] = field(default_factory=list)  # per checkpoint: batch EM's files and scores
    runs: dict[str, "Run"] = field(default_factory=dict)  # by method name
    scores: dict[str, list[dict[str, Any]]] = field(default_factory=dict)  # by method: per checkpoint
    error: str = ""

    @property
    def name(self) -> str:
        return self.cell.name


def prepare(args: argparse.Namespace, stream: Stream, fingerprint: str) -> None:
    """The stream's files (bench_real's: the corrupted graph or the written guess, the false loops,
    the truth), the clean optimum when there is no ground truth, and its checkpoints."""
    cell = stream.cell
    bench_real.prepare(args, cell, fingerprint)
    if cell.error:
        stream.error = cell.error
        return
    try:
        if cell.truth is None:  # the clean graph's optimum, one per dataset
            cell.truth = bench_robust.make_reference(args.pgem, cell.source, args.work / "references" / cell.source.stem)
            stream.truth_kind = "clean optimum"
        else:
            stream.truth_kind = "ground truth"
        stream.ids = vertex_ids(cell.peer_input)
        stream.checkpoints = checkpoint_poses(len(stream.ids), args.checkpoints)
    except (bench_robust.RunFailure, OSError, ValueError) as error:
        stream.error = f"not prepared: {error}"


# --------------------------------------------------------------------------------------
# Batch EM on the graph received so far
# --------------------------------------------------------------------------------------


def write_prefix(source: Path, ids: set[int], out: Path) -> int:
    """The graph's poses in ids (their VERTEX lines: the file's initial estimates), its FIX lines
    for them and the edges between them, in file order; returns the edge count."""
    lines, edges = [], 0
    with open(source, encoding="ascii", errors="replace") as handle:
        for line in handle:
            fields = line.split()
            if not fields:
                continue
            if fields[0] == "FIX":  # one or more ids: those of the prefix
                held = [field for field in fields[1:] if int(field) in ids]
                line, keep = "FIX " + " ".join(held) + "\n", bool(held)
            elif fields[0].startswith("VERTEX"):
                keep = int(fields[1]) in ids
            elif fields[0].startswith("EDGE"):
                keep = int(fields[1]) in ids and int(fields[2]) in ids
                edges += keep
            else:
                keep = False
            if keep:
                lines.append(line)
    bench_real.write_atomic(out, "".join(lines))
    return edges


def write_prefix_outliers(outliers: Path, ids: set[int], out: Path) -> int:
    """The false loops whose poses are both in ids (every copy of such a pair is then in the
    prefix, so pgem eval's multiset matching holds); returns their count."""
    pairs = [pair for pair in bench_real.read_pairs(outliers) if pair[0] in ids and pair[1] in ids]
    bench_real.write_atomic(out, "# false loops of the prefix (from to)\n" + "".join(f"{a} {b}\n" for a, b in pairs))
    return len(pairs)


def solve_batch(args: argparse.Namespace, stream: Stream) -> None:
    """Per checkpoint: the prefix, its false loops, batch EM on it, scored against the truth."""
    cell = stream.cell
    for index, poses in enumerate(stream.checkpoints, 1):
        folder = args.work / "batch" / cell.slug / f"checkpoint_{index:02d}"
        ids = set(stream.ids[:poses])
        entry: dict[str, Any] = {"checkpoint": index, "poses": poses}
        try:
            prefix, outliers = folder / "prefix.g2o", folder / "false_loops.txt"
            entry["edges"] = write_prefix(cell.peer_input, ids, prefix)
            entry["false_loops"] = write_prefix_outliers(cell.outliers, ids, outliers)
            summary = bench_robust.pgem_optimize(args.pgem, prefix, ("--robust", "em"), folder)
            result, weights = folder / bench_robust.RESULT_FILE, folder / bench_robust.WEIGHTS_FILE
            scores = bench_real.pgem_eval(args.pgem, result, cell.truth, outliers, weights, 0.0)
            entry.update({"prefix": str(prefix), "outliers": str(outliers), "result": str(result),
                          "weights": str(weights), "solve_seconds": summary.get("solve_seconds"),
                          "loops": summary.get("loops"), "pruned": summary.get("pruned"),
                          "ate": scores.get("ate_translation_rmse"), "precision": scores.get("precision"),
                          "recall": scores.get("recall")})
        except (bench_robust.RunFailure, OSError, ValueError, KeyError) as error:
            entry["error"] = f"batch EM at checkpoint {index}: {error}"
        stream.batch.append(entry)


# --------------------------------------------------------------------------------------
# Runs: the driver and the iSAM2 worker, their checkpoints
# --------------------------------------------------------------------------------------


@dataclass
class Run:
    """One method streaming one graph."""

    method: str
    status: str = "ok"  # ok | failed | timeout
    error: str = ""
    summary: dict[str, Any] = field(default_factory=dict)
    checkpoints: dict[int, dict[str, Any]] = field(default_factory=dict)  # by index: poses, edges, graph, weights
    cached: bool = False
    cache_date: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def read_lines(path: Path) -> list[dict[str, Any]]:
    """The JSON lines of a run's stdout, kept beside its files."""
    lines = []
    for text in path.read_text(encoding="utf-8").splitlines():
        try:
            lines.append(json.loads(text))
        except json.JSONDecodeError:
            continue
    return lines


def run_from_lines(method: str, lines: Sequence[dict[str, Any]], folder: Path) -> Run:
    """A run's summary and checkpoints from its lines, the files looked up in folder (where
    they are now: a cached run's folder moved)."""
    record = Run(method)
    for line in lines:
        kind = line.get("type")
        if kind == "summary":
            record.summary = line
        elif kind == "checkpoint":
            index = int(line["checkpoint"])
            record.checkpoints[index] = {"poses": int(line["poses"]), "edges": int(line["edges"]),
                                         "graph": str(folder / f"checkpoint_{index:02d}.g2o"),
                                         "weights": str(folder / f"checkpoint_{index:02d}.weights")}
    return record


def stream_run(args: argparse.Namespace, stream: Stream, method: Method, outdir: Path, eta: bench.Eta) -> Run:
    """One streamed process writing its checkpoints into outdir; its lines (all but the updates'),
    kept as lines.jsonl beside them."""
    if outdir.exists():
        shutil.rmtree(outdir)
    outdir.mkdir(parents=True)
    cell = stream.cell
    if method.is_pgem:
        command = [str(args.driver), str(cell.solve_input), "--mode", "incremental", "--no-settle",
                   "--checkpoints", str(args.checkpoints), "--checkpoint-dir", str(outdir),
                   "--time-limit", repr(args.timeout), "--quiet"]
        if method.name.startswith("pgem-live"):
            command += ["--live-em", str(args.live_em)]
        if method.name == "pgem-live-no-pending":
            command.append("--no-pending")
    else:
        command = isam2_live_worker.command(method.name, cell.peer_input, outdir, args.checkpoints, args.timeout)
    watch = bench_online.Watch(f"[{stream.name}] {method.name}", len(stream.ids), eta)
    kill_after = args.timeout * 1.2 + 60.0
    others: list[dict[str, Any]] = []
    code, _, summary, killed = bench_online.stream_process(command, kill_after, outdir / "stderr.log", watch,
                                                                 others)
    lines = [line for line in others if line.get("type") != "pass" and line.get("type") != "adopt"]
    lines += [summary] if summary else []
    with open(outdir / "lines.jsonl", "w", encoding="utf-8") as handle:
        handle.writelines(json.dumps(line) + "\n" for line in lines)
    if method.is_pgem:  # the passes and adoptions, for the report's pass columns
        with open(outdir / "passes.jsonl", "w", encoding="utf-8") as handle:
            handle.writelines(json.dumps(line) + "\n" for line in others if line.get("type") in ("pass", "adopt"))
    record = run_from_lines(method.name, lines, outdir)
    if killed:
        record.status, record.error = "timeout", f"killed after {kill_after:g} s"
    elif code != 0 or not summary:
        record.status, record.error = "failed", f"exit {code}: {bench_online.first_error(outdir / 'stderr.log')}"
    elif len(record.checkpoints) == 0:
        record.status, record.error = "failed", "no checkpoint written"
    return record


# --------------------------------------------------------------------------------------
# The iSAM2 cache (bench_real's): runs keyed by input, kernel, checkpoints, GTSAM and code
# --------------------------------------------------------------------------------------


def peer_code() -> str:
    """What an iSAM2 run depends on in code: the workers and the modules they import."""
    digest = hashlib.sha256(bench_real.worker_code().encode())
    for module in (isam2_worker, isam2_live_worker):
        digest.update(Path(module.__file__).read_bytes())
    return digest.hexdigest()


def peer_job(args: argparse.Namespace, stream: Stream, method: Method, gtsam_version: str,
             code: str) -> bench_real.PeerJob:
    params = (("format", CACHE_FORMAT), ("gtsam", gtsam_version), ("code", code),
              ("parameters", isam2_worker.PARAMETERS), ("checkpoints", args.checkpoints), ("guess", "anchored"))
    return bench_real.PeerJob(stream.name, method.name, stream.cell.peer_input, params)


def cached_run(cache: bench_real.Cache, job: bench_real.PeerJob, timeout: float) -> Run | None:
    """A stored iSAM2 run, unless it stopped at a shorter time limit than asked for now."""
    solve = cache.lookup(job)
    if solve is None:
        return None
    limit = solve.summary.get("time_limit")
    if solve.summary.get("stopped") and limit is not None and float(limit) < timeout:
        return None
    folder = cache.folder(job)
    if not (folder / "lines.jsonl").is_file():
        return None
    record = run_from_lines(job.method, read_lines(folder / "lines.jsonl"), folder)
    record.status, record.error = solve.status, solve.error
    record.cached, record.cache_date = True, solve.cache_date
    return record


def store_run(cache: bench_real.Cache, job: bench_real.PeerJob, record: Run, outdir: Path) -> Run:
    """Moves a finished iSAM2 run into the cache; the record then points at the cached files."""
    solve = bench_real.Solve(job.cell, job.method, record.status, record.error,
                             record.summary.get("update_seconds"), summary=record.summary)
    solve = cache.store(job, solve, outdir)
    folder = cache.folder(job)
    stored = run_from_lines(job.method, read_lines(folder / "lines.jsonl"), folder)
    stored.status, stored.error, stored.cache_date = record.status, record.error, solve.cache_date
    return stored


# --------------------------------------------------------------------------------------
# Scoring
# --------------------------------------------------------------------------------------


def compare_decisions(mine: Path, batch: Path, reject_below: float) -> dict[str, int]:
    """The method's loop verdicts against batch EM's on the same graph, pairs matched in order
    (both files list a pair's copies in file order): loops, kept (by the method, pruned by batch
    EM), dropped (rejected by the method, kept by batch EM), missing (not in the method's file)."""
    ours, theirs = bench_online.read_weights(mine), bench_online.read_weights(batch)
    found = {"loops": 0, "kept": 0, "dropped": 0, "missing": 0}
    for pair, queue in theirs.items():
        mine_queue = ours.get(pair, collections.deque())
        for _, state in queue:
            found["loops"] += 1
            if not mine_queue:
                found["missing"] += 1
                continue
            weight, my_state = mine_queue.popleft()
            mine_rejected = my_state == "pruned" or weight < reject_below
            batch_rejected = state == "pruned"
            found["kept"] += batch_rejected and not mine_rejected
            found["dropped"] += mine_rejected and not batch_rejected
    return found


def bound(batch_ate: float) -> float:
    """The target's bound on a live ATE."""
    return TARGET_RATIO * batch_ate + TARGET_SLACK


def score_checkpoint(args: argparse.Namespace, stream: Stream, method: Method, index: int,
                     found: dict[str, Any] | None, batch: dict[str, Any]) -> dict[str, Any]:
    """One live estimate: ATE against the truth and against batch EM on the same prefix, the
    loop decisions against batch EM's and the labels, and the target."""
    entry: dict[str, Any] = {"checkpoint": index, "poses": stream.checkpoints[index - 1]}
    if found is None:
        entry["error"] = "not reached (the run stopped or failed before it)"
        return entry
    if batch.get("error"):
        entry["error"] = batch["error"]
        return entry
    if found["poses"] != batch["poses"]:  # a run stopped by the time limit: its end is earlier
        entry["error"] = f"written at {found['poses']} poses (the run stopped), batch EM at {batch['poses']}"
        return entry
    try:
        scores = bench_real.pgem_eval(args.pgem, found["graph"], stream.cell.truth, Path(batch["outliers"]),
                                      Path(found["weights"]), method.reject_below)
        against = bench_real.pgem_eval(args.pgem, found["graph"], batch["result"])
        if against.get("poses_only_result") or against.get("poses_only_reference"):
            raise bench_robust.RunFailure(f"not the poses of the prefix: {against.get('poses_only_result')} only in "
                                          f"the live estimate, {against.get('poses_only_reference')} only in batch EM's")
        entry.update({"ate": scores.get("ate_translation_rmse"), "precision": scores.get("precision"),
                      "recall": scores.get("recall"), "rejected": scores.get("rejected"),
                      "ate_vs_batch": against.get("ate_translation_rmse")})
        entry.update(compare_decisions(Path(found["weights"]), Path(batch["weights"]), method.reject_below))
        if entry["ate"] is not None and batch.get("ate") is not None:
            entry["bound"] = bound(float(batch["ate"]))
            entry["meets"] = float(entry["ate"]) <= entry["bound"]
    except (bench_robust.RunFailure, OSError, ValueError, KeyError) as error:
        entry["error"] = f"scoring: {error}"
    return entry


def score_stream(args: argparse.Namespace, stream: Stream, methods: Sequence[Method]) -> None:
    for method in methods:
        record = stream.runs.get(method.name)
        if record is None:
            continue
        stream.scores[method.name] = [score_checkpoint(args, stream, method, index, record.checkpoints.get(index),
                                                       stream.batch[index - 1])
                                      for index in range(1, args.checkpoints + 1)]


# --------------------------------------------------------------------------------------
# Targets
# --------------------------------------------------------------------------------------

Verdict = bench_real.Verdict


def verdict(stream: Stream, name: str) -> Verdict:
    """Whether a method's live ATE met the bound at every checkpoint of a stream."""
    if stream.error:
        return Verdict("not measured", f"`{stream.name}`: {stream.error}")
    scores = stream.scores.get(name)
    if not scores:
        return Verdict("not measured", f"`{stream.name}`: {name} not run")
    unscored = [s for s in scores if "meets" not in s]
    missed = [s for s in scores if s.get("meets") is False]
    if unscored:
        first = unscored[0]
        return Verdict("missed", f"`{stream.name}`: checkpoint {first['checkpoint']} not scored: "
                                 f"{first.get('error', 'no ATE')}")
    worst = max(scores, key=lambda s: float(s["ate"]) - s["bound"])
    detail = (f"`{stream.name}`: {len(scores) - len(missed)} of {len(scores)} checkpoints; "
              f"{'worst' if missed else 'closest to the bound'} at {worst['poses']} poses, ATE {m(worst['ate'])} "
              f"against a bound of {m(worst['bound'])}")
    return Verdict("missed" if missed else "met", detail)


def check_targets(streams: Sequence[Stream], methods: Sequence[Method]) -> dict[str, list[Verdict]]:
    """Per method (the subject first), one verdict per stream."""
    return {method.name: [verdict(stream, method.name) for stream in streams] for method in methods}


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def m(value: Any) -> str:
    """A length in metres, three significant digits (four from 10 m)."""
    if value is None or not math.isfinite(float(value)):
        return "-"
    value = float(value)
    return f"{value:.4g}" if abs(value) >= 10.0 else f"{value:.3g}" if abs(value) >= 1e-3 else "0" \
        if value == 0.0 else f"{value:.1e}"


def seconds_text(value: Any) -> str:
    return bench_online.ms(None if value is None else float(value))


def ate_cell(entry: dict[str, Any]) -> str:
    """A live ATE, bold when it is over the bound, '-' when not scored."""
    if "ate" not in entry:
        return "-"
    text = m(entry["ate"])
    return f"**{text}**" if entry.get("meets") is False else text


def decisions_cell(entry: dict[str, Any]) -> str:
    """+kept / -rejected against batch EM ('=' when the same verdicts)."""
    if "loops" not in entry:
        return "-"
    if entry["kept"] == entry["dropped"] == entry["missing"] == 0:
        return "="
    text = f"+{entry['kept']} / -{entry['dropped']}"
    return text + (f" ({entry['missing']} missing)" if entry["missing"] else "")


def stream_table(stream: Stream, methods: Sequence[Method]) -> list[str]:
    """One row per checkpoint: batch EM, then each method's ATE, ATE against batch EM and verdicts."""
    head = ["checkpoint", "poses", "loops (false)", "batch EM ATE", "P / R", "bound"]
    for method in methods:
        head += [f"{method.label} ATE", "vs batch", "loops vs batch"]
    lines = ["| " + " | ".join(head) + " |", "|" + "--:|" * len(head)]
    total = len(stream.checkpoints)
    for index, batch in enumerate(stream.batch, 1):
        share = f"{100 * index // total} %" + (" (end)" if index == total else "")
        if batch.get("error"):
            row = [share, str(batch["poses"]), "-", f"**{batch['error'][:80]}**", "-", "-"]
        else:
            row = [share, str(batch["poses"]), f"{batch.get('loops')} ({batch.get('false_loops')})", m(batch.get("ate")),
                   f"{bench_robust.format_ratio(batch.get('precision'))} / {bench_robust.format_ratio(batch.get('recall'))}",
                   m(bound(float(batch["ate"]))) if batch.get("ate") is not None else "-"]
        for method in methods:
            scores = stream.scores.get(method.name)
            entry = scores[index - 1] if scores else {}
            row += [ate_cell(entry), m(entry.get("ate_vs_batch")), decisions_cell(entry)]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def run_outcome(record: Run) -> str:
    if not record.ok:
        return f"**{record.status}**: {record.error[:100]}"
    s, parts = record.summary, []
    if s.get("stopped"):
        parts.append(f"**stopped** after {s.get('poses')} of {s.get('poses_total')} poses (time limit)")
    if record.method.startswith("pgem-"):
        parts.append(f"{s.get('graph_pruned')} of {s.get('graph_loops')} loops pruned at the end")
        if s.get("failed_updates"):
            parts.append(f"**{s['failed_updates']} updates failed**, {s.get('restarts')} restarts")
    else:
        parts.append(f"{s.get('rejected')} of {s.get('loops')} loops below 0.01 at the end")
    if record.cached:
        parts.append(f"cached {record.cache_date}")
    return "; ".join(parts)


def runs_table(streams: Sequence[Stream], methods: Sequence[Method]) -> list[str]:
    lines = ["| stream | method | updates | update time | passes (adopted) | pass time: total / longest | outcome |",
             "|---|---|--:|--:|--:|--:|---|"]
    for stream in streams:
        for method in methods:
            record = stream.runs.get(method.name)
            if record is None:
                continue
            s = record.summary
            passes = f"{s.get('passes')} ({s.get('adopted')})" if s.get("live_em") else "-"
            pass_time = (f"{seconds_text(s.get('pass_seconds'))} / {seconds_text(s.get('pass_seconds_max'))}"
                         if s.get("live_em") else "-")
            lines.append(f"| `{stream.name}` | {method.label} | {s.get('updates', '-')} | "
                         f"{seconds_text(s.get('update_seconds'))} | {passes} | {pass_time} | {run_outcome(record)} |")
    return lines


def summary_table(streams: Sequence[Stream], methods: Sequence[Method], targets: dict[str, list[Verdict]]) -> list[str]:
    """One row per stream: batch EM's largest ATE over the checkpoints and, per method, its
    largest live ATE and how many checkpoints met the bound."""
    head = ["stream", "poses", "false loops", "truth", "batch EM ATE, max"]
    head += [f"{method.label}: ATE max, checkpoints met" for method in methods]
    lines = ["| " + " | ".join(head) + " |", "|---|--:|--:|---|--:|" + "--:|" * len(methods)]
    for number, stream in enumerate(streams):
        if stream.error:
            lines.append(f"| `{stream.name}` | **{stream.error[:100]}** |" + " - |" * (len(head) - 2))
            continue
        batch_ates = [float(b["ate"]) for b in stream.batch if b.get("ate") is not None]
        row = [f"`{stream.name}`", str(len(stream.ids)), str(stream.cell.loops_false), stream.truth_kind,
               m(max(batch_ates)) if batch_ates else "-"]
        for method in methods:
            scores = stream.scores.get(method.name)
            if not scores:
                row.append("-")
                continue
            ates = [float(s["ate"]) for s in scores if s.get("ate") is not None]
            met = sum(bool(s.get("meets")) for s in scores)
            state = targets[method.name][number].state
            mark = "yes" if state == "met" else "**NO**"
            row.append(f"{m(max(ates)) if ates else '-'}, {met}/{len(scores)} {mark}")
        lines.append("| " + " | ".join(row) + " |")
    return lines


def targets_lines(targets: dict[str, list[Verdict]], methods: Sequence[Method]) -> list[str]:
    lines = []
    for method in methods:
        verdicts = targets.get(method.name, [])
        counted = [v for v in verdicts if v.state in ("met", "missed")]
        met = sum(v.state == "met" for v in counted)
        state = "not measured" if not counted else "**met**" if met == len(counted) else "**missed**"
        what = "the target" if method.name == SUBJECT else "for comparison"
        lines.append(f"- {method.label} ({what}): {state}" + (f" (met on {met} of {len(counted)} streams)" if counted else ""))
        lines += [f"  - {v.state}: {v.detail}" for v in verdicts]
    return lines


def definitions(args: argparse.Namespace) -> list[str]:
    return [
        "- **Stream**: the poses in file order (KITTI: by id, the guess composed along the odometry, written as "
        "VERTEX lines for iSAM2 and checked bit-identical), each followed by every edge whose later pose it is; "
        "one update per pose. A new pose joined by odometry to a solved one is placed by that measurement from it "
        "(the LCM bridge's rule), on both sides.",
        f"- **pgem live (--live-em)**: `pgem-online-driver --mode incremental --live-em {args.live_em} --no-settle`: "
        "`pgem_update` after every pose (new loop closures through its innovation gate) and, every "
        f"{args.live_em} poses, the previous whole-graph pass adopted (`pgem_update_adopt`, before that pose's "
        "update) and a new one started: batch EM on a copy of the graph received so far, from the file's initial "
        f"estimates, solved in the driver but adopted only at the next pass point (a pass that runs beside the "
        f"updates and takes up to {args.live_em} poses' time); as the LCM bridge with its passes, the updates hold "
        "back a loop that passes the gate only because the map is uncertain, for a pass to judge (`pending`). "
        "**pgem live, --no-pending**: the same with the gate as without passes. **pgem incremental alone**: no "
        "pass (today's behaviour without them). No settle solve at the end: the last checkpoint is the live map.",
        "- **iSAM2 + Cauchy / + DCS**: `isam2_live_worker.py`: GTSAM's `ISAM2` with `ISAM2Params()` defaults "
        f"({', '.join(f'{k} {v}' for k, v in isam2_worker.PARAMETERS.items())}), `update()` once per pose, the "
        "loop closures in `noiseModel.Robust` with `mEstimator.Cauchy(1)` or `mEstimator.DCS(1)`, odometry "
        "Gaussian, the gauge a prior of sigma 1e-6 on the first pose; the estimate at a checkpoint is "
        "`calculateEstimate()`.",
        f"- **Checkpoints**: the first time the stream holds ceil(i P / {args.checkpoints}) of its P poses, after "
        "that pose's update, and the end of the stream (`100 % (end)`), before any settle.",
        "- **batch EM**: `pgem optimize --robust em` on the graph received so far (its poses with the file's "
        "initial estimates, the edges between them), the reference for the live estimate at that checkpoint. "
        "**P / R**: precision and recall of its pruned loops against the labels.",
        "- **ATE**: `pgem eval`'s translation RMSE (m) after a rigid alignment, against the ground truth (KITTI's "
        "`_GT.g2o`, `ring_groundTruth.g2o`) or, for corrupted M3500 and City10000, the clean graph's optimum "
        "(`pgem optimize` on the uncorrupted file). **vs batch**: the live estimate against batch EM's on the "
        "same prefix. **bound**: batch EM's ATE x "
        f"{TARGET_RATIO:g} + {TARGET_SLACK:g} m; a live ATE over it is in bold.",
        "- **loops vs batch**: the live verdicts against batch EM's: `+k / -r`, k loops the live map keeps that "
        "batch EM pruned, r it rejects that batch EM keeps (`=`: the same verdicts). Rejected: pgem pruned; "
        "iSAM2 weight below 0.01.",
        "- **update time** (the updates' library calls alone) and **pass time** (the passes' copies and EM "
        "solves, summed, and the longest): the passes run beside the updates, so their time is not update time.",
    ]


def render(args: argparse.Namespace, header: str, streams: Sequence[Stream], methods: Sequence[Method],
           notes: Sequence[str], wall: float, cache: bench_real.Cache, partial: int | None) -> str:
    targets = check_targets([s for s in streams if s.batch or s.error], methods)
    done = [s for s in streams if s.batch or s.error]
    lines = ["# pgem live-map benchmark (issue 30): the live estimate against batch EM while poses arrive", "",
             header, ""]
    if partial is not None:
        lines += [f"**Partial**: {partial} of {len(streams)} streams done so far.", ""]
    lines += [f"Streams: {', '.join(f'`{s.name}`' for s in streams)}. `--live-em {args.live_em}`, "
              f"{args.checkpoints} checkpoints, timeout {args.timeout:g} s per run. iSAM2 cache: {cache.hits} run(s) "
              f"reused, {cache.misses} computed" + ("" if cache.enabled else " (--no-cache)") + ".", "",
              "## Summary", ""]
    lines += summary_table(done, methods, targets)
    lines += ["", f"## Target: live ATE at most batch EM's x {TARGET_RATIO:g} + {TARGET_SLACK:g} m at every "
                  "checkpoint", ""]
    lines += targets_lines(targets, methods)
    lines += ["", "## Checkpoints", ""]
    for stream in done:
        if stream.error:
            continue
        lines += [f"### `{stream.name}`", "",
                  f"{len(stream.ids)} poses, {stream.cell.loops_true} true and {stream.cell.loops_false} false loop "
                  f"closures; ATE against the {stream.truth_kind}.", ""]
        lines += stream_table(stream, methods) + [""]
    lines += ["## Runs", ""] + runs_table(done, methods)
    lines += ["", "## Definitions", ""] + definitions(args)
    failures = [f"- `{s.name}`: {s.error}" for s in done if s.error]
    failures += [f"- `{s.name}` {r.method}: {r.status}: {r.error}" for s in done for r in s.runs.values() if not r.ok]
    failures += [f"- `{s.name}`: {b['error']}" for s in done for b in s.batch if b.get("error")]
    lines += ["", "## Failures and timeouts", ""] + (failures or ["None."])
    if notes:
        lines += ["", "## Notes", ""] + [f"- {note}" for note in notes]
    lines += ["", f"Wall time: {bench_robust.format_duration(wall)}."]
    return "\n".join(lines) + "\n"


def raw_results(args: argparse.Namespace, header: str, streams: Sequence[Stream], methods: Sequence[Method],
                wall: float) -> dict[str, Any]:
    targets = check_targets([s for s in streams if s.batch or s.error], methods)
    options = {key: (str(value) if isinstance(value, Path) else value) for key, value in vars(args).items()}
    return {"header": header, "options": options, "wall_seconds": wall,
            "targets": {name: [dataclasses.asdict(v) for v in verdicts] for name, verdicts in targets.items()},
            "streams": [{"stream": s.name, "poses": len(s.ids), "checkpoints": s.checkpoints, "truth": s.truth_kind,
                         "loops_true": s.cell.loops_true, "loops_false": s.cell.loops_false, "error": s.error,
                         "batch": s.batch, "scores": s.scores,
                         "runs": {name: {"status": r.status, "error": r.error, "summary": r.summary,
                                         "cached": r.cached} for name, r in s.runs.items()}}
                        for s in streams if s.batch or s.error]}


def write_report(args: argparse.Namespace, header: str, streams: Sequence[Stream], methods: Sequence[Method],
                 notes: Sequence[str], start: float, cache: bench_real.Cache, partial: int | None) -> str:
    wall = time.perf_counter() - start
    report = render(args, header, streams, methods, notes, wall, cache, partial)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    bench_real.write_atomic(args.out, report)
    raw = args.out.with_suffix(".json")
    bench_real.write_atomic(raw, json.dumps(raw_results(args, header, streams, methods, wall), indent=1) + "\n")
    return report


# --------------------------------------------------------------------------------------
# The benchmark
# --------------------------------------------------------------------------------------


def run_stream(args: argparse.Namespace, stream: Stream, methods: Sequence[Method], cache: bench_real.Cache,
               gtsam_version: str, code: str, eta: bench.Eta) -> None:
    """Every method on one stream (iSAM2 from the cache when it can), then batch EM and the scores."""
    for method in methods:
        key = f"{stream.name}:{method.name}"
        job = None if method.is_pgem else peer_job(args, stream, method, gtsam_version, code)
        if job is not None:
            found = cached_run(cache, job, args.timeout)
            if found is not None:
                cache.hits += 1
                stream.runs[method.name] = found
                eta.skip([key])
                continue
            cache.misses += 1
        started = time.perf_counter()
        outdir = args.work / "runs" / stream.cell.slug / method.name
        record = stream_run(args, stream, method, outdir, eta)
        if job is not None:  # failures too: the same input fails the same way
            record = store_run(cache, job, record, outdir)
        stream.runs[method.name] = record
        done = eta.step(key, time.perf_counter() - started)
        text = "ok" if record.ok else f"{record.status.upper()}: {record.error}"
        bench_gn.progress(f"[{stream.name}] {method.name}: {text}, {len(record.checkpoints)} checkpoints, updates "
                          f"{seconds_text(record.summary.get('update_seconds'))}"
                          + (f", passes {seconds_text(record.summary.get('pass_seconds'))}"
                             if record.summary.get("live_em") else "") + f" ({done})")
    bench_gn.progress(f"[{stream.name}] batch EM at {len(stream.checkpoints)} checkpoints, scoring ...")
    solve_batch(args, stream)
    score_stream(args, stream, methods)


def check_tools(args: argparse.Namespace) -> None:
    bench_robust.check_pgem(args.pgem)
    if not args.driver.is_file():
        raise bench_gn.BenchError(f"pgem-online-driver not found at {args.driver}: build it with `cmake --build "
                                  "--preset release` (target pgem_online_driver) or pass --driver")
    bench.check_peer(args)


def run_benchmark(args: argparse.Namespace) -> int:
    check_tools(args)
    start, notes = time.perf_counter(), []
    fingerprint = bench_gn.binary_fingerprint(args.pgem)
    gtsam_version = bench_gn.gtsam_version() if args.peer == "gtsam" else ""
    code = peer_code() if args.peer == "gtsam" else ""
    offered = [m for m in METHODS if (m.is_pgem or args.peer == "gtsam")
               and (args.methods or m.name not in OPTIONAL_METHODS)]
    methods = bench_real.chosen_methods(offered, args.methods)
    streams = [Stream(cell) for cell in build_cells(args, notes)]
    header = bench_gn.machine_line(args.pgem, f"driver sha256 {bench_gn.binary_fingerprint(args.driver)}",
                                   gtsam=args.peer == "gtsam") + f"; load average {bench.load_average()} at the start"
    bench_gn.progress(header)
    bench_gn.progress(f"{len(streams)} stream(s), methods {', '.join(m.name for m in methods)}; work folder {args.work}")
    cache = bench_real.Cache(args.work / "cache", not args.no_cache, args.timeout)
    eta = bench.Eta([f"{s.name}:{m.name}" for s in streams for m in methods])
    for number, stream in enumerate(streams, 1):
        prepare(args, stream, fingerprint)
        if stream.error:
            eta.skip([f"{stream.name}:{m.name}" for m in methods])
            bench_gn.progress(f"[{stream.name}] {stream.error}")
        else:
            run_stream(args, stream, methods, cache, gtsam_version, code, eta)
        write_report(args, header, streams, methods, notes, start, cache, number if number < len(streams) else None)
    rebuilt = bench_gn.rebuilt_note(args.pgem, fingerprint, "the results")
    if rebuilt:
        notes.append(rebuilt)
    header += f", {bench.load_average()} at the end"
    report = write_report(args, header, streams, methods, notes, start, cache, None)
    print(report)
    for line in targets_lines(check_targets(streams, methods), methods[:1]):
        bench_gn.progress(line)
    bench_gn.progress(f"report written to {args.out}, raw results to {args.out.with_suffix('.json').name} "
                      f"({bench_robust.format_duration(time.perf_counter() - start)})")
    return 0


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--datasets", type=Path, default=bench_gn.DEFAULT_DATASETS,
                        help="datasets folder holding 2d/ and real/ (default ../shared/datasets beside the repository)")
    parser.add_argument("--pgem", type=Path, default=bench_gn.DEFAULT_PGEM,
                        help="pgem binary (default build/release/tools/pgem/pgem)")
    parser.add_argument("--driver", type=Path, help="pgem-online-driver (default: beside pgem, ../bench/)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="Markdown report, rewritten after every stream; the raw results go beside it as .json "
                             "(default build/bench/bench_live.md)")
    parser.add_argument("--work", type=Path, default=DEFAULT_WORK,
                        help="inputs, runs, batch solves and the iSAM2 cache (default build/bench/bench_live_work)")
    parser.add_argument("--cells", help="comma-separated patterns over the stream names (shell globs or regular "
                                        "expressions), e.g. 'M3500/*' or kitti (default every stream)")
    parser.add_argument("--methods", help="comma-separated shell globs over pgem-live, pgem-incremental, "
                                          "isam2-cauchy, isam2-dcs (default), and pgem-live-no-pending (the pass "
                                          "with the updates' gate as without it: run only when named)")
    parser.add_argument("--seeds", help=f"pgem corrupt's seeds for M3500 (default {','.join(map(str, SEEDS))})")
    parser.add_argument("--city-seeds", help=f"... for City10000 (default {','.join(map(str, CITY_SEEDS))})")
    parser.add_argument("--counts", help=f"M3500's false loops (default {','.join(map(str, M3500_COUNTS))})")
    parser.add_argument("--kitti-alpha", default=KITTI_ALPHA, choices=("0.00", "0.50", "1.00"),
                        help=f"the KITTI files' loop-detector threshold (default {KITTI_ALPHA}: the most false loops)")
    parser.add_argument("--live-em", type=int, default=LIVE_EM,
                        help=f"poses between whole-graph passes of pgem live (default {LIVE_EM})")
    parser.add_argument("--checkpoints", type=int, default=CHECKPOINTS,
                        help=f"checkpoints over each stream, the last at its end (default {CHECKPOINTS})")
    parser.add_argument("--peer", choices=("gtsam", "none"), default="gtsam",
                        help="iSAM2 (gtsam) or pgem alone (none: no gtsam or numpy needed)")
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT,
                        help="seconds a run may stream; then it stops and its later checkpoints are missing "
                             f"(default {DEFAULT_TIMEOUT:g})")
    parser.add_argument("--no-cache", action="store_true", help="re-run iSAM2")
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke run: the stream {', '.join(QUICK_CELLS)} alone")
    args = parser.parse_args(argv)
    split = bench_robust.split_list
    args.cells = split(args.cells, QUICK_CELLS if args.quick else ())
    args.methods = split(args.methods, ())
    try:
        args.seeds = split(args.seeds, QUICK_SEEDS if args.quick else SEEDS, int)
        args.city_seeds = split(args.city_seeds, CITY_SEEDS, int)
        args.counts = split(args.counts, M3500_COUNTS, int)
    except ValueError:
        parser.error("--seeds, --city-seeds and --counts take comma-separated integers")
    if args.timeout <= 0 or args.live_em < 1 or args.checkpoints < 1 or any(c < 1 for c in args.counts):
        parser.error("--timeout, --live-em, --checkpoints and --counts must be positive")
    bench_online.resolve_paths(args)
    return args


def main(argv: Sequence[str]) -> int:
    return bench_online.run_main("bench_live", parse_args, run_benchmark, argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
