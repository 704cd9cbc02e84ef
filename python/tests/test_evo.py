"""The ATE of a result computed by evo (PyPI) equals pgem eval's: the same rigid alignment
(rotation and translation, no scale) and the same RMSE of the position error."""
import json
import os
import subprocess

import numpy as np
import pytest

import pgem

evo_trajectory = pytest.importorskip("evo.core.trajectory",
                                     reason="evo (PyPI) is installed by tools/setup-debian")
from evo.core import metrics  # noqa: E402


def pgem_cli():
    path = os.environ.get("PGEM_CLI")
    if not path:
        pytest.skip("PGEM_CLI (the pgem tool, which CTest passes) is not set")
    return path


def trajectory(graph: pgem.Graph):
    ids, poses = graph.poses()
    if graph.dimension == 2:
        xyz = np.column_stack([poses[:, :2], np.zeros(len(poses))])
        half = poses[:, 2] / 2
        wxyz = np.column_stack([np.cos(half), np.zeros((len(poses), 2)), np.sin(half)])
    else:
        xyz = poses[:, :3]
        wxyz = poses[:, [6, 3, 4, 5]]
    return evo_trajectory.PoseTrajectory3D(xyz, wxyz, timestamps=ids.astype(float))


@pytest.mark.parametrize("world, dimension", [("manhattan", 2), ("sphere", 3)])
def test_ate_equals_pgem_eval(scratch, world, dimension):
    cli = pgem_cli()
    run = lambda *args: subprocess.run([cli, *args], cwd=scratch, check=True,  # noqa: E731
                                       capture_output=True, text=True).stdout
    run("simulate", "-o", "sim.g2o", "--truth", "truth.g2o", "--world", world, "--poses", "400",
        "--seed", "3")
    graph = pgem.read_g2o(scratch / "sim.g2o")
    graph.optimize()
    graph.write_g2o(scratch / "result.g2o")
    report = json.loads(run("eval", "result.g2o", "--reference", "truth.g2o", "--json"))
    estimate = trajectory(graph)
    reference = trajectory(pgem.read_g2o(scratch / "truth.g2o"))
    assert graph.dimension == dimension
    estimate.align(reference, correct_scale=False)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((reference, estimate))
    rmse = ape.get_statistic(metrics.StatisticsType.rmse)
    assert rmse == pytest.approx(report["ate_translation_rmse"], rel=1e-6)
