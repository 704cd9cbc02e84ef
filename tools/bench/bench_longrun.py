#!/usr/bin/env python3
"""Long missions in a fixed block: graphs streamed through the LCM bridge with --compact.

Each graph is streamed by ``pgem-lcm-send --rate R`` into a ``pgem-lcm-bridge --max-poses N
--max-edges M --compact`` whose block holds 10 %, 25 % and 50 % of the graph's poses, then
into a bridge with room for everything (the unbounded stream), and into GTSAM's
IncrementalFixedLagSmoother (fixedlag_worker.py) whose window holds as many poses as pgem's
block: the peer that bounds memory by forgetting. The final graph is the one
``pgem-lcm-dump`` received last (the bridge's settle solve after the stream), with its loop
weights and the bridge's last status. Everything runs over UDP multicast inside a network
namespace of its own (``unshare -n``, loopback only), as bench_lcm.py; needs root.

Graphs: City10000, M3500 and Sphere2500 with 100 random false loop closures (``pgem corrupt``,
seed 1); a 10000-pose ``pgem simulate`` Manhattan world with its ground truth and 100 false loop
closures; the real KITTI 00, 05 and 09 graphs with the loop closures DLoopDetector proposed
(real/kitti, alpha 0.00 by default: the most false ones) and their labels.

Columns: the ATE (translation RMS after a rigid alignment) of the poses the bounded bridge kept,
against the ground truth where there is one (the simulated world; KITTI's GT chain) and else
against the unbounded batch optimum (``pgem optimize --robust em`` on the whole file); the
unbounded stream's ATE over the same poses and the ratio; the ATE against the batch optimum;
the fixed-lag smoother's ATE over the same poses (each pose's estimate as it left the window);
loop decisions against the batch EM's (loops whose two poses were kept, matched by their ends:
agree / disagree) and, for KITTI, against the labels; per-update latency from the bridge's log
(``solve N (..., incremental): ... X ms``) median / p99 / max, apart from compaction and with
each compaction (``compaction N: ... in X ms``) added to the update that waited for it; the
compactions' median and max; poses and edges refused for capacity (the status's reasons); the
core block's MiB (the bridge's first log line) and the live EM pass copy's.

The report is Markdown on stdout and in --out (rewritten after every row, so a long run leaves
partial results), the figures in --json. ``--quick``: M3500 and the simulated world (2000
poses) at 25 %, no KITTI.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_lcm  # noqa: E402  (tools, the network namespace, percentiles)
import fixedlag_worker  # noqa: E402  (the peer's command line)

try:
    import numpy as np
except ImportError:
    np = None

DEFAULT_OUT = bench_lcm.REPO_ROOT / "build" / "bench" / "bench_longrun.md"
GRAPHS = ("city10000", "M3500", "sphere2500", "sim10000", "kitti00", "kitti05", "kitti09")
FILES = {"city10000": "2d/city10000.g2o", "M3500": "2d/input_M3500_g2o.g2o",
         "sphere2500": "3d/sphere2500.g2o"}
SOLVE = re.compile(r"solve (\d+) \(([^)]*)\): .*?([0-9.]+) ms \(publishing")
COMPACTION = re.compile(r"compaction (\d+): (\d+) -> (\d+) poses.*? in ([0-9.]+) ms")
BLOCK = re.compile(r"core block ([0-9.]+) MiB")
PASS_BLOCK = re.compile(r"the copy's block ([0-9.]+) MiB")


class Graph:
    """One streamed file and what it is measured against."""

    def __init__(self, name: str, path: Path, truth: dict | None, labels: set | None,
                 is_3d: bool) -> None:
        self.name, self.path, self.truth, self.labels, self.is_3d = name, path, truth, labels, is_3d
        self.poses = sum(1 for line in path.open() if line.startswith("VERTEX"))
        self.edges = bench_lcm.count_edges(path)
        self.optimum: dict = {}
        self.weights: dict = {}


def run(command: list, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([str(c) for c in command], check=True, capture_output=True, text=True,
                          **kwargs)


def read_vertices(path: Path) -> dict[int, list[float]]:
    poses = {}
    for line in path.open():
        fields = line.split()
        if fields and fields[0].startswith("VERTEX"):
            poses[int(fields[1])] = [float(v) for v in fields[2:]]
    return poses


def read_weights(path: Path) -> dict[tuple[int, int], bool]:
    """(from, to) -> accepted, from a 'from to weight state' file."""
    found = {}
    if not path.exists():
        return found
    for line in path.read_text().splitlines():
        fields = line.split()
        if len(fields) >= 4 and not line.startswith("#"):
            found[(int(fields[0]), int(fields[1]))] = fields[3] == "accepted"
    return found


def compose_chain(path: Path) -> dict[int, list[float]]:
    """KITTI's ground truth: the i -> i+1 EDGE_SE2 lines composed from pose 0 at the origin."""
    steps = {}
    for line in path.open():
        fields = line.split()
        if fields and fields[0] == "EDGE_SE2":
            steps[int(fields[1])] = [float(v) for v in fields[3:6]]
    poses = {0: [0.0, 0.0, 0.0]}
    i = 0
    while i in steps:
        x, y, t = poses[i]
        dx, dy, dt = steps[i]
        poses[i + 1] = [x + math.cos(t) * dx - math.sin(t) * dy,
                        y + math.sin(t) * dx + math.cos(t) * dy, t + dt]
        i += 1
    return poses


