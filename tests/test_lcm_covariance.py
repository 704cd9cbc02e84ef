#!/usr/bin/env python3
"""The newest pose's covariance the LCM bridge publishes (pgem.covariance_t) against the offline
tool, over real UDP multicast in a network namespace of the test's own (test_lcm_faults.py's).

M3500 with 100 random false loop closures (a simulated walk without the datasets folder) is
streamed in order into a bridge with EM; then
  - the covariance of the first graph holding every edge (an incremental update's): its pose
    is the newest pose (the graph's last id), its solve_id and utime the graph's, `current`
    false (the incremental factor; true only after a whole-graph solve), the matrix symmetric
    and positive definite;
  - the covariance of the settled graph: the newest pose again, `current` true, and the matrix
    what `pgem optimize --robust em --covariances` writes for that pose within 1e-6 (relative,
    Frobenius), its pose the offline one within 1e-6.
The tolerance: the settled estimate is the offline one to the 1e-6 the fault tests allow
(measured 1e-13); a marginal moves with its linearisation point by about the pose difference
over the edges' length (1 m and more here), so 1e-6 relative; the file's 12 digits add 5e-12.
Measured: 4e-11. Sphere2500 (3D, when the datasets folder has it) is streamed into a 3D bridge
and checked the same way (6 x 6).

Environment (CTest sets it): PGEM, BRIDGE, SEND, DUMP, DATASETS, WORK. Exit 0 pass, 1 fail, 77
skipped where PGEM_ALLOW_SKIP=1 allows it (as test_lcm_faults.py).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import test_lcm_faults as faults  # noqa: E402  (its namespace, processes and helpers)

TOLERANCE = 1e-6


def offline_covariance(path: Path, pose_id: int, n: int) -> list[list[float]]:
    """Pose pose_id's matrix from a `pgem optimize --covariances` file (upper triangles)."""
    for line in path.read_text().splitlines():
        fields = line.split()
        if fields and int(fields[0]) == pose_id:
            upper = [float(x) for x in fields[1:]]
            matrix = [[0.0] * n for _ in range(n)]
            k = 0
            for i in range(n):
                for j in range(i, n):
                    matrix[i][j] = matrix[j][i] = upper[k]
                    k += 1
            return matrix
    raise faults.Failure(f"{path} has no pose {pose_id}")


def offline_pose(path: Path, pose_id: int) -> list[float]:
    for line in path.read_text().splitlines():
        fields = line.split()
        if fields and fields[0].startswith("VERTEX") and int(fields[1]) == pose_id:
            return [float(x) for x in fields[2:]]
    raise faults.Failure(f"{path} has no pose {pose_id}")


def relative_difference(a: list[list[float]], b: list[list[float]]) -> float:
    """|a - b|_F / |b|_F."""
    difference = sum((x - y) ** 2 for row_a, row_b in zip(a, b) for x, y in zip(row_a, row_b))
    norm = sum(y * y for row in b for y in row)
    return math.sqrt(difference / norm)


def positive_definite(matrix: list[list[float]]) -> bool:
    """Cholesky without pivoting succeeds."""
    n = len(matrix)
    lower = [[0.0] * n for _ in range(n)]
    for j in range(n):
        pivot = matrix[j][j] - sum(lower[j][k] ** 2 for k in range(j))
        if not pivot > 0.0:
            return False
        lower[j][j] = math.sqrt(pivot)
        for i in range(j + 1, n):
            lower[i][j] = (matrix[i][j] - sum(lower[i][k] * lower[j][k] for k in range(j))) / lower[j][j]
    return True


def last_id(g2o: Path) -> int:
    """The id of the last pose a dumped graph lists (the bridge's insertion order)."""
    ids = [int(line.split()[1]) for line in g2o.read_text().splitlines()
           if line.startswith("VERTEX")]
    return ids[-1]


