"""The same graph in GTSAM (for the comparisons): a g2o file's edges as BetweenFactors with
pgem's noise model, the first pose held by a tight prior, values from a pgem estimate."""
from pathlib import Path
from typing import List, Tuple

import numpy as np

HELD_SIGMA = 1e-6  # the first pose's prior: held, as pgem holds it (no column in H)

# pgem's 3D edge error is (translation, the vector part of the error quaternion), about half
# the rotation angle; GTSAM's Pose3 error is (rotation vector, translation). The same noise
# model in GTSAM's tangent: J^T Omega J with J = d(pgem error)/d(GTSAM error), the blocks
# swapped and the rotation rows halved.
_HALF_ROTATION = np.diag([1.0, 1.0, 1.0, 0.5, 0.5, 0.5])
_SWAP = np.roll(np.eye(6), 3, axis=1)  # pgem (t, r) = _SWAP @ gtsam (r, t)


def read_edges(path: Path) -> List[Tuple[int, int, np.ndarray, np.ndarray]]:
    """(from, to, measurement, information) of every EDGE_SE2 / EDGE_SE3:QUAT line."""
    edges = []
    for line in open(path, encoding="ascii"):
        fields = line.split()
        if not fields or fields[0] not in ("EDGE_SE2", "EDGE_SE3:QUAT"):
            continue
        size, pose = (6, 7) if fields[0] == "EDGE_SE3:QUAT" else (3, 3)
        values = np.array([float(v) for v in fields[3:]])
        information = np.zeros((size, size))
        information[np.triu_indices(size)] = values[pose:]
        information = information + np.triu(information, 1).T
        edges.append((int(fields[1]), int(fields[2]), values[:pose], information))
    return edges


def gtsam_pose(gtsam, pose: np.ndarray):
    if len(pose) == 3:
        return gtsam.Pose2(*map(float, pose))
    q = pose[3:] / np.linalg.norm(pose[3:])
    return gtsam.Pose3(gtsam.Rot3.Quaternion(q[3], q[0], q[1], q[2]), gtsam.Point3(*pose[:3]))


def gtsam_information(information: np.ndarray) -> np.ndarray:
    """pgem's edge information in GTSAM's tangent (2D: the same)."""
    if information.shape[0] == 3:
        return information
    j = _HALF_ROTATION @ _SWAP
    return j.T @ information @ j


def gtsam_problem(gtsam, edges, ids: np.ndarray, poses: np.ndarray):
    """The factor graph (first pose held) and the values of a pgem estimate."""
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    for key, pose in zip(ids, poses):
        values.insert(int(key), gtsam_pose(gtsam, pose))
    three = poses.shape[1] == 7
    first = int(ids[0])
    held = gtsam.noiseModel.Isotropic.Sigma(6 if three else 3, HELD_SIGMA)
    prior = gtsam.PriorFactorPose3 if three else gtsam.PriorFactorPose2
    between = gtsam.BetweenFactorPose3 if three else gtsam.BetweenFactorPose2
    graph.add(prior(first, gtsam_pose(gtsam, poses[0]), held))
    for a, b, measurement, information in edges:
        noise = gtsam.noiseModel.Gaussian.Information(gtsam_information(information))
        graph.add(between(a, b, gtsam_pose(gtsam, measurement), noise))
    return graph, values


def relative_frobenius(mine: np.ndarray, reference: np.ndarray) -> float:
    return float(np.linalg.norm(mine - reference) / np.linalg.norm(reference))