def ate(estimate: dict, reference: dict, ids) -> float:
    """Translation RMS of estimate against reference over ids, after the rigid alignment
    (rotation and translation, no scale) that minimises it."""
    ids = [i for i in ids if i in estimate and i in reference]
    if len(ids) < 3:
        return math.nan
    dim = 3 if len(next(iter(estimate.values()))) == 7 else 2
    a = np.array([estimate[i][:dim] for i in ids])
    b = np.array([reference[i][:dim] for i in ids])
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.eye(dim)
    d[-1, -1] = np.sign(np.linalg.det(vt.T @ u.T))
    rotation = vt.T @ d @ u.T
    moved = (rotation @ (a - ca).T).T + cb
    return float(np.sqrt(np.mean(np.sum((moved - b) ** 2, axis=1))))


def prepare(args, work: Path, name: str) -> Graph:
    """The file to stream (with its VERTEX lines), its truth and labels, and the batch optimum."""
    pgem = bench_lcm.tool("pgem")
    datasets = args.datasets
    truth = labels = None
    out = work / f"{name}.g2o"
    if name in FILES or name.startswith("sim"):
        source = datasets / FILES[name] if name in FILES else work / f"{name}.clean.g2o"
        if name.startswith("sim"):
            truth_file = work / f"{name}.truth.g2o"
            run([pgem, "simulate", "-o", source, "--truth", truth_file, "--poses",
                 str(args.sim_poses), "--seed", "1"])
            truth = read_vertices(truth_file)
        run([pgem, "corrupt", source, "-o", out, "--policy", "random", "--count",
             str(args.outliers), "--seed", "1"])
        false = set()
        for line in out.with_name(out.name + ".outliers").read_text().splitlines():
            fields = line.split()
            if len(fields) >= 2:
                false |= {(int(fields[0]), int(fields[1])), (int(fields[1]), int(fields[0]))}
        labels = ("false", false)
    elif name.startswith("kitti"):
        sequence = name[len("kitti"):]
        folder = datasets / "real" / "kitti"
        source = folder / f"kitti_{sequence}_alpha_{args.kitti_alpha}.g2o"
        run([pgem, "corrupt", source, "-o", out, "--policy", "random", "--count", "0",
             "--seed", "1"])  # the same graph with the composed odometry as VERTEX lines
        true = set()
        for line in (folder / f"kitti_{sequence}_alpha_{args.kitti_alpha}_GT_LC.txt").read_text().splitlines():
            fields = line.split()
            if len(fields) >= 2:
                true |= {(int(fields[0]), int(fields[1])), (int(fields[1]), int(fields[0]))}
        labels = ("true", true)
        truth = compose_chain(folder / f"kitti_{sequence}_GT.g2o")
    else:
        raise bench_lcm.BenchError(f"unknown graph {name} (one of {', '.join(GRAPHS)})")
    is_3d = any(line.startswith("VERTEX_SE3") for line in out.open())
    graph = Graph(name, out, truth, labels, is_3d)
    optimum, weights = work / f"{name}.optimum.g2o", work / f"{name}.optimum.weights"
    run([pgem, "optimize", out, "--robust", "em", "--weights", weights, "-o", optimum, "--quiet"])
    graph.optimum = read_vertices(optimum)
    graph.weights = read_weights(weights)
    return graph


