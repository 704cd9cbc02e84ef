"""Shared fixtures: the shared datasets folder, small synthetic graphs, a scratch folder."""
import math
import os
from pathlib import Path

import numpy as np
import pytest

import pgem


def datasets_dir() -> Path:
    """The shared datasets (PGEM_DATASETS, as CTest sets it; else ../shared/datasets beside
    the checkout)."""
    configured = os.environ.get("PGEM_DATASETS")
    if configured:
        return Path(configured)
    return Path(__file__).resolve().parents[3] / "shared" / "datasets"


def dataset(relative: str) -> Path:
    """A dataset file, or a skip saying where it was looked for."""
    path = datasets_dir() / relative
    if not path.is_file():
        pytest.skip(f"{path} is not there: the shared datasets are needed")
    return path


def square_walk(laps: int = 2, side: int = 4, false_loops=(), spare: int = 0,
                online: bool = False) -> pgem.Graph:
    """A 2D robot driving laps around a square with drifting odometry, a loop closure at each
    return to a visited corner, and false loop closures (pairs of ids) with a wrong
    measurement."""
    count = laps * 4 * side + 1
    graph = pgem.Graph(2, count + spare, 4 * count, online=online)
    information = np.diag([100.0, 100.0, 400.0])
    truth = []
    pose = np.zeros(3)
    for k in range(count):
        truth.append(pose.copy())
        turn = (k + 1) % side == 0
        heading = pose[2]
        pose = pose + [math.cos(heading), math.sin(heading), math.pi / 2 if turn else 0.0]
    guess = np.zeros(3)
    graph.add_pose(0, guess)
    for k in range(1, count):
        delta = relative(truth[k - 1], truth[k])
        drift = delta + [0.02, 0.01, 0.01]
        guess = compose(guess, drift)
        graph.add_pose(k, guess)
        graph.add_edge(k - 1, k, delta, information)
    period = 4 * side
    for k in range(period, count):
        graph.add_edge(k - period, k, relative(truth[k - period], truth[k]), information,
                       loop=True)
    for a, b in false_loops:
        graph.add_edge(a, b, [3.0, -2.0, 1.0], information, loop=True)
    graph.truth = np.array(truth)  # (for the tests: the poses the measurements came from)
    return graph


def relative(a, b) -> np.ndarray:
    """b in the frame of a (SE(2))."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    angle = math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))
    return np.array([c * dx + s * dy, -s * dx + c * dy, angle])


def compose(a, d) -> np.ndarray:
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * d[0] - s * d[1], a[1] + s * d[0] + c * d[1], a[2] + d[2]])


@pytest.fixture
def scratch(tmp_path: Path) -> Path:
    return tmp_path
