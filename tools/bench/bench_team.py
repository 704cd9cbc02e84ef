#!/usr/bin/env python3
"""Simulated robot teams (issue 36): ``bench_team.py PGEM [--robots 2,4,8] [--seeds 1,2,3]
[--false 0,50] [--poses 2000] [--world manhattan|sphere|grid3d] [--gtsam] [--em-options OPTS]
[--out DIR]``.

Each cell is one ``pgem simulate --robots R --false-loops K`` world (the walk split across R
robots, each robot's odometry from its own origin, an unknown frame; ids r*1000000+i), solved
by ``pgem optimize --robust em`` and, with ``--gtsam``, by GTSAM's GNC-TLS from the same initial
guess (gtsam_worker.py). Printed per cell: EM's rounds, termination, the robots placed in the
frame their agreeing loops imply (``frames_placed``) and the parts held; the rejected
loops' precision and recall against the false ones (``pgem eval``); the ATE over the team and
the worst robot's, after one rigid alignment of the whole team on the truth (a robot placed in
the wrong frame shows as its own large error); the same for GNC-TLS. The table is Markdown.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gtsam_worker  # noqa: E402  (the GTSAM solves, each in its own process)

ROBOT_IDS = 1000000


def read_positions(path: Path) -> dict[int, np.ndarray]:
    """Pose id -> position (x, y[, z]) from a g2o file's vertex lines."""
    positions = {}
    for line in path.read_text().splitlines():
        fields = line.split()
        if fields and fields[0] == "VERTEX_SE2":
            positions[int(fields[1])] = np.array([float(fields[2]), float(fields[3])])
        elif fields and fields[0] == "VERTEX_SE3:QUAT":
            positions[int(fields[1])] = np.array([float(v) for v in fields[2:5]])
    return positions


def ate(result: Path, truth: Path) -> tuple[float, float]:
    """RMSE of the positions after one rigid alignment of the whole team (Kabsch), over the team
    and for the worst robot."""
    estimate, reference = read_positions(result), read_positions(truth)
    ids = sorted(set(estimate) & set(reference))
    a = np.array([estimate[i] for i in ids])
    b = np.array([reference[i] for i in ids])
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.eye(a.shape[1])
    d[-1, -1] = np.sign(np.linalg.det(u @ vt))
    rotation = (u @ d @ vt).T
    error = np.linalg.norm((a - ca) @ rotation.T + cb - b, axis=1)
    robots = np.array([i // ROBOT_IDS for i in ids])
    worst = max(float(np.sqrt(np.mean(error[robots == r] ** 2))) for r in set(robots.tolist()))
    return float(np.sqrt(np.mean(error ** 2))), worst


def run(command: list[str]) -> str:
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)}: {done.stderr.strip()}")
    return done.stdout


def score(pgem: str, result_dir: Path, graph: Path, outliers: Path | None) -> str:
    """Precision / recall of the rejected loops, or '-' without false loops."""
    if outliers is None:
        return "-"
    text = run([pgem, "eval", str(result_dir / "result.g2o"), "--reference", str(graph),
                "--outliers", str(outliers), "--weights", str(result_dir / "weights.txt"),
                "--json"])
    scores = json.loads(text)
    return f"{scores['precision']:.3f}/{scores['recall']:.3f}"


def cell(args: argparse.Namespace, robots: int, seed: int, false: int, out: Path) -> str:
    name = f"team_{args.world}_r{robots}_s{seed}_f{false}"
    graph, truth = out / f"{name}.g2o", out / f"{name}_truth.g2o"
    simulate = [args.pgem, "simulate", "-o", str(graph), "--truth", str(truth), "--poses",
                str(args.poses), "--seed", str(seed), "--robots", str(robots), "--world", args.world]
    if false > 0:
        simulate += ["--false-loops", str(false)]
    run(simulate)
    outliers = Path(f"{graph}.outliers") if false > 0 else None
    em_dir = out / f"{name}_em"
    em_dir.mkdir(exist_ok=True)
    summary = json.loads(run([args.pgem, "optimize", str(graph), "--robust", "em", "--quiet",
                              "--json", "-o", str(em_dir / "result.g2o"), "--weights",
                              str(em_dir / "weights.txt")] + args.em_options.split()))
    team, worst = ate(em_dir / "result.g2o", truth)
    row = (f"| {robots} | {seed} | {false} | {summary['rounds']} | "
           f"{summary.get('termination', 'converged')} | {summary.get('frames_placed', 0)} | "
           f"{summary.get('parts_held', 0)} | "
           f"{summary['rejected']}/{summary['loops']} | "
           f"{score(args.pgem, em_dir, graph, outliers)} | {team:.3f} | {worst:.3f} |")
    if args.gtsam:
        gnc_dir = out / f"{name}_gnc"
        gnc_dir.mkdir(exist_ok=True)
        try:
            run(gtsam_worker.command("gtsam-gnc", graph, gnc_dir))
            team, worst = ate(gnc_dir / "result.g2o", truth)
            row += f" {score(args.pgem, gnc_dir, graph, outliers)} | {team:.3f} | {worst:.3f} |"
        except RuntimeError as error:
            row += f" failed: {str(error)[-60:]} | | |"
    return row


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("pgem")
    parser.add_argument("--robots", default="2,4,8")
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--false", default="0,50")
    parser.add_argument("--poses", type=int, default=2000)
    parser.add_argument("--world", default="manhattan", choices=("manhattan", "sphere", "grid3d"))
    parser.add_argument("--gtsam", action="store_true")
    parser.add_argument("--em-options", default="",
                        help="more options for pgem optimize, e.g. '--frames off'")
    parser.add_argument("--out", default="build/bench_team")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    header = ("| robots | seed | false loops | EM rounds | termination | frames placed | parts held | "
              "rejected | "
              "EM P/R | EM ATE team (m) | EM ATE worst robot (m) |")
    if args.gtsam:
        header += " GNC P/R | GNC ATE team (m) | GNC ATE worst robot (m) |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for robots in (int(r) for r in args.robots.split(",")):
        for seed in (int(s) for s in args.seeds.split(",")):
            for false in (int(f) for f in args.false.split(",")):
                print(cell(args, robots, seed, false, out), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