def is_false(graph: Graph, pair: tuple[int, int]) -> bool:
    kind, pairs = graph.labels
    return (pair in pairs) == (kind == "false")


FILL = re.compile(r"needs (\d+) nonzeros but config.fill_budget is (\d+)")


def stream(args, work: Path, graph: Graph, tag: str, bridge_args: list[str]) -> dict:
    """stream_once, and once more with --fill-budget 1.5 times what a solve found it needed
    when one failed for want of it (the bridge's default budget is 32 b^2 per pose)."""
    result = stream_once(args, work, graph, tag, bridge_args)
    needed = [int(m.group(1)) for m in FILL.finditer(result["log"])]
    result["fill_budget"] = None
    if needed and "--fill-budget" not in bridge_args:
        budget = math.ceil(1.5 * max(needed))
        print(f"   a solve needed {max(needed)} factor nonzeros: again with --fill-budget {budget}",
              flush=True)
        result = stream_once(args, work, graph, tag, [*bridge_args, "--fill-budget", str(budget)])
        result["fill_budget"] = budget
        result["fill_failures"] = len(FILL.findall(result["log"]))
    return result


def parse_log(text: str) -> tuple[list[float], list[float], list[float], int]:
    """From a bridge's log: the solves the stream caused (every one but the settle; most are
    incremental updates, some restart from the front-end's estimates after an update failed),
    the same with each compaction's time added to the solve after it, the compactions' times,
    and how many of the solves were not incremental."""
    updates, included, compactions = [], [], []
    waiting = 0.0
    whole = 0
    for line in text.splitlines():
        found = COMPACTION.search(line)
        if found:
            compactions.append(float(found.group(4)))
            waiting += float(found.group(4))
            continue
        found = SOLVE.search(line)
        if found and not found.group(2).startswith("settle"):
            updates.append(float(found.group(3)))
            included.append(float(found.group(3)) + waiting)
            whole += "incremental" not in found.group(2)
            waiting = 0.0
    return updates, included, compactions, whole


