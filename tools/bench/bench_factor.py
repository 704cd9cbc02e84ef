#!/usr/bin/env python3
"""Factorisation benchmark: pgem's sparse Cholesky beside CHOLMOD's on the same Newton matrix,
and beside GTSAM's Gauss-Newton iteration, on the shared datasets and on simulated graphs of
1000, 10000 and 100000 poses (2D and 3D, ``pgem simulate``).

Per graph, interleaved (pgem, CHOLMOD, GTSAM, pgem, ...), ``--runs`` times:

* ``pgem-bench-factor pgem FILE`` (tools/bench/bench_factor.c): pgem's symbolic analysis, one
  numeric factorisation and one Gauss-Newton iteration, each the median of ``--repeat`` in
  the process, one thread; its factor's nonzeros and flops; the block's bytes. The first run
  also writes the Newton matrix H at the file's estimate (built from pgem's public geometry).
* ``pgem-bench-factor cholmod H``: CHOLMOD (Debian's libcholmod, default settings: its own
  choice of AMD or METIS and of simplicial or supernodal) analysing and factorising that H, with
  a serial BLAS: OpenBLAS's serial build when installed (Debian ``libopenblas0-serial``,
  loaded through LD_LIBRARY_PATH, OPENBLAS_NUM_THREADS=1), else the system's libblas; the
  report names the library the process mapped. Its nonzeros, flops and peak resident set.
* a GTSAM worker (this script, ``--gtsam-worker``): one ``GaussNewtonOptimizer`` iteration from
  the file's estimate (construction, linearisation, ordering, elimination, update), for graphs
  of at most ``--gtsam-max-poses`` poses.
* ``pgem optimize FILE -o OUT --threads 1`` as a whole process (wall time from the start of the
  process to its end) beside its own solve time, for graphs of at most ``--whole-max-poses``.

Flops are the sum over the factor's columns of their squared nonzero counts (CHOLMOD's measure
of an ordering; about twice the multiply-adds), computed the same way for both from the exact
pattern of L (pgem's explicit zeros of relaxed supernodes left out).

Output: a Markdown report on stdout and in ``--out``, every run's raw JSON beside it.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_gn  # noqa: E402  (g2o parsing, GTSAM helpers, machine line)

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_BUILD = REPO_ROOT / "build" / "release"
DEFAULT_OUT = REPO_ROOT / "build" / "bench" / "bench_factor.md"
SHARED = ("input_M3500_g2o", "city10000", "sphere2500")
WORLDS = ("manhattan", "sphere", "grid3d")
SIZES = (1000, 10000, 100000)
# The table: the sphere world's sizes are squares of its rings (about sqrt(N) poses per
# ring), so its 1k and 100k graphs have 1024 and 99856 poses.
SPHERE_POSES = {1000: 1024, 10000: 10000, 100000: 99856}
OPENBLAS_SERIAL = Path("/usr/lib/x86_64-linux-gnu/openblas-serial")


def progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# --------------------------------------------------------------------------------------
# The GTSAM worker: one Gauss-Newton iteration
# --------------------------------------------------------------------------------------


def gtsam_iteration_worker(path: Path) -> dict[str, Any]:
    """One GTSAM Gauss-Newton iteration on a file, timed from the optimizer's construction."""
    import gtsam

    parsed = bench_gn.parse_g2o(path)
    graph, initial = gtsam.readG2o(str(path), parsed.is_3d)
    bench_gn.add_gauge_priors(gtsam, graph, initial, parsed.fixed_ids or parsed.vertex_ids[:1],
                              parsed.is_3d)
    params = gtsam.GaussNewtonParams()
    params.setMaxIterations(1)
    bench_gn.reset_peak_rss()
    rss_before = bench_gn.proc_status_bytes("VmRSS")
    start = time.perf_counter()
    optimizer = gtsam.GaussNewtonOptimizer(graph, initial, params)
    optimizer.optimize()
    seconds = time.perf_counter() - start
    return {"iteration_seconds": seconds, "iterations": int(optimizer.iterations()),
            "peak_rss_growth": bench_gn.proc_status_bytes("VmHWM") - rss_before}


# --------------------------------------------------------------------------------------
# Running one graph
# --------------------------------------------------------------------------------------