def dump(name: str, *stop: str) -> subprocess.Popen:
    process = faults.spawn(
        [faults.program("DUMP"), "-o", f"{name}.g2o", "--json", f"{name}.json", "--covariance",
         f"{name}.covariance.json", *stop, "--timeout", "240", "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    time.sleep(0.3)
    return process


def check_message(name: str, newest: int) -> dict:
    """The covariance a dump wrote belongs to its graph, names the newest pose, is `current`
    exactly after the settle (a whole-graph solve) and is a covariance; returns it."""
    covariance = faults.read_json(Path(f"{name}.covariance.json"))
    graph = faults.read_json(Path(f"{name}.json"))
    faults.expect(covariance is not None and graph is not None, f"{name}: no covariance or graph")
    current = graph["stats"]["trigger"] == "settle"
    faults.expect(covariance["solve_id"] == graph["stats"]["solve_id"] and
                  covariance["utime"] == graph["utime"],
                  f"{name}: covariance of graph {covariance['solve_id']} (utime "
                  f"{covariance['utime']}), the graph is {graph['stats']['solve_id']} "
                  f"({graph['utime']})")
    faults.expect(covariance["id"] == newest == last_id(Path(f"{name}.g2o")),
                  f"{name}: covariance of pose {covariance['id']}, the newest is {newest}")
    faults.expect(covariance["current"] == current,
                  f"{name}: current is {covariance['current']}, expected {current}")
    matrix = covariance["covariance"]
    n = 3 if covariance["dimension"] == 2 else 6
    faults.expect(len(matrix) == n and all(len(row) == n for row in matrix),
                  f"{name}: the matrix is not {n} x {n}")
    faults.expect(all(matrix[i][j] == matrix[j][i] for i in range(n) for j in range(n)),
                  f"{name}: the matrix is not symmetric")
    faults.expect(positive_definite(matrix), f"{name}: the matrix is not positive definite")
    return covariance


def stream(name: str, graph: Path, edges: int, poses: int, offline: Path, *bridge_options: str,
           rate: str = "2000") -> dict:
    """Streams graph into a new bridge; checks the live and the settled covariance."""
    faults.step(f"{name}: {graph.name} streamed at {rate} edges/s")
    bridge = faults.Bridge(Path(f"{name}.log"), *bridge_options)
    bridge.start()
    live = dump(f"{name}.live", "--edges", str(edges))
    settled = dump(f"{name}.settled", "--edges", str(edges), "--settled")
    faults.finish(faults.sender(graph, "--rate", rate, "--wait", "60"), f"{name}: sending")
    faults.finish(live, f"{name}: the first graph with every edge")
    faults.finish(settled, f"{name}: the settled graph")
    bridge.stop()
    newest = poses - 1  # the file's ids are 0 .. poses - 1, sent in order
    check_message(f"{name}.live", newest)
    message = check_message(f"{name}.settled", newest)
    n = len(message["covariance"])
    reference = offline_covariance(offline, newest, n)
    difference = relative_difference(message["covariance"], reference)
    live_difference = relative_difference(
        faults.read_json(Path(f"{name}.live.covariance.json"))["covariance"], reference)
    pose = offline_pose(offline.with_suffix(".g2o"), newest)
    if len(pose) == 7 and sum(a * b for a, b in zip(pose[3:], message["pose"][3:])) < 0.0:
        pose[3:] = [-q for q in pose[3:]]  # the same rotation
    pose_error = max(abs(a - b) for a, b in zip(message["pose"], pose))
    print(f"{name}: settled covariance of pose {newest} within {difference:.2g} of pgem "
          f"optimize --covariances (pose within {pose_error:.2g}); the incremental one of the "
          f"first graph with every edge within {live_difference:.2g}")
    faults.expect(difference <= TOLERANCE,
                  f"{name}: the settled covariance differs from the offline one by "
                  f"{difference:.3g} (relative), more than {TOLERANCE:g}")
    faults.expect(pose_error <= TOLERANCE, f"{name}: the settled pose differs by {pose_error:.3g}")
    log = Path(f"{name}.log").read_text()
    faults.expect("no covariance" not in log, f"{name}: the bridge could not give a covariance")
    return {"settled": difference, "live": live_difference}


def offline(graph: Path, name: str) -> Path:
    """`pgem optimize --robust em --covariances NAME.cov -o NAME.g2o`; returns NAME.cov."""
    subprocess.run([faults.program("PGEM"), "optimize", str(graph), "--robust", "em",
                    "--covariances", f"{name}.cov", "-o", f"{name}.g2o", "--quiet"],
                   check=True, stdout=subprocess.DEVNULL)
    return Path(f"{name}.cov")


def poses_in(graph: Path) -> int:
    with graph.open() as handle:
        return sum(1 for line in handle if line.startswith("VERTEX"))


def main() -> int:
    faults.enter_namespace()
    work = Path(os.environ.get("WORK", "lcm_covariance"))
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    os.chdir(work)
    datasets = Path(os.environ.get("DATASETS", ""))
    figures = {}
    try:
        graph, edges = faults.make_input(datasets)
        figures["2d"] = stream("m3500", graph, edges, poses_in(graph), offline(graph, "offline2"))
        sphere = datasets / "3d" / "sphere2500.g2o"
        if sphere.exists():
            figures["3d"] = stream("sphere", sphere, faults.count_edges(sphere), poses_in(sphere),
                                   offline(sphere, "offline3"), "--dimension", "3", rate="4000")
        else:
            print("(no 3d/sphere2500.g2o in the datasets folder: 3D not checked)")
    except (faults.Failure, subprocess.CalledProcessError, subprocess.TimeoutExpired) as error:
        return faults.report_failure(error)
    finally:
        faults.end_started()
    print(f"PASS {json.dumps(figures)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