def stream_once(args, work: Path, graph: Graph, tag: str, bridge_args: list[str]) -> dict:
    """The graph streamed into one bridge; the last graph published, the log's figures."""
    log_path = bench_lcm.fresh_log(work / f"{tag}.bridge.log")
    dumped, weights, status = (work / f"{tag}.dump.g2o", work / f"{tag}.dump.weights",
                               work / f"{tag}.status.json")
    live, live_weights = work / f"{tag}.live.g2o", work / f"{tag}.live.weights"
    for stale in (dumped, weights, status, live, live_weights):
        stale.unlink(missing_ok=True)
    timeout = str(graph.edges / args.rate + 900)
    with log_path.open("w") as log:
        # the settle comes --settle-after seconds after the stream: one dump leaves before it
        # with the live map, the other after it with the settled graph
        bridge = subprocess.Popen([str(bench_lcm.tool("pgem-lcm-bridge")),
                                   "--dimension", "3" if graph.is_3d else "2", "--idle-solve",
                                   str(args.settle_after), *bridge_args],
                                  stdout=log, stderr=log)
        time.sleep(0.5)
        dump = subprocess.Popen([str(bench_lcm.tool("pgem-lcm-dump")), "-o", str(dumped),
                                 "--weights", str(weights), "--status", str(status), "--idle",
                                 str(args.settle_after + args.idle), "--timeout", timeout,
                                 "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        live_dump = subprocess.Popen([str(bench_lcm.tool("pgem-lcm-dump")), "-o", str(live),
                                      "--weights", str(live_weights), "--idle",
                                      str(args.settle_after / 3.0), "--timeout", timeout,
                                      "--quiet"], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        time.sleep(0.3)
        started = time.monotonic()
        sent = bench_lcm.send(graph.path, "--rate", str(args.rate), "--wait", "120",
                              timeout=graph.edges / args.rate + 600)
        streamed = time.monotonic() - started
        for process in (live_dump, dump):
            try:
                process.wait(timeout=graph.edges / args.rate + 900)
            except subprocess.TimeoutExpired:
                process.kill()
        bridge.send_signal(signal.SIGINT)
        try:
            bridge.wait(timeout=60)
        except subprocess.TimeoutExpired:
            bridge.kill()
    text = log_path.read_text()
    updates, included, compactions, whole = parse_log(text)
    refused = {}
    if status.exists():
        try:
            reasons = json.loads(status.read_text()).get("rejected", {})
            refused = {k: v for k, v in reasons.items() if v and ("capac" in k or "compact" in k)}
        except json.JSONDecodeError:
            pass
    block = BLOCK.search(text)
    pass_block = PASS_BLOCK.search(text)
    poses = read_vertices(dumped) if dumped.exists() else {}
    settled = len(re.findall(r"solve \d+ \(settle", text))
    return {"tag": tag, "sent_ok": sent.returncode == 0, "sender": sent.stdout.strip().splitlines()[-1:]
            if sent.stdout.strip() else [], "seconds": streamed, "poses": poses,
            "weights": read_weights(weights), "settles": settled,
            "live": read_vertices(live) if live.exists() else {},
            "live_weights": read_weights(live_weights), "updates": updates, "whole": whole, "included": included,
            "compactions": compactions, "refused": refused,
            "refused_logged": len(re.findall(r"rejected \([^)]*capacity", text)),
            "log": text, "block_mib": float(block.group(1)) if block else math.nan,
            "pass_mib": float(pass_block.group(1)) if pass_block else math.nan}


def peer(args, work: Path, graph: Graph, window: int) -> dict:
    """GTSAM's fixed-lag smoother with a window of `window` poses."""
    outdir = work / f"{graph.name}.fixedlag.{window}"
    command = fixedlag_worker.command(graph.path, outdir, window, args.peer_time_limit)
    result = subprocess.run(command, capture_output=True, text=True,
                            timeout=(args.peer_time_limit or 3600) + 600)
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    if result.returncode != 0 or not lines or lines[-1].get("type") != "summary":
        return {"error": (result.stderr.strip() or "no summary")[-300:]}
    seconds = [1e3 * line["seconds"] for line in lines if line.get("type") == "update"]
    summary = lines[-1]
    summary["poses"] = read_vertices(outdir / fixedlag_worker.RESULT_FILE)
    summary["update_ms"] = seconds
    return summary


def decisions(graph: Graph, weights: dict) -> dict:
    """Loop decisions against the batch EM's (loops found in both by their ends) and labels."""
    agree = disagree = 0
    true_pruned = false_accepted = 0
    for pair, accepted in weights.items():
        if pair not in graph.weights:
            continue  # carried onto another pose by compaction: not the file's loop any more
        if graph.weights[pair] == accepted:
            agree += 1
        else:
            disagree += 1
        if graph.labels is not None:
            bad = is_false(graph, pair)
            false_accepted += bad and accepted
            true_pruned += (not bad) and not accepted
    return {"loops": len(weights), "agree": agree, "disagree": disagree,
            "true_pruned": true_pruned, "false_accepted": false_accepted}


def stats(values: list[float]) -> tuple[float, float, float]:
    if not values:
        return (math.nan, math.nan, math.nan)
    return (statistics.median(values), bench_lcm.percentile(values, 99), max(values))


def row(graph: Graph, label: str, share: float | None, result: dict, unbounded: dict | None,
        fixed: dict | None) -> dict:
    kept = sorted(result["poses"])
    reference = graph.truth if graph.truth is not None else graph.optimum
    figures = {"graph": graph.name, "block": label, "share": share, "poses": graph.poses,
               "kept": len(kept), "sent_ok": result["sent_ok"], "sender": result["sender"],
               "refused": result["refused"], "refused_logged": result["refused_logged"],
               "compactions": len(result["compactions"]),
               "reference": "truth" if graph.truth is not None else "batch optimum",
               "ate": ate(result["poses"], reference, kept),
               "ate_optimum": ate(result["poses"], graph.optimum, kept),
               "settles": result["settles"], "live_kept": len(result["live"]),
               "ate_live": ate(result["live"], reference, sorted(result["live"])),
               "live_loops": decisions(graph, result["live_weights"]),
               "update": stats(result["updates"]), "included": stats(result["included"]),
               "compaction": stats(result["compactions"]), "updates": len(result["updates"]),
               "whole_solves": result["whole"],
               "block_mib": result["block_mib"], "pass_mib": result["pass_mib"],
               "fill_budget": result["fill_budget"],
               "loops": decisions(graph, result["weights"])}
    if graph.truth is not None:  # the batch optimum's own error over the same poses
        figures["batch_ate"] = ate(graph.optimum, reference, kept)
    if unbounded is not None:
        figures["unbounded_ate"] = ate(unbounded["poses"], reference, kept)
        figures["unbounded_ate_live"] = ate(unbounded["live"], reference, sorted(result["live"]))
    if fixed is not None and "error" not in fixed:
        figures["fixedlag_ate"] = ate(fixed["poses"], reference, kept)
        figures["fixedlag_ate_all"] = ate(fixed["poses"], reference, list(fixed["poses"]))
        figures["fixedlag_update"] = stats(fixed["update_ms"])
        figures["fixedlag_lost"] = fixed["loops_lost"]
        figures["fixedlag_stopped"] = fixed["stopped"]
    elif fixed is not None:
        figures["fixedlag_error"] = fixed["error"]
    return figures


def cell(value: float, digits: int = 3) -> str:
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.{digits}f}"


