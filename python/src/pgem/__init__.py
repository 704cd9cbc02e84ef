"""pgem: robust pose-graph optimisation (EM loop-closure weighting) and pose covariances.

A Graph holds one pgem instance: a fixed-memory block sized at creation for its capacities.
Poses are numpy arrays: 2D ``[x, y, theta]``, 3D ``[x, y, z, qx, qy, qz, qw]``; information
matrices are full n x n (n = 3 in 2D, 6 in 3D; in 3D over x, y, z and the quaternion's vector
part, as g2o). Every failed call raises :class:`pgem.Error` carrying pgem's message.

>>> import numpy as np, pgem
>>> graph = pgem.Graph(2, max_poses=10, max_edges=20)
>>> graph.add_pose(0, [0.0, 0.0, 0.0])
>>> graph.add_pose(1, [1.1, 0.1, 0.0])
>>> graph.add_edge(0, 1, [1.0, 0.0, 0.0], np.eye(3) * 100)
0
>>> summary = graph.optimize()
>>> graph.covariance(1).shape
(3, 3)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._error import Error
from ._pgem import VERSION as _VERSION
from ._pgem import _Graph

__all__ = ["Error", "Graph", "Summary", "UpdateSummary", "read_g2o", "to_gtsam", "LOOP_DTYPE"]
__version__ = _VERSION

ArrayLike = Union[npt.ArrayLike, Sequence[float]]

#: The rows of :meth:`Graph.loop_weights`: the two pose ids, the weight, and whether the robust
#: layer pruned the loop.
LOOP_DTYPE = np.dtype([("from", np.uint64), ("to", np.uint64), ("weight", np.float64),
                       ("pruned", np.bool_)])

_ROBUST = ("em", "none", "cauchy", "huber", "dcs")


@dataclass(frozen=True)
class Summary:
    """What :meth:`Graph.optimize` did.

    ``final_chi2`` is the weighted chi2 of the result (rejected loops excluded),
    ``iterations`` the Gauss-Newton iterations run (over every M-step for a robust solve),
    ``rejected`` the loop closures the robust method rejected (0 for ``robust="none"``),
    ``loops`` the loop closures in the graph (robust solves), ``outcome`` (robust) and
    ``termination`` why it ended (robust: ``converged``, ``round_limit``, ``oscillated`` ...),
    ``held_poses`` (robust) the poses holding the parts that rejected loop closures left
    without a held pose, each at its own gauge; ``frames_placed`` (EM) the parts (a team's
    robots, each from its own origin) moved into the frame their agreeing loop closures
    imply."""

    initial_chi2: float
    final_chi2: float
    iterations: int
    rejected: int
    loops: int = 0
    rounds: int = 0
    em_iterations: int = 0
    final_chi2_with_rejected: float = float("nan")
    outcome: str = ""
    termination: str = ""
    held_poses: Tuple[int, ...] = ()
    frames_placed: int = 0
    usable: bool = True


@dataclass(frozen=True)
class UpdateSummary:
    """What :meth:`Graph.update` did: poses and edges that entered the incremental factor,
    poses relinearised, whether the factor was rebuilt, and (robust) the new loop closures
    the consistency gate accepted or rejected, and pruned ones it re-admitted; then the
    loop closures in the graph, how many are pruned, and the ``outcome`` a robust solve's
    :class:`Summary` would give for them (``"loops_accepted"``, ``"most_rejected"``, ...)."""

    poses_added: int
    edges_added: int
    relinearized: int
    rebuilt: bool
    loops_accepted: int
    loops_rejected: int
    loops_readmitted: int
    loops: int = 0
    loops_pruned: int = 0
    outcome: str = ""


def _vector(values: ArrayLike, size: int, what: str) -> np.ndarray:
    array = np.ascontiguousarray(values, dtype=np.float64)
    if array.shape != (size,):
        raise ValueError(f"{what} must have {size} values, got shape {array.shape}")
    return array


def _matrix(values: ArrayLike, size: int, what: str) -> np.ndarray:
    array = np.ascontiguousarray(values, dtype=np.float64)
    if array.shape != (size, size):
        raise ValueError(f"{what} must be {size} x {size}, got shape {array.shape}")
    return array


class Graph:
    """A pose graph in one fixed-memory pgem instance.

    ``dimension`` is 2 (SE(2) poses) or 3 (SE(3)); ``max_poses`` and ``max_edges`` are the
    capacities (adding beyond them raises, changing nothing). ``fill_budget`` is the room for
    the Cholesky factor in nonzeros (0: 32 pose blocks per pose, about twice what the standard
    datasets need); ``online=True`` also reserves the incremental factor :meth:`update` needs
    (twice the fill budget)."""

    def __init__(self, dimension: int, max_poses: int, max_edges: int, *,
                 fill_budget: int = 0, online: bool = False,
                 _instance: Optional[_Graph] = None) -> None:
        self._graph = _instance if _instance is not None else _Graph(
            int(dimension), int(max_poses), int(max_edges), int(fill_budget), bool(online))
        self._dimension = self._graph.dimension()

    @property
    def dimension(self) -> int:
        """2 or 3."""
        return self._dimension

    @property
    def pose_size(self) -> int:
        """Values in a pose: 3 in 2D, 7 in 3D."""
        return 7 if self._dimension == 3 else 3

    @property
    def tangent_size(self) -> int:
        """Rows of a pose's covariance: 3 in 2D, 6 in 3D."""
        return 6 if self._dimension == 3 else 3

    @property
    def pose_count(self) -> int:
        """Poses added."""
        return self._graph.pose_count()

    @property
    def edge_count(self) -> int:
        """Edges added."""
        return self._graph.edge_count()

    def __len__(self) -> int:
        return self.pose_count

    def __repr__(self) -> str:
        return (f"pgem.Graph(dimension={self._dimension}, poses={self.pose_count}, "
                f"edges={self.edge_count})")

    def add_pose(self, id: int, pose: ArrayLike) -> None:
        """Adds pose ``id`` (an unsigned 64-bit integer) with its initial estimate: 2D
        ``[x, y, theta]``, 3D ``[x, y, z, qx, qy, qz, qw]`` (normalised; refused if its norm
        is off 1 by more than 1 %)."""
        self._graph.add_pose(int(id), _vector(pose, self.pose_size, "pose"))

    def set_pose(self, id: int, pose: ArrayLike) -> None:
        """Overwrites pose ``id``'s estimate."""
        self._graph.set_pose(int(id), _vector(pose, self.pose_size, "pose"))

    def pose(self, id: int) -> np.ndarray:
        """Pose ``id``'s estimate (3 or 7 values)."""
        return self._graph.pose(int(id))

    def fix_pose(self, id: int, fixed: bool = True) -> None:
        """Holds pose ``id`` constant (or frees it). With none fixed, the first pose added is
        held (the gauge)."""
        self._graph.fix_pose(int(id), bool(fixed))

    def add_edge(self, a: int, b: int, measurement: ArrayLike, information: ArrayLike,
                 loop: bool = False) -> int:
        """Adds a measurement of pose ``b`` in the frame of pose ``a`` (a pose's layout) with
        its full information matrix (n x n, symmetric positive definite), as odometry or, with
        ``loop=True``, as a loop closure the robust methods may reject. Returns the edge's
        index."""
        n = self.tangent_size
        return self._graph.add_edge(int(a), int(b), _vector(measurement, self.pose_size,
                                                               "measurement"),
                                    _matrix(information, n, "information"), bool(loop))

    def optimize(self, robust: str = "none", *, scale: float = 0.0, method: str = "gn",
                 max_iterations: int = 0) -> Summary:
        """Optimizes from the current estimate. ``robust`` is ``"em"`` (EM loop-closure
        weighting with pruning, pgem's method), ``"cauchy"``, ``"huber"``, ``"dcs"``
        (IRLS kernels, as ``pgem optimize --robust``) or ``"none"`` (plain least squares,
        every loop closure back at weight 1). ``scale`` is the kernel's (0: 1), ``method``
        ``"gn"`` (Gauss-Newton) or ``"lm"`` (Levenberg-Marquardt), ``max_iterations`` 0 for
        the default (100). On failure the estimate is restored and :class:`Error` raised."""
        if robust not in _ROBUST:
            raise ValueError(f"robust must be one of {', '.join(_ROBUST)}, got {robust!r}")
        done = self._graph.optimize(robust, float(scale), method, int(max_iterations))
        if "held_poses" in done:
            done["held_poses"] = tuple(done["held_poses"])
        return Summary(**done)

    def update(self, robust: bool = False, rebuild: bool = False) -> UpdateSummary:
        """The online path (``pgem_update``): brings the estimate up to date with the poses
        and edges added since the last call, refactoring only what they touch; with
        ``robust=True`` new loop closures must pass the consistency gate. Needs a graph made
        with ``online=True``. One Gauss-Newton step per call, not the optimum: call
        :meth:`optimize` (e.g. ``robust="em"``) at the end."""
        return UpdateSummary(**self._graph.update(bool(robust), bool(rebuild)))

    def poses(self) -> Tuple[np.ndarray, np.ndarray]:
        """``(ids, poses)``: the ids (uint64, insertion order) and an N x 3 (2D) or N x 7
        (3D) array of their estimates."""
        return self._graph.poses()

    def loop_weights(self) -> np.ndarray:
        """Every loop closure in edge order as a structured array of rows ``(from, to,
        weight, pruned)`` (:data:`LOOP_DTYPE`): ``rows["weight"]``, ``rows["pruned"]``."""
        ends, weights, pruned = self._graph.loops()
        rows = np.empty(len(weights), dtype=LOOP_DTYPE)
        rows["from"] = ends[:, 0]
        rows["to"] = ends[:, 1]
        rows["weight"] = weights
        rows["pruned"] = pruned
        return rows

    def chi2(self) -> float:
        """Sum of e^T Omega e over every edge at the current estimate (unweighted)."""
        return self._graph.chi2()

    def covariance(self, id: int) -> np.ndarray:
        """The marginal covariance of pose ``id`` at the current estimate: 3 x 3 over
        (x, y, theta) in 2D, exactly GTSAM's Pose2; 6 x 6 over (x, y, z, rx, ry, rz) in 3D,
        translation first (:func:`to_gtsam` gives GTSAM's Pose3 order). The tangent is on the
        right (body frame). A held pose's is zero. The factor at the current estimate is made
        when none is current."""
        return self._graph.covariance(int(id))

    def joint_covariance(self, a: int, b: int) -> np.ndarray:
        """The joint marginal covariance of poses ``a`` and ``b`` (6 x 6 or 12 x 12), ``a``'s
        tangent first."""
        return self._graph.joint_covariance(int(a), int(b))

    def covariances(self) -> np.ndarray:
        """Every pose's marginal covariance in one sparse-inverse pass: an N x 3 x 3 (2D) or
        N x 6 x 6 (3D) array in the order of :meth:`poses`."""
        return self._graph.covariances()

    def write_g2o(self, path: str) -> None:
        """Writes the graph (its current estimate) as g2o, doubles written to round-trip."""
        self._graph.write_g2o(str(path))


def read_g2o(path: str, *, fill_budget: int = 0, online: bool = False) -> Graph:
    """Reads a g2o or TORO 2D file (FORMATS.md) into a Graph whose capacities are the
    file's. Errors name the file and line."""
    return Graph(0, 0, 0, _instance=_Graph.read_g2o(str(path), int(fill_budget), bool(online)))


def to_gtsam(covariance: np.ndarray) -> np.ndarray:
    """A covariance in GTSAM's order: in 3D (6 x 6, or N x 6 x 6) the two 3-blocks swapped
    (rotation first, as GTSAM's Pose3); 2D (3 x 3) is GTSAM's Pose2 already and returned as
    is."""
    array = np.asarray(covariance)
    if array.shape[-1] != 6:
        return array
    return np.roll(array, 3, axis=(-2, -1))