def run_json(command: list[str], env: dict[str, str] | None, timeout: float) -> dict[str, Any]:
    """Runs a command that prints one JSON object; {'error': ...} on failure or timeout."""
    try:
        proc = subprocess.run(command, capture_output=True, text=True, env=env, timeout=timeout,
                              check=False)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    if proc.returncode != 0:
        return {"error": (proc.stderr.strip() or proc.stdout.strip() or f"exit {proc.returncode}")[:300]}
    try:
        return json.loads(proc.stdout.strip().splitlines()[-1])
    except (json.JSONDecodeError, IndexError):
        return {"error": f"no JSON in: {proc.stdout[:200]}"}


def cholmod_env(blas: str) -> dict[str, str]:
    env = dict(os.environ)
    env["OPENBLAS_NUM_THREADS"] = "1"
    env["OMP_NUM_THREADS"] = "1"
    if blas == "openblas" and OPENBLAS_SERIAL.is_dir():
        env["LD_LIBRARY_PATH"] = str(OPENBLAS_SERIAL) + os.pathsep + env.get("LD_LIBRARY_PATH", "")
    return env


def whole_process(pgem: Path, path: Path, out: Path, timeout: float) -> dict[str, Any]:
    """pgem optimize as a whole process: wall seconds beside its own solve_seconds."""
    command = [str(pgem), "optimize", str(path), "-o", str(out), "--quiet", "--json",
               "--threads", "1"]
    start = time.perf_counter()
    summary = run_json(command, None, timeout)
    summary["whole_seconds"] = time.perf_counter() - start
    return summary


def bench_graph(args: argparse.Namespace, name: str, path: Path, poses: int) -> dict[str, Any]:
    matrix = args.work / f"{name}.H"
    result: dict[str, Any] = {"name": name, "path": str(path), "poses": poses, "pgem": [],
                              "cholmod": [], "gtsam": [], "whole": []}
    repeat = 1 if poses > 50000 else args.repeat
    for run in range(args.runs):
        command = [str(args.bench_program), "pgem", str(path), "--repeat", str(repeat), "--threads", "1"]
        if run == 0:
            command += ["--matrix", str(matrix)]
        progress(f"  {name}: pgem run {run + 1}/{args.runs}")
        result["pgem"].append(run_json(command, None, args.timeout))
        if matrix.exists():
            progress(f"  {name}: CHOLMOD run {run + 1}/{args.runs}")
            result["cholmod"].append(run_json(
                [str(args.bench_program), "cholmod", str(matrix), "--repeat", str(repeat)],
                cholmod_env(args.blas), args.timeout))
        if args.peer == "gtsam" and poses <= args.gtsam_max_poses:
            progress(f"  {name}: GTSAM run {run + 1}/{args.runs}")
            result["gtsam"].append(run_json(
                [sys.executable, str(Path(__file__).resolve()), "--gtsam-worker", str(path)],
                None, args.timeout))
        if poses <= args.whole_max_poses:
            progress(f"  {name}: pgem optimize run {run + 1}/{args.runs}")
            result["whole"].append(whole_process(args.pgem, path, args.work / f"{name}.out.g2o",
                                                 args.timeout))
    if matrix.exists() and not args.keep_matrices:
        matrix.unlink()
    return result


# --------------------------------------------------------------------------------------
# Report
# --------------------------------------------------------------------------------------


