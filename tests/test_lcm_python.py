#!/usr/bin/env python3
"""The generated Python LCM types import and read what the C types write (issue 17: `import
pgem` was a SyntaxError, the field `from` being a Python keyword; it is `from_` in Python).

Runs LCM_ENCODE (tests/lcm_encode.c) into a scratch folder, imports the package from
PGEM_PYTHON (the build's lcmtypes/python), decodes every message, checks its fields, and
encodes it again: the bytes must be the C side's, so the wire format is the same.
Environment: LCM_ENCODE, PGEM_PYTHON, WORK. Exit 0 pass, 1 fail."""

import os
import subprocess
import sys
from pathlib import Path


def main() -> int:
    work = Path(os.environ["WORK"])
    work.mkdir(parents=True, exist_ok=True)
    subprocess.run([os.environ["LCM_ENCODE"], str(work)], check=True)
    sys.path.insert(0, os.environ["PGEM_PYTHON"])
    import pgem  # noqa: E402  (the generated package)

    def read(name, kind):
        data = (work / f"{name}.bin").read_bytes()
        message = kind.decode(data)
        if message.encode() != data:
            raise AssertionError(f"{name}: re-encoded bytes differ from the C side's")
        return message

    edge = read("edge2", pgem.edge2_t)
    assert edge.from_ == -1 and edge.to == 7 and edge.sequence == 42, vars(edge)
    assert edge.source == "front-end \u00e9" and edge.kind == pgem.edge2_t.LOOP
    assert list(edge.measurement) == [1.5, -0.25, 3.0]
    assert list(edge.information) == [100.0 + k for k in range(6)]
    edge3 = read("edge3", pgem.edge3_t)
    assert edge3.from_ == 9 and edge3.to == 10 and list(edge3.information) == list(range(21))
    graph = read("graph", pgem.graph_t)
    assert [(loop.from_, loop.to, loop.weight, loop.state) for loop in graph.loops] == [
        (0, 5, 0.875, pgem.loop_t.ACCEPTED), (5, 0, 0.0, pgem.loop_t.PRUNED)]
    assert graph.sources == ["a", "b"] and list(graph.last_sequence) == [11, 12]
    assert list(graph.ids) == [0, 5] and list(graph.poses[1]) == [1.0, 2.0, 0.5]
    assert graph.stats.trigger == "settle" and graph.stats.chi2 == 137.91295093603975
    pose = read("pose3", pgem.pose3_t)
    assert pose.id == 77 and pose.fixed and list(pose.pose)[6] == 1.0
    command = read("command", pgem.command_t)
    assert command.command == pgem.command_t.SNAPSHOT and command.path == "map.g2o"
    status = read("status", pgem.status_t)
    assert status.reasons == ["journal"] and list(status.rejected) == [50]
    assert status.accepted_poses == 100 and status.journal_records == 100
    covariance = read("covariance", pgem.covariance_t)
    assert (covariance.id, covariance.solve_id, covariance.size) == (2499, 812, 6)
    assert covariance.current and list(covariance.pose) == [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]
    assert [list(row) for row in covariance.covariance] == [
        [6.0 * i + j + 0.5 for j in range(6)] for i in range(6)]
    team = read("team", pgem.team_t)
    assert (team.solve_id, team.dimension, team.num_parts) == (17, 3, 2), vars(team)
    assert team.sources == ["robot-0", "robot-1"] and list(team.poses) == [300, 299]
    assert list(team.first_ids) == [0, 1000000] and list(team.parts) == [0, 1]
    assert list(team.anchored) == [1, 0]
    assert list(team.frames[1]) == [10.0, -12.0, 1.0, 0.0, 0.0, 1.0, 0.0]
    # written from Python, read as the C types write them: an edge built in Python
    built = pgem.edge2_t()
    built.utime, built.source, built.sequence = edge.utime, edge.source, 42
    built.from_, built.to, built.kind = -1, 7, pgem.edge2_t.LOOP
    built.measurement, built.information = list(edge.measurement), list(edge.information)
    assert built.encode() == (work / "edge2.bin").read_bytes()
    print("PASS: every pgem type imports, decodes the C encoding and encodes it back bit for bit")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (AssertionError, ImportError, SyntaxError, subprocess.CalledProcessError) as error:
        print(f"FAIL: {type(error).__name__}: {error}")
        sys.exit(1)