def ms(value: float) -> str:
    """The bridge logs times to 0.1 ms: below that it says 0.0."""
    return "<0.1" if value == 0.0 else cell(value, 1)


def table(rows: list[dict]) -> list[str]:
    lines = ["| graph | block | kept / poses | refused (capacity); other rejections | compactions | ATE kept (ref) | "
             "unbounded stream, same poses | ratio | batch optimum, same poses | ratio | vs batch optimum | live map before the settle: ATE, "
             "unbounded's | fixed-lag, same poses | loops vs "
             "batch EM agree / disagree (of) | true pruned / false accepted | update ms median / "
             "p99 / max | with compaction p99 / max | compaction ms median / max | block MiB "
             "(+ pass copy) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        refused = str(sum(r["refused"].values()) if r["refused"] else 0)
        # the sender's last status line: edges the bridge did not take, e.g. expired waiting
        found = re.search(r"rejected (\d+)(?: \(([^)]*)\))?", " ".join(r["sender"]))
        if found and int(found.group(1)) > 0:
            refused += f"; not taken: {found.group(2) or found.group(1)}"
        ratio = r.get("unbounded_ate", math.nan)  # only against a truth (the batch optimum is
        ratio = r["ate"] / ratio if r["reference"] == "truth" and ratio > 0 else math.nan  # ~0)
        batch = r.get("batch_ate", math.nan)
        batch_ratio = r["ate"] / batch if r["reference"] == "truth" and batch > 0 else math.nan
        loops = r["loops"]
        fixed = cell(r.get("fixedlag_ate"))
        if "fixedlag_error" in r:
            fixed = "failed"
        elif r.get("fixedlag_stopped"):
            fixed += " (stopped early)"
        u, i, c = r["update"], r["included"], r["compaction"]
        fill = f", fill budget {r['fill_budget']}" if r.get("fill_budget") else ""
        whole = f" ({r['whole_solves']} of {r['updates']} whole-graph)" if r.get("whole_solves") else ""
        lines.append(
            f"| {r['graph']} | {r['block']} | {r['kept']} / {r['poses']} | {refused}"
            f"{'' if r['sent_ok'] else ' (send failed)'} | {r['compactions']} | {cell(r['ate'])} "
            f"({r['reference']}) | {cell(r.get('unbounded_ate'))} | {cell(ratio, 2)} | "
            f"{cell(r.get('batch_ate'))} | {cell(batch_ratio, 2)} | "
            f"{cell(r['ate_optimum'])} | {cell(r.get('ate_live'))}, "
            f"{cell(r.get('unbounded_ate_live'))} | {fixed} | {loops['agree']} / {loops['disagree']} "
            f"({loops['loops']}) | {loops['true_pruned']} / {loops['false_accepted']} | "
            f"{ms(u[0])} / {ms(u[1])} / {ms(u[2])}{whole} | {ms(i[1])} / "
            f"{ms(i[2])} | {ms(c[0])} / {ms(c[2])} | {cell(r['block_mib'], 1)} "
            f"(+ {cell(r['pass_mib'], 1)}){fill} |")
    return lines


def report(args, rows: list[dict], header: list[str], done: bool) -> str:
    lines = header + table(rows) + [""]
    if not done:
        lines.append("(partial: the run is still going or was stopped)")
    text = "\n".join(lines)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text + "\n")
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1, default=str) + "\n")
    return text