def ok(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [r for r in runs if "error" not in r]


def med(runs: list[dict[str, Any]], key: str) -> float | None:
    values = [r[key] for r in ok(runs) if key in r]
    return statistics.median(values) if values else None


def spread(runs: list[dict[str, Any]], key: str) -> str:
    values = [r[key] for r in ok(runs) if key in r]
    if len(values) < 2:
        return "-"
    m = statistics.median(values)
    return f"{100.0 * (max(values) - min(values)) / m:.0f}%" if m > 0 else "-"


def seconds(value: float | None) -> str:
    if value is None:
        return "-"
    if value >= 1.0:
        return f"{value:.2f} s"
    return f"{value * 1e3:.3g} ms"


def ratio(a: float | None, b: float | None) -> str:
    return f"{a / b:.2f}x" if a is not None and b else "-"


def count(value: float | None) -> str:
    if value is None:
        return "-"
    for unit, scale in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if value >= scale:
            return f"{value / scale:.3g}{unit}"
    return f"{value:.0f}"


def mib(value: float | None) -> str:
    return f"{value / 2**20:.1f} MiB" if value is not None else "-"


def first(runs: list[dict[str, Any]], key: str) -> Any:
    for r in ok(runs):
        if key in r:
            return r[key]
    return None


def render(results: list[dict[str, Any]], header: str, blas: str) -> str:
    lines = ["# Factorisation: pgem beside CHOLMOD and GTSAM", "", header, "",
             f"CHOLMOD's BLAS: {blas}. One thread each. Times are medians of the interleaved runs "
             "(each run the median of its in-process repeats); 'spread' is (max - min) / median "
             "over the runs.", "",
             "| graph | poses | factor nonzeros pgem / CHOLMOD | flops pgem / CHOLMOD | ordering "
             "pgem / CHOLMOD | analysis pgem / CHOLMOD | factorisation pgem / CHOLMOD | "
             "CHOLMOD/pgem | GN iteration pgem / GTSAM | GTSAM/pgem | whole process / solve | "
             "pgem block | CHOLMOD peak RSS growth | GTSAM peak RSS growth |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        p, c, g, w = r["pgem"], r["cholmod"], r["gtsam"], r["whole"]
        pf, cf = med(p, "factor_seconds"), med(c, "factor_seconds")
        pi, gi = med(p, "iteration_seconds"), med(g, "iteration_seconds")
        whole = med(w, "whole_seconds")
        solve = med(w, "solve_seconds")
        growth = None
        if ok(c):
            growth = statistics.median(x["peak_rss_bytes"] - x["rss_before_bytes"] for x in ok(c))
        lines.append(
            f"| {r['name']} | {r['poses']} | {count(first(p, 'exact_nonzeros'))} "
            f"({count(first(p, 'factor_nonzeros'))} stored) / {count(first(c, 'factor_nonzeros'))} "
            f"| {count(first(p, 'flops'))} / {count(first(c, 'flops'))} "
            f"| {first(p, 'ordering') or '-'} / {first(c, 'ordering') or '-'}"
            f"{' (supernodal)' if first(c, 'supernodal') else ' (simplicial)' if ok(c) else ''} "
            f"| {seconds(med(p, 'analysis_seconds'))} / {seconds(med(c, 'analysis_seconds'))} "
            f"| {seconds(pf)} / {seconds(cf)} | {ratio(cf, pf)} "
            f"| {seconds(pi)} / {seconds(gi)} | {ratio(gi, pi)} "
            f"| {seconds(whole)} / {seconds(solve)} = {ratio(whole, solve)} "
            f"| {mib(first(p, 'block_bytes'))} | {mib(growth)} "
            f"| {mib(med(g, 'peak_rss_growth'))} |")
    lines += ["", "## Spread", "",
              "| graph | pgem factorisation | CHOLMOD factorisation | pgem iteration | GTSAM "
              "iteration | whole process |", "|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r['name']} | {spread(r['pgem'], 'factor_seconds')} | "
                     f"{spread(r['cholmod'], 'factor_seconds')} | "
                     f"{spread(r['pgem'], 'iteration_seconds')} | "
                     f"{spread(r['gtsam'], 'iteration_seconds')} | "
                     f"{spread(r['whole'], 'whole_seconds')} |")
    failures = [f"- {r['name']} {side}: {x['error']}" for r in results
                for side in ("pgem", "cholmod", "gtsam", "whole") for x in r[side] if "error" in x]
    lines += ["", "## Targets", ""]
    for r in results:
        pf, cf = med(r["pgem"], "factor_seconds"), med(r["cholmod"], "factor_seconds")
        if pf and cf:
            verdict = "met" if cf / pf >= 1.5 else "missed"
            lines.append(f"- {r['name']}: factorisation {cf / pf:.2f}x CHOLMOD's speed "
                         f"(target 1.5x): {verdict}")
        whole, solve = med(r["whole"], "whole_seconds"), med(r["whole"], "solve_seconds")
        if whole and solve and r["name"] in ("input_M3500_g2o", "city10000"):
            verdict = "met" if whole / solve <= 1.3 else "missed"
            lines.append(f"- {r['name']}: whole process {whole / solve:.2f}x the solve (target "
                         f"at most 1.3x): {verdict}")
    if failures:
        lines += ["", "## Failures and timeouts", "", *failures]
    return "\n".join(lines) + "\n"


def blas_name(results: list[dict[str, Any]]) -> str:
    for r in results:
        for c in ok(r["cholmod"]):
            if c.get("blas"):
                return c["blas"]
    return "unknown"


# --------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------


def simulated(args: argparse.Namespace) -> list[tuple[str, Path, int]]:
    graphs = []
    for size in args.sizes:
        for world in args.worlds:
            poses = SPHERE_POSES.get(size, size) if world == "sphere" else size
            name = f"{world}{poses}"
            path = args.work / f"{name}.g2o"
            if not path.exists():
                progress(f"simulating {name}")
                subprocess.run([str(args.pgem), "simulate", "--world", world, "--poses", str(poses),
                                "--seed", "1", "-o", str(path)], check=True, capture_output=True)
            graphs.append((name, path, poses))
    return graphs


def shared(args: argparse.Namespace) -> list[tuple[str, Path, int]]:
    graphs = []
    for name in args.files:
        for sub in ("2d", "3d"):
            path = args.datasets / sub / f"{name}.g2o"
            if path.exists():
                poses = sum(1 for line in open(path, encoding="ascii", errors="replace")
                            if line.startswith("VERTEX"))
                graphs.append((name, path, poses))
                break
        else:
            progress(f"skipping {name}: not found in {args.datasets}")
    return graphs


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3, help="interleaved runs per graph (3)")
    parser.add_argument("--repeat", type=int, default=3,
                        help="repeats inside each run (3; 1 for graphs of more than 50000 poses)")
    parser.add_argument("--sizes", default=",".join(map(str, SIZES)),
                        help="simulated graph sizes (1000,10000,100000; '' for none)")
    parser.add_argument("--worlds", default=",".join(WORLDS), help="simulated worlds")
    parser.add_argument("--files", default=",".join(SHARED), help="shared datasets ('' for none)")
    parser.add_argument("--datasets", type=Path, default=REPO_ROOT.parent / "shared" / "datasets")
    parser.add_argument("--pgem", type=Path, default=DEFAULT_BUILD / "tools" / "pgem" / "pgem")
    parser.add_argument("--bench-program", type=Path,
                        default=DEFAULT_BUILD / "tools" / "bench" / "pgem-bench-factor")
    parser.add_argument("--blas", choices=("openblas", "system"), default="openblas",
                        help="CHOLMOD's BLAS: Debian's serial OpenBLAS when installed (default) "
                             "or the system's libblas")
    parser.add_argument("--peer", choices=("gtsam", "none"), default="gtsam",
                        help="run the GTSAM iteration worker (default) or not")
    parser.add_argument("--gtsam-max-poses", type=int, default=100000,
                        help="GTSAM only on graphs of at most this many poses")
    parser.add_argument("--whole-max-poses", type=int, default=20000,
                        help="time pgem optimize as a whole process on graphs of at most this many poses")
    parser.add_argument("--timeout", type=float, default=900.0, help="per process (900 s)")
    parser.add_argument("--work", type=Path, default=DEFAULT_OUT.parent / "factor_work")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--keep-matrices", action="store_true", help="keep the H files")
    parser.add_argument("--quick", action="store_true",
                        help="1 run; the 1000-pose graphs and input_M3500_g2o")
    parser.add_argument("--gtsam-worker", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.quick:
        args.runs = 1
        args.sizes, args.files = "1000", "input_M3500_g2o"
    args.sizes = [int(x) for x in args.sizes.split(",") if x]
    args.worlds = [x for x in args.worlds.split(",") if x]
    args.files = [x for x in args.files.split(",") if x]
    return args


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    if args.gtsam_worker is not None:
        print(json.dumps(gtsam_iteration_worker(args.gtsam_worker)))
        return 0
    for program in (args.pgem, args.bench_program):
        if not program.exists():
            print(f"bench_factor: {program} not found (build the release preset; "
                  "pgem-bench-factor needs CHOLMOD's headers)", file=sys.stderr)
            return 1
    if args.peer == "gtsam":
        try:
            import gtsam  # noqa: F401
        except ImportError:
            print("bench_factor: gtsam is not installed (pip install gtsam numpy), or use "
                  "--peer none", file=sys.stderr)
            return 1
    args.work.mkdir(parents=True, exist_ok=True)
    graphs = shared(args) + simulated(args)
    results = []
    for name, path, poses in graphs:
        progress(f"{name} ({poses} poses)")
        results.append(bench_graph(args, name, path, poses))
    header = bench_gn.machine_line(args.pgem, f"{args.runs} interleaved run(s) per graph",
                                   gtsam=args.peer == "gtsam")
    report = render(results, header, blas_name(results))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    args.out.with_suffix(".json").write_text(json.dumps(results, indent=1))
    print(report)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
