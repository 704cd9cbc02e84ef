#!/usr/bin/env python3
"""Benchmark of the LCM bridge: latency, sustained ingest rate, and SIGKILL recovery.

Everything runs over real UDP multicast between separate processes (pgem-lcm-bridge,
pgem-lcm-send, pgem-lcm-dump) inside a network namespace of its own (``unshare -n``,
loopback only, ttl=0), so no packet leaves the machine. Needs root (or CAP_SYS_ADMIN).

1. Latency: each dataset, with false loop closures added by ``pgem corrupt``, is streamed
   by ``pgem-lcm-send --rate HZ --latency CSV`` as a front-end would (poses in order, each
   followed by its odometry and loop closures). For every loop closure the sender notes when
   it was sent and when the first published graph containing it arrived; the report gives
   the median, p90, p99 (nearest rank, as the sender prints them) and maximum over all loop
   closures, the slowest one with its solve, and the bridge's solve times.
2. Sustained ingest: the file is sent at increasing rates (no pacing other than --rate) to
   a fresh bridge each time; a rate passes when the bridge's status shows every edge
   accepted. The highest passing rate is the sustained zero-loss rate.
3. Recovery: the stream runs while the bridge is killed with SIGKILL at random moments and
   restarted on its journal; each restart's replayed records are reported; at the end the
   front-end resends the whole file (replays are recognised and ignored) and the dumped
   graph is compared with the offline ``pgem optimize --robust em`` solve.

5. Split: the file with a share of its odometry edges gone (``--loss``, seeded), as UDP loss
   leaves it: the graph falls into parts. It is sent twice to fresh bridges, paced at the
   file's rate and as a burst (``--burst`` edges/s), and the time until the bridge's status
   shows every edge taken and nothing queued is reported for both, with the whole-graph solves
   the bridge ran meanwhile and the loop verdicts of the graph published then, and again once
   a live EM pass has seen every pose (against the same stream without loss).
6. Island: the latency run again, with a stray sender's island (two poses far from the map
   and an edge between them, three datagrams) sent a quarter into the stream; the report
   gives the loop-closure latency median with and without it.

4. Pauses: the same stream with the sender silent --pauses times for --pause-seconds
   (``pgem-lcm-send --pause-every``; longer than the bridge's idle time, 0.5 s, so its settle
   solve of the whole graph starts), as a robot that stands still and drives on. The report
   gives the latency of the loop closures sent in the first 2 s after a pause (those that
   reach a bridge busy with its settle), and of them all.

The report is printed as Markdown and written to --out; ``--json FILE`` writes the figures
too. ``--phases`` runs only some of the four (bench_online.py runs the latency alone).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_BUILD = Path("build") / "release"
BUILD = REPO_ROOT / DEFAULT_BUILD  # replaced by --build
DEFAULT_DATASETS = REPO_ROOT.parent / "shared" / "datasets"
DEFAULT_OUT = REPO_ROOT / "build" / "bench" / "bench_lcm.md"
URL = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304"


class BenchError(Exception):
    """Ends the benchmark with a message."""


def build_dir(given: Path) -> Path:
    """--build: absolute as given; relative to the current directory, else to the repository."""
    if given.is_absolute():
        return given
    here = Path.cwd() / given
    return (here if here.exists() else REPO_ROOT / given).resolve()


def tool(name: str) -> Path:
    path = BUILD / ("tools/pgem/pgem" if name == "pgem" else f"tools/lcm/{name}")
    if name == "lcm_compare":
        path = BUILD / "tests" / "lcm_compare"
    if not path.exists():
        raise BenchError(f"{path} is missing: build first (cmake --build --preset release, "
                         "or point --build at your build directory)")
    return path


def enter_namespace() -> None:
    """Re-runs this script inside a fresh network namespace with multicast on loopback."""
    if os.environ.get("PGEM_BENCH_NETNS") == "1":
        for command in (["ip", "link", "set", "lo", "up"],
                        ["ip", "link", "set", "lo", "multicast", "on"],
                        ["ip", "route", "add", "224.0.0.0/4", "dev", "lo"]):
            subprocess.run(command, check=True)
        os.environ["LCM_DEFAULT_URL"] = URL
        return
    if shutil.which("unshare") is None:
        raise BenchError("unshare(1) is needed for a private network namespace")
    env = dict(os.environ, PGEM_BENCH_NETNS="1")
    result = subprocess.run(["unshare", "-n", sys.executable, *sys.argv], env=env)
    sys.exit(result.returncode)


def dataset(datasets: Path, name: str) -> Path:
    for sub in ("2d", "3d"):
        candidate = datasets / sub / f"{name}.g2o"
        if candidate.exists():
            return candidate
    raise BenchError(f"dataset {name}.g2o not found under {datasets}")


def count_edges(path: Path) -> int:
    with path.open() as handle:
        return sum(1 for line in handle if line.startswith(("EDGE", "EDGE2", "EDGE3")))


PHASES = ("latency", "ingest", "recovery", "pause", "split", "island")
REPLAYED = re.compile(r"(\d+) records replayed \((\d+) poses, (\d+) edges\)")


class Bridge:
    """A pgem-lcm-bridge process with its log (appended to: restarts share one log)."""

    def __init__(self, log: Path, journal: Path | None = None, extra: list[str] | None = None):
        args = [str(tool("pgem-lcm-bridge")), "--max-poses", "20000"]
        if journal is not None:
            args += ["--journal", str(journal)]
        args += extra or []
        self.log_path = log
        before = len(REPLAYED.findall(log.read_text())) if log.exists() else 0
        self.log = log.open("a")
        self.process = subprocess.Popen(args, stderr=self.log, stdout=self.log)
        self.replayed = (0, 0, 0)
        time.sleep(0.5)
        if journal is not None:
            self.replayed = self.wait_replay(before)

    def wait_replay(self, before: int, timeout: float = 60.0) -> tuple[int, int, int]:
        """(records, poses, edges) of this start's journal line, once it is in the log."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            found = REPLAYED.findall(self.log_path.read_text())
            if len(found) > before:
                return tuple(int(x) for x in found[-1])
            if self.process.poll() is not None:
                raise BenchError(f"the bridge exited ({self.process.returncode}) while "
                                 f"replaying its journal; see {self.log_path}")
            time.sleep(0.05)
        raise BenchError(f"the bridge did not replay its journal within {timeout:g} s")

    def stop(self) -> None:
        self.process.send_signal(2)
        try:
            self.process.wait(timeout=30)
        except subprocess.TimeoutExpired as error:
            self.process.kill()
            raise BenchError("the bridge did not stop on SIGINT within 30 s") from error
        self.log.close()

    def kill(self) -> None:
        self.process.kill()
        self.process.wait()
        self.log.close()

    def solve_times(self) -> list[float]:
        text = self.log_path.read_text()
        return [float(m) for m in re.findall(r"solve \d+ \([^)]*\):.*?([0-9.]+) ms", text)]