def rerender_graph(args, work: Path, name: str, cache: dict) -> Graph:
    """A graph's batch EM weights and labels from an earlier run's work files."""
    if name not in cache:
        graph = Graph.__new__(Graph)
        graph.weights = read_weights(work / f"{name}.optimum.weights")
        graph.labels = None
        if name.startswith("kitti"):
            sequence = name[len("kitti"):]
            true = set()
            listed = args.datasets / "real" / "kitti" / f"kitti_{sequence}_alpha_{args.kitti_alpha}_GT_LC.txt"
            for line in listed.read_text().splitlines():
                fields = line.split()
                if len(fields) >= 2:
                    true |= {(int(fields[0]), int(fields[1])), (int(fields[1]), int(fields[0]))}
            graph.labels = ("true", true)
        else:
            false = set()
            listed = work / f"{name}.g2o.outliers"
            for line in listed.read_text().splitlines() if listed.exists() else []:
                fields = line.split()
                if len(fields) >= 2:
                    false |= {(int(fields[0]), int(fields[1])), (int(fields[1]), int(fields[0]))}
            graph.labels = ("false", false)
        cache[name] = graph
    return cache[name]


def render(args) -> int:
    """The table again from --render's JSON, the batch optimum's error over the kept poses
    added from the work files where there is a truth (rows of runs before that column)."""
    rows = []
    for path in args.render:
        rows += json.loads(path.read_text())
    work = args.out.parent / "longrun_work"
    cache: dict = {}
    for r in rows:
        name = r["graph"]
        found = re.search(r"\((\d+)\)", r["block"])
        tag = f"{name}.{found.group(1) if found else 'unbounded'}"
        log = work / f"{tag}.bridge.log"
        if "whole_solves" not in r and log.exists():
            updates, included, compactions, whole = parse_log(log.read_text())
            r.update(update=stats(updates), included=stats(included),
                     compaction=stats(compactions), updates=len(updates), whole_solves=whole)
        labelled = rerender_graph(args, work, name, cache)
        for key, suffix in (("loops", "dump"), ("live_loops", "live")):
            weights = work / f"{tag}.{suffix}.weights"
            if weights.exists():
                r[key] = decisions(labelled, read_weights(weights))
        if "batch_ate" in r or r["reference"] != "truth":
            continue
        if name.startswith("sim"):
            truth = read_vertices(work / f"{name}.truth.g2o")
        else:
            sequence = name[len("kitti"):]
            truth = compose_chain(args.datasets / "real" / "kitti" / f"kitti_{sequence}_GT.g2o")
        dump = work / f"{tag}.dump.g2o"
        if dump.exists():
            kept = sorted(read_vertices(dump))
            r["batch_ate"] = ate(read_vertices(work / f"{name}.optimum.g2o"), truth, kept)
    print("\n".join(table(rows)))
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--datasets", type=Path, default=bench_lcm.DEFAULT_DATASETS)
    parser.add_argument("--graphs", default=",".join(GRAPHS), help=f"some of {','.join(GRAPHS)}")
    parser.add_argument("--shares", default="0.1,0.25,0.5", help="block sizes, shares of the poses")
    parser.add_argument("--rate", type=float, default=1000.0, help="edges per second sent")
    parser.add_argument("--outliers", type=int, default=100, help="false loops added (synthetic)")
    parser.add_argument("--sim-poses", type=int, default=10000)
    parser.add_argument("--kitti-alpha", default="0.00", help="0.00, 0.50 or 1.00")
    parser.add_argument("--edge-slack", type=float, default=1.5,
                        help="--max-edges is the graph's edges per pose times this times --max-poses")
    parser.add_argument("--idle", type=float, default=10.0,
                        help="seconds after the settle's graph the dump takes it as the last")
    parser.add_argument("--settle-after", type=float, default=15.0,
                        help="the bridges' --idle-solve: the settle solve starts this long after "
                             "the stream; the live map is taken a third of it after the last graph")
    parser.add_argument("--bridge-args", default="",
                        help="more pgem-lcm-bridge options for every bridge (space-separated)")
    parser.add_argument("--no-peer", action="store_true", help="no fixed-lag smoother")
    parser.add_argument("--peer-shares", help="run the fixed-lag smoother at these of --shares "
                        "only (default: every one)")
    parser.add_argument("--peer-time-limit", type=float, default=1800.0,
                        help="seconds a fixed-lag run may stream (then it stops, marked)")
    parser.add_argument("--quick", action="store_true",
                        help="M3500 and a 2000-pose simulated world at 25 %% only")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--build", type=Path, default=bench_lcm.DEFAULT_BUILD)
    parser.add_argument("--render", type=Path, nargs="+",
                        help="print the table of an earlier run's --json (and the batch "
                             "optimum's error from its work files) without running anything")
    args = parser.parse_args()
    if args.render is not None:
        return render(args)
    bench_lcm.BUILD = bench_lcm.build_dir(args.build)
    if args.quick:
        args.graphs, args.shares, args.sim_poses = "M3500,sim2000", "0.25", 2000
    try:
        if np is None:
            raise bench_lcm.BenchError("numpy is needed")
        bench_lcm.enter_namespace()
        work = args.out.parent / "longrun_work"
        work.mkdir(parents=True, exist_ok=True)
        extra = args.bridge_args.split()
        header = ["# Long missions in a fixed block", "",
                  f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores; streamed at "
                  f"{args.rate:g} edges/s; bridges `--compact --max-poses N --max-edges M` (M: "
                  f"{args.edge_slack:g} x the graph's edges per pose x N){' ' + args.bridge_args if extra else ''}; "
                  f"fixed-lag peer: GTSAM IncrementalFixedLagSmoother, window N poses, Cauchy(1) "
                  f"on loop closures. ATE in metres after a rigid alignment, over the poses the "
                  f"bounded bridge kept (ratio: to the unbounded stream's over the same poses, "
                  f"where there is a truth). Loops compared by their two ends (a loop carried "
                  f"onto another pose by compaction is not matched). Times are the bridge's "
                  f"log's, to 0.1 ms.", ""]
        rows: list[dict] = []
        shares = [float(s) for s in args.shares.split(",") if s.strip()]
        for name in [g.strip() for g in args.graphs.split(",") if g.strip()]:
            print(f"== {name}: preparing", flush=True)
            graph = prepare(args, work, name)
            print(f"== {name}: unbounded stream ({graph.poses} poses, {graph.edges} edges)", flush=True)
            unbounded = stream(args, work, graph, f"{name}.unbounded",
                               ["--max-poses", str(graph.poses + 64), "--max-edges",
                                str(graph.edges + 64), *extra])
            rows.append(row(graph, "unbounded", None, unbounded, None, None))
            report(args, rows, header, False)
            print(table(rows)[-1], flush=True)
            for share in shares:
                poses = max(16, round(share * graph.poses))
                edges = math.ceil(args.edge_slack * graph.edges / graph.poses * poses)
                print(f"== {name}: {100 * share:g} % block ({poses} poses, {edges} edges)", flush=True)
                bounded = stream(args, work, graph, f"{name}.{poses}",
                                 ["--max-poses", str(poses), "--max-edges", str(edges),
                                  "--compact", *extra])
                with_peer = not args.no_peer and (args.peer_shares is None or any(
                    abs(share - float(x)) < 1e-9 for x in args.peer_shares.split(",")))
                fixed = peer(args, work, graph, poses) if with_peer else None
                rows.append(row(graph, f"{100 * share:g} % ({poses})", share, bounded, unbounded,
                                fixed))
                report(args, rows, header, False)
                print(table(rows)[-1], flush=True)
        print(report(args, rows, header, True))
        return 0
    except (bench_lcm.BenchError, subprocess.CalledProcessError, subprocess.TimeoutExpired) as error:
        detail = getattr(error, "stderr", "") or ""
        print(f"bench_longrun: {error} {detail}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