def send(path: Path, *args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    command = [str(tool("pgem-lcm-send")), str(path), "--quiet", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)


def percentile(values: list[float], q: float) -> float:
    """Nearest rank: the smallest value with at least q % of the values at or below it."""
    ordered = sorted(values)
    rank = math.ceil(q / 100.0 * len(ordered))
    return ordered[min(len(ordered), max(1, rank)) - 1]


def fresh_log(path: Path) -> Path:
    if path.exists():
        path.unlink()
    return path


def latency_samples(csv: Path) -> tuple[list[tuple], int, dict[int, float]]:
    """(latency ms, sequence, from, to, solve id) of the loop closures seen, how many were sent,
    and by sequence the seconds from the end of the sender's last pause to each send."""
    samples = []
    sent = 0
    since = {}
    for line in csv.read_text().splitlines()[1:]:
        fields = line.split(",")
        sent += 1
        if len(fields) >= 5 and fields[3] != "":
            samples.append((float(fields[3]), int(fields[0]), int(fields[1]), int(fields[2]),
                            int(fields[4])))
        if len(fields) >= 6 and fields[5] != "":
            since[int(fields[0])] = float(fields[5])
    return samples, sent, since


def streamed(work: Path, name: str, phase: str, corrupted: Path, rate: float,
             bridge_args: list[str], sender_args: list[str], extra_seconds: float = 0.0):
    """The file streamed at `rate` into a fresh bridge, every loop closure's latency measured:
    (samples, sent, since pause, the sender's stdout, the bridge)."""
    bridge = Bridge(fresh_log(work / f"{name}.{phase}.bridge.log"), extra=bridge_args)
    csv = work / f"{name}.{phase}.csv"
    edges = count_edges(corrupted)
    result = send(corrupted, "--rate", str(rate), *sender_args, "--latency", str(csv),
                  "--wait", "120", timeout=edges / rate + extra_seconds + 300)
    bridge.stop()
    if result.returncode != 0:
        raise BenchError(f"{name}: {phase} run failed:\n{result.stdout}{result.stderr}")
    samples, sent, since = latency_samples(csv)
    if not samples:
        raise BenchError(f"{name}: no latency samples in {csv}")
    return samples, sent, since, result.stdout, bridge


def latency_run(work: Path, name: str, corrupted: Path, rate: float,
                bridge_args: list[str]) -> dict:
    samples, sent, _, stdout, bridge = streamed(work, name, "latency", corrupted, rate,
                                                bridge_args, [])
    summary = re.search(r"^latency: .*$", stdout, re.MULTILINE)
    values = [sample[0] for sample in samples]
    solves = bridge.solve_times()
    return {
        "rate": rate,
        "loops": len(samples),
        "sent": sent,
        "sender": summary.group(0) if summary else "(no latency line from the sender)",
        "median": percentile(values, 50),
        "p90": percentile(values, 90),
        "p99": percentile(values, 99),
        "max": max(values),
        "worst": max(samples),
        "solves": len(solves),
        "solve_median": statistics.median(solves) if solves else float("nan"),
        "solve_max": max(solves) if solves else float("nan"),
    }


def pause_run(work: Path, name: str, corrupted: Path, rate: float, pauses: int,
              seconds: float, bridge_args: list[str]) -> dict:
    """The stream with the sender silent `pauses` times (pgem-lcm-send --pause-every)."""
    every_n = max(1, count_edges(corrupted) // (pauses + 1))
    samples, sent, since, _, bridge = streamed(
        work, name, "pause", corrupted, rate, bridge_args,
        ["--pause-every", str(every_n), "--pause", str(seconds)], pauses * seconds)
    log = bridge.log_path.read_text()
    values = [sample[0] for sample in samples]
    late = [sample[0] for sample in samples if since.get(sample[1], 1e9) < 2.0]
    return {
        "rate": rate, "pauses": pauses, "seconds": seconds, "loops": len(samples), "sent": sent,
        "after_loops": len(late),
        "after_median": percentile(late, 50) if late else float("nan"),
        "after_p99": percentile(late, 99) if late else float("nan"),
        "after_max": max(late) if late else float("nan"),
        "median": percentile(values, 50), "p99": percentile(values, 99), "max": max(values),
        "settles": len(re.findall(r"solve \d+ \(settle", log)),
        "gave_way": log.count("settle gave way"),
    }


def lossy_copy(source: Path, out: Path, loss: float, seed: int) -> int:
    """`source` without a share `loss` of its odometry edges (the first edge between ids i and
    i + 1), chosen with `seed`: the parts UDP loss leaves. Returns the edges dropped."""
    rng = random.Random(seed)
    dropped = 0
    with source.open() as handle, out.open("w") as written:
        for line in handle:
            fields = line.split()
            if (fields and fields[0].startswith("EDGE") and len(fields) > 2 and
                    fields[2].lstrip("-").isdigit() and int(fields[2]) == int(fields[1]) + 1 and
                    rng.random() < loss):
                dropped += 1
                continue
            written.write(line)
    return dropped


def loop_states(weights: Path, outliers: Path) -> tuple[int, int, int, int]:
    """(true loops pruned, true loops, false loops accepted, false loops) in a weights file
    ('from to weight state' lines) against the false loops `pgem corrupt` listed."""
    false = set()
    for line in outliers.read_text().splitlines():
        fields = line.split()
        if len(fields) >= 2:
            false.add((int(fields[0]), int(fields[1])))
            false.add((int(fields[1]), int(fields[0])))
    counts = [0, 0, 0, 0]
    for line in weights.read_text().splitlines():
        fields = line.split()
        if len(fields) < 4 or line.startswith("#"):
            continue
        accepted = fields[3] == "accepted"
        if (int(fields[0]), int(fields[1])) in false:
            counts[2] += accepted
            counts[3] += 1
        else:
            counts[0] += not accepted
            counts[1] += 1
    return counts[0], counts[1], counts[2], counts[3]


def drain_run(work: Path, tag: str, path: Path, rate: float, outliers: Path) -> dict:
    """`path` sent at `rate` to a fresh bridge (no settle while it streams): seconds until the
    status shows every edge taken and nothing queued, the whole-graph solves meanwhile, and
    the loop verdicts of the last graph published then."""
    bridge = Bridge(fresh_log(work / f"{tag}.bridge.log"), extra=["--idle-solve", "60"])
    weights = work / f"{tag}.weights"
    weights.unlink(missing_ok=True)
    dump = subprocess.Popen([str(tool("pgem-lcm-dump")), "--weights", str(weights), "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(0.3)
    poses = sum(1 for line in path.open() if line.startswith("VERTEX"))
    started = time.monotonic()
    result = send(path, "--rate", str(rate), "--wait", "600",
                  timeout=count_edges(path) / rate + 900)
    drained = time.monotonic() - started
    time.sleep(0.5)
    at_drain = loop_states(weights, outliers)
    # then until a live EM pass has seen every pose (loops decided by the gate alone while
    # the stream outran the passes get their whole-graph verdicts), at most two minutes
    covered = re.compile(rf"live EM pass \d+: EM on {poses} poses")
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not covered.search(bridge.log_path.read_text()):
        time.sleep(0.2)
    decided = time.monotonic() - started if covered.search(bridge.log_path.read_text()) else math.nan
    time.sleep(0.5)
    dump.send_signal(2)
    dump.wait(timeout=30)
    bridge.stop()
    if result.returncode != 0:
        raise BenchError(f"{tag}: the bridge did not take the stream:\n{result.stdout}{result.stderr}")
    log = bridge.log_path.read_text()
    solves = re.findall(r"solve \d+ \(([^)]*)\)", log)
    whole = [s for s in solves if "incremental" not in s]
    pruned, true, accepted, false = loop_states(weights, outliers)
    return {"rate": rate, "drained": drained, "decided": decided, "whole_solves": len(whole),
            "solves": len(solves), "true_pruned_at_drain": at_drain[0],
            "false_accepted_at_drain": at_drain[2], "true_pruned": pruned, "true_loops": true,
            "false_accepted": accepted, "false_loops": false}


def split_run(work: Path, name: str, corrupted: Path, rate: float, loss: float,
              burst: float) -> dict:
    """The lossy copy paced and as a burst, and the whole file paced (the verdicts without loss)."""
    lossy = work / f"{name}.lossy.g2o"
    dropped = lossy_copy(corrupted, lossy, loss, 1)
    outliers = corrupted.with_name(corrupted.name + ".outliers")
    return {"loss": loss, "dropped": dropped,
            "whole": drain_run(work, f"{name}.split.whole", corrupted, rate, outliers),
            "paced": drain_run(work, f"{name}.split.paced", lossy, rate, outliers),
            "burst": drain_run(work, f"{name}.split.burst", lossy, burst, outliers)}


def island_run(work: Path, name: str, corrupted: Path, rate: float, bridge_args: list[str]) -> dict:
    """Loop-closure latency without and with a stray sender's island a quarter in."""
    plain = latency_run(work, name, corrupted, rate, bridge_args)
    island = work / f"{name}.island.g2o"
    island.write_text("VERTEX_SE2 900000001 -5000 -5000 0\nVERTEX_SE2 900000002 -4999 -5000 0\n"
                      "EDGE_SE2 900000001 900000002 1 0 0 100 0 0 100 0 100\n")
    delay = count_edges(corrupted) / rate / 4.0
    stray = subprocess.Popen(["sh", "-c", f"sleep {delay:.3f} && exec {tool('pgem-lcm-send')} "
                              f"{island} --source stray --quiet"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    samples, sent, _, _, bridge = streamed(work, name, "island", corrupted, rate, bridge_args, [])
    stray.wait(timeout=60)
    log = bridge.log_path.read_text()
    solves = re.findall(r"solve \d+ \(([^)]*)\)", log)
    values = [sample[0] for sample in samples]
    return {"rate": rate, "plain_median": plain["median"], "plain_p99": plain["p99"],
            "island_median": percentile(values, 50), "island_p99": percentile(values, 99),
            "loops": len(samples), "sent": sent,
            "whole_solves": len([s for s in solves if "incremental" not in s and "settle" not in s])}


def split_lines(run: dict) -> list[str]:
    rows = []
    for key, what in (("whole", "whole file, paced"), ("paced", "lossy, paced"),
                      ("burst", "lossy, burst")):
        r = run[key]
        rows.append(f"| {what} | {r['rate']:g} | {r['drained']:.1f} s | {r['whole_solves']} of "
                    f"{r['solves']} | {r['true_pruned_at_drain']} / {r['false_accepted_at_drain']} | "
                    f"{r['decided']:.1f} s | {r['true_pruned']} of {r['true_loops']} | "
                    f"{r['false_accepted']} of {r['false_loops']} |")
    ratio = run["burst"]["drained"] / run["paced"]["drained"]
    return [f"Split: {run['dropped']} odometry edges dropped ({100 * run['loss']:g} %, seed 1); "
            f"the burst drains in {ratio:.2f}x the paced send's time (target at most 1.5x).", "",
            "| stream | edges/s | taken, nothing queued | whole-graph solves | true pruned / false "
            "accepted then | a pass saw every pose | true loops pruned then | false loops "
            "accepted |", "|---|---|---|---|---|---|---|---|", *rows, ""]


def island_lines(run: dict) -> list[str]:
    change = run["island_median"] / run["plain_median"] - 1.0
    return [f"Island: a stray sender's two poses and edge a quarter into the stream at "
            f"{run['rate']:g} edges/s: loop-closure latency median {run['plain_median']:.1f} ms "
            f"without, {run['island_median']:.1f} ms with ({100 * change:+.0f} %, target at most "
            f"+10 %); p99 {run['plain_p99']:.1f} / {run['island_p99']:.1f} ms; whole-graph solves "
            f"while streaming with it: {run['whole_solves']}.", ""]


def accepted_edges(output: str) -> int:
    match = re.search(r"accepted \d+ poses, (\d+) edges", output)
    return int(match.group(1)) if match else -1


def ingest_run(work: Path, name: str, corrupted: Path, rates: list[float]) -> list[dict]:
    edges = count_edges(corrupted)
    rows = []
    for rate in rates:
        bridge = Bridge(fresh_log(work / f"{name}.ingest.{int(rate)}.bridge.log"))
        started = time.monotonic()
        result = send(corrupted, "--rate", str(rate), "--wait", "30")
        elapsed = time.monotonic() - started
        bridge.stop()
        got = accepted_edges(result.stdout + result.stderr)
        rows.append({"rate": rate, "sent": edges, "accepted": got, "ok": got == edges,
                     "seconds": elapsed})
    return rows


def recovery_run(work: Path, name: str, corrupted: Path, kills: int, rate: float,
                 seed: int) -> dict:
    offline_g2o = work / f"{name}.offline.g2o"
    offline_weights = work / f"{name}.offline.weights"
    subprocess.run([str(tool("pgem")), "optimize", str(corrupted), "--robust", "em", "--weights",
                    str(offline_weights), "-o", str(offline_g2o), "--quiet"], check=True,
                   capture_output=True)
    journal = work / f"{name}.journal.lcmlog"
    if journal.exists():
        journal.unlink()
    log = work / f"{name}.recovery.bridge.log"
    if log.exists():
        log.unlink()
    edges = count_edges(corrupted)
    stream_seconds = edges / rate
    rng = random.Random(seed)
    moments = sorted(rng.uniform(0.1, 0.9) * stream_seconds for _ in range(kills))
    bridge = Bridge(log, journal)
    if bridge.replayed[0] != 0:
        raise BenchError(f"{journal} was not empty at the start")
    sender = subprocess.Popen([str(tool("pgem-lcm-send")), str(corrupted), "--quiet", "--rate",
                               str(rate)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
    started = time.monotonic()
    replayed = []
    for moment in moments:
        time.sleep(max(0.0, moment - (time.monotonic() - started)))
        bridge.kill()
        bridge = Bridge(log, journal)
        replayed.append(bridge.replayed)
    sender.communicate(timeout=600)
    dump_g2o = work / f"{name}.recovered.g2o"
    dump_weights = work / f"{name}.recovered.weights"
    dump = subprocess.Popen([str(tool("pgem-lcm-dump")), "-o", str(dump_g2o), "--weights",
                             str(dump_weights), "--edges", str(edges), "--timeout", "180",
                             "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    time.sleep(0.3)
    resend = send(corrupted, "--rate", str(rate * 4), "--wait", "120")
    dumped, _ = dump.communicate(timeout=200)
    bridge.stop()
    if dump.returncode != 0:
        raise BenchError(f"{name}: pgem-lcm-dump failed after the resend:\n{dumped}"
                         f"{resend.stdout}{resend.stderr}")
    compare = subprocess.run([str(tool("lcm_compare")), str(dump_g2o), str(offline_g2o), "1e-6",
                              str(dump_weights), str(offline_weights)], capture_output=True,
                             text=True)
    return {"kills": kills, "edges": edges, "replayed": replayed,
            "resend": resend.stdout.strip().splitlines()[-1:] if resend.stdout else [],
            "agree": compare.returncode == 0, "compare": compare.stdout.strip()}


def latency_lines(lat: dict) -> list[str]:
    return [f"Latency, each loop closure's send to the first graph including it, over "
            f"{lat['loops']} of {lat['sent']} loop closures (seen of sent) streamed at "
            f"{lat['rate']:g} edges/s:", "",
            "| median | p90 | p99 | max | solves | solve median | solve max |",
            "|---|---|---|---|---|---|---|",
            f"| {lat['median']:.1f} ms | {lat['p90']:.1f} ms | {lat['p99']:.1f} ms | "
            f"{lat['max']:.1f} ms | {lat['solves']} | {lat['solve_median']:.1f} ms | "
            f"{lat['solve_max']:.1f} ms |", "",
            f"Slowest: sequence {lat['worst'][1]} ({lat['worst'][2]} -> "
            f"{lat['worst'][3]}), {lat['worst'][0]:.1f} ms, in solve "
            f"{lat['worst'][4]}. The sender's line: `{lat['sender']}`", ""]


def pause_lines(run: dict) -> list[str]:
    return [f"Pauses: the stream at {run['rate']:g} edges/s, the sender silent {run['pauses']} "
            f"times for {run['seconds']:g} s; the bridge ran "
            f"{run['settles']} settle solves to the end and {run['gave_way']} that gave way to "
            f"arriving items. Latency of the {run['after_loops']} loop closures sent in the first 2 s "
            f"after a pause, and of all {run['loops']} (seen of {run['sent']} sent):", "",
            "| loops | median | p99 | max |", "|---|---|---|---|",
            f"| after a pause | {run['after_median']:.1f} ms | {run['after_p99']:.1f} ms | "
            f"{run['after_max']:.1f} ms |",
            f"| all | {run['median']:.1f} ms | {run['p99']:.1f} ms | {run['max']:.1f} ms |", ""]


def ingest_lines(ingest: list[dict]) -> list[str]:
    lines = ["Sustained ingest (every edge accepted?):", "",
             "| rate (edges/s) | sent | accepted | zero loss |", "|---|---|---|---|"]
    lines += [f"| {row['rate']:g} | {row['sent']} | {row['accepted']} | "
              f"{'yes' if row['ok'] else 'no'} |" for row in ingest]
    passing = [row["rate"] for row in ingest if row["ok"]]
    return lines + ["", f"Highest zero-loss rate tried: {max(passing):g} edges/s."
                    if passing else "No rate passed.", ""]


def recovery_lines(rec: dict, kill_rate: float) -> list[str]:
    return [f"Recovery: {rec['kills']} SIGKILLs while streaming at "
            f"{kill_rate:g} edges/s, each followed by a restart on the journal "
            "(records, poses, edges replayed): " +
            ", ".join(f"{r[0]}/{r[1]}/{r[2]}" for r in rec["replayed"]) +
            f". After a full resend the dumped graph "
            f"{'agrees with' if rec['agree'] else 'DIFFERS from'} the offline solve:",
            "", "```", rec["compare"], "```", ""]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--datasets", type=Path, default=DEFAULT_DATASETS)
    parser.add_argument("--files", default="input_M3500_g2o:100,city10000:200",
                        help="NAME:RATE,... datasets and their streaming rate in edges/s")
    parser.add_argument("--outliers", type=int, default=100, help="false loops added")
    parser.add_argument("--ingest-rates", default="2000,5000,10000,20000,50000")
    parser.add_argument("--kills", type=int, default=5)
    parser.add_argument("--kill-rate", type=float, default=1000.0)
    parser.add_argument("--pauses", type=int, default=4,
                        help="pause phase: silent spells in the stream (default 4)")
    parser.add_argument("--pause-seconds", type=float, default=1.0,
                        help="pause phase: length of each (default 1.0 s)")
    parser.add_argument("--loss", type=float, default=0.01,
                        help="split phase: share of odometry edges lost (default 0.01)")
    parser.add_argument("--burst", type=float, default=20000.0,
                        help="split phase: the burst's rate in edges/s (default 20000)")
    parser.add_argument("--quick", action="store_true",
                        help="M3500 only, streamed at 500 edges/s, 3 kills")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--json", type=Path, help="also write the figures as JSON (one entry per dataset)")
    parser.add_argument("--phases", default=",".join(PHASES),
                        help=f"comma-separated phases to run (default {','.join(PHASES)})")
    parser.add_argument("--bridge-args", default="",
                        help="extra pgem-lcm-bridge options for the latency and pause phases, e.g. "
                             "--bridge-args=--full (space-separated)")
    parser.add_argument("--build", type=Path, default=DEFAULT_BUILD,
                        help="build directory with the tools (default build/release)")
    args = parser.parse_args()
    phases = [phase.strip() for phase in args.phases.split(",") if phase.strip()]
    unknown = [phase for phase in phases if phase not in PHASES]
    if unknown or not phases:
        parser.error(f"--phases takes some of {','.join(PHASES)} (got '{args.phases}')")
    global BUILD
    BUILD = build_dir(args.build)
    try:
        enter_namespace()
        work = args.out.parent / "lcm_work"
        work.mkdir(parents=True, exist_ok=True)
        files = [entry.split(":") for entry in args.files.split(",")]
        if args.quick:
            files = [["input_M3500_g2o", "500"]]
            args.kills = 3
        bridge = f"`pgem-lcm-bridge {args.bridge_args}`" if args.bridge_args.strip() \
            else "the bridge's defaults"
        lines = ["# LCM bridge benchmark", "",
                 f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} cores, URL `{URL}`, "
                 f"{args.outliers} random false loop closures (seed 1), latency with {bridge}.",
                 ""]
        figures = []
        for name, rate in files:
            source = dataset(args.datasets, name)
            corrupted = work / f"{name}.corrupted.g2o"
            subprocess.run([str(tool("pgem")), "corrupt", str(source), "-o", str(corrupted),
                            "--policy", "random", "--count", str(args.outliers), "--seed", "1"],
                           check=True, capture_output=True)
            lines += [f"## {name}", ""]
            found = {"name": name, "rate": float(rate)}
            if "latency" in phases:
                print(f"== {name}: latency at {rate} edges/s", flush=True)
                found["latency"] = latency_run(work, name, corrupted, float(rate),
                                               args.bridge_args.split())
                lines += latency_lines(found["latency"])
            if "pause" in phases:
                print(f"== {name}: {args.pauses} pauses of {args.pause_seconds:g} s", flush=True)
                found["pause"] = pause_run(work, name, corrupted, float(rate), args.pauses,
                                           args.pause_seconds, args.bridge_args.split())
                lines += pause_lines(found["pause"])
            if "split" in phases:
                print(f"== {name}: split by lost odometry, paced and as a burst", flush=True)
                found["split"] = split_run(work, name, corrupted, float(rate), args.loss,
                                           args.burst)
                lines += split_lines(found["split"])
            if "island" in phases:
                print(f"== {name}: a stray sender's island", flush=True)
                found["island"] = island_run(work, name, corrupted, float(rate),
                                             args.bridge_args.split())
                lines += island_lines(found["island"])
            if "ingest" in phases:
                print(f"== {name}: sustained ingest", flush=True)
                found["ingest"] = ingest_run(work, name, corrupted,
                                             [float(r) for r in args.ingest_rates.split(",")])
                lines += ingest_lines(found["ingest"])
            if "recovery" in phases:
                print(f"== {name}: {args.kills} SIGKILLs and restarts", flush=True)
                found["recovery"] = recovery_run(work, name, corrupted, args.kills, args.kill_rate, 1)
                lines += recovery_lines(found["recovery"], args.kill_rate)
            figures.append(found)
        report = "\n".join(lines)
        print(report)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(report + "\n")
        if args.json is not None:
            args.json.write_text(json.dumps(figures, indent=1) + "\n")
        return 0
    except (BenchError, subprocess.CalledProcessError, subprocess.TimeoutExpired) as error:
        print(f"bench_lcm: {error}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
