"""The binding itself: building, solving, reading and writing graphs, robust solves, the
online path, covariances, and errors raised as pgem.Error with pgem's message."""
import math

import numpy as np
import pytest

import pgem
from conftest import dataset, relative, square_walk


def test_square_walk_solves_and_shapes():
    graph = square_walk()
    assert len(graph) == 33 and graph.dimension == 2
    summary = graph.optimize()
    assert summary.final_chi2 < 1e-6
    assert summary.iterations >= 2 and summary.rejected == 0
    ids, poses = graph.poses()
    assert ids.dtype == np.uint64 and poses.shape == (33, 3)
    assert np.allclose(poses[4], [4.0, 0.0, math.pi / 2], atol=1e-6)
    assert np.array_equal(graph.pose(4), poses[4])


def test_round_trip_g2o(scratch):
    graph = square_walk()
    graph.fix_pose(0)
    path = scratch / "walk.g2o"
    graph.write_g2o(path)
    again = pgem.read_g2o(path)
    ids, poses = graph.poses()
    ids2, poses2 = again.poses()
    assert np.array_equal(ids, ids2) and np.array_equal(poses, poses2)  # %.17g: the same bits
    assert again.edge_count == graph.edge_count
    assert np.array_equal(again.loop_weights()[["from", "to"]], graph.loop_weights()[["from", "to"]])
    again.write_g2o(scratch / "again.g2o")
    assert (scratch / "again.g2o").read_text() == path.read_text()


def test_self_loops_left_out_with_a_warning(scratch):
    path = scratch / "self.g2o"
    path.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
                    "EDGE_SE2 1 1 0 0 0 1 0 0 1 0 1\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n")
    with pytest.warns(UserWarning, match=r"self-loop edges .* line\(s\) 3$"):
        graph = pgem.read_g2o(path)
    assert graph.edge_count == 1
    assert graph.optimize().final_chi2 < 1e-12


def test_round_trip_dataset(scratch):
    graph = pgem.read_g2o(dataset("3d/sphere2500.g2o"))
    assert graph.dimension == 3 and len(graph) == 2500
    graph.write_g2o(scratch / "sphere.g2o")
    again = pgem.read_g2o(scratch / "sphere.g2o")
    # quaternions are normalised when added: written with %.17g, they read back within an ulp
    assert np.allclose(graph.poses()[1], again.poses()[1], rtol=0, atol=1e-13)


def test_em_rejects_false_loops():
    false = [(3, 20), (7, 30), (12, 25)]
    graph = square_walk(false_loops=false)
    plain = square_walk(false_loops=false)
    summary = graph.optimize("em")
    assert summary.rejected == 3 and summary.loops == 17 + 3
    rows = graph.loop_weights()
    assert rows.dtype == pgem.LOOP_DTYPE
    rejected = {(int(r["from"]), int(r["to"])) for r in rows if r["pruned"]}
    assert rejected == set(false)
    assert summary.final_chi2 < 1e-6
    assert plain.optimize("none").final_chi2 > 100.0  # the false loops bend plain least squares
    for kernel in ("cauchy", "huber", "dcs"):
        assert square_walk(false_loops=false).optimize(kernel).final_chi2 < plain.chi2()


def test_errors_carry_pgem_message(scratch):
    graph = pgem.Graph(2, 3, 3)
    graph.add_pose(1, [0, 0, 0])
    with pytest.raises(pgem.Error) as caught:
        graph.add_pose(1, [1, 0, 0])
    assert str(caught.value) == "pose id 1 already exists"
    assert caught.value.name == "PGEM_ERR_DUPLICATE_ID" and caught.value.code == -5
    with pytest.raises(pgem.Error, match="no pose with id 7"):
        graph.add_edge(1, 7, [1, 0, 0], np.eye(3))
    with pytest.raises(pgem.Error, match="not positive definite"):
        graph.add_pose(2, [1, 0, 0])
        graph.add_edge(1, 2, [1, 0, 0], -np.eye(3))
    with pytest.raises(pgem.Error, match="no pose with id 99"):
        graph.covariance(99)
    with pytest.raises(ValueError, match="pose must have 3 values"):
        graph.add_pose(5, [0, 0])
    with pytest.raises(ValueError, match="robust must be one of"):
        graph.optimize("tukey")
    bad = scratch / "bad.g2o"
    bad.write_text("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0\n")
    with pytest.raises(pgem.Error, match=r"bad.g2o:2: EDGE_SE2 has 4 fields, expected 11"):
        pgem.read_g2o(bad)
    with pytest.raises(pgem.Error, match="cannot open"):
        pgem.read_g2o(scratch / "missing.g2o")
    with pytest.raises(pgem.Error, match="capacity"):
        graph.add_pose(3, [0, 0, 0])
        graph.add_pose(4, [0, 0, 0])
    with pytest.raises(pgem.Error) as caught:
        pgem.Graph(4, 10, 10)
    assert caught.value.name == "PGEM_ERR_CONFIG"


def test_singular_graph_has_no_covariance():
    graph = square_walk(laps=1, spare=1)
    graph.add_pose(100, [0, 0, 0])  # no edge: a part no held pose holds
    with pytest.raises(pgem.Error, match="pose 100 is in a part of the graph with no held pose"):
        graph.covariance(3)


def test_covariance_calls_agree():
    graph = square_walk()
    graph.optimize()
    every = graph.covariances()
    assert every.shape == (33, 3, 3)
    assert not every[0].any()  # the held first pose
    one = graph.covariance(20)
    joint = graph.joint_covariance(20, 9)
    assert np.allclose(one, every[20], rtol=1e-12, atol=0)
    assert np.allclose(joint[:3, :3], one, rtol=1e-10) and np.allclose(joint[3:, 3:], every[9], rtol=1e-10)
    assert np.allclose(joint, joint.T, rtol=0, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(joint) > 0)
    # the covariance follows the estimate: a moved pose, a new factor
    graph.set_pose(20, graph.pose(20) + [0.0, 0.0, 0.3])
    assert not np.allclose(graph.covariance(20), one)


def test_covariance_is_body_frame():
    """A chain of one edge from a held pose: the covariance of the second pose is the edge's
    own (its inverse information) in the second pose's frame, whatever the heading."""
    information = np.array([[50.0, 5.0, 0.0], [5.0, 20.0, 1.0], [0.0, 1.0, 80.0]])
    for heading in (0.0, 0.7, 2.5):
        graph = pgem.Graph(2, 2, 1)
        graph.add_pose(0, [1.0, 2.0, heading])
        graph.add_pose(1, [1.0, 2.0, heading + 0.4])
        graph.add_edge(0, 1, [0.0, 0.0, 0.4], information)
        graph.optimize()
        # e = t2v(Z^-1 X0^-1 X1): for Z a pure rotation, the error's translation is the
        # second pose's body-frame translation rotated by nothing more: Sigma = Omega^-1
        assert np.allclose(graph.covariance(1), np.linalg.inv(information), rtol=1e-9)


def test_online_updates_then_settle():
    """The walk streamed pose by pose through Graph.update (the consistency gate on), then
    EM from the online estimate: the optimum, every loop closure accepted."""
    source = square_walk(laps=3)
    _, guesses = source.poses()
    truth = source.truth
    loops = {}
    for row in source.loop_weights():
        loops.setdefault(int(row["to"]), []).append(int(row["from"]))
    information = np.diag([100.0, 100.0, 400.0])
    online = pgem.Graph(2, len(source), 4 * len(source), online=True)
    online.add_pose(0, guesses[0])
    accepted = 0
    for k in range(1, len(source)):
        online.add_pose(k, guesses[k])
        online.add_edge(k - 1, k, relative(truth[k - 1], truth[k]), information)
        for other in loops.get(k, []):
            online.add_edge(other, k, relative(truth[other], truth[k]), information, loop=True)
        step = online.update(robust=True)
        if not step.rebuilt:
            assert step.poses_added == 1
        accepted += step.loops_accepted
        rows = online.loop_weights()  # the update's running counts are the graph's
        assert (step.loops, step.loops_pruned) == (len(rows), int(rows["pruned"].sum()))
    assert step.outcome == "loops_accepted"
    settled = online.optimize("em")
    assert settled.rejected == 0 and settled.loops == step.loops
    assert settled.outcome == step.outcome
    poses = online.poses()[1]
    assert np.allclose(poses[:, :2], truth[:, :2], atol=1e-6)
    assert np.allclose(np.angle(np.exp(1j * (poses[:, 2] - truth[:, 2]))), 0.0, atol=1e-6)
    assert online.covariance(len(source) - 1).shape == (3, 3)


def test_update_needs_online_room():
    graph = square_walk(laps=1)
    with pytest.raises(pgem.Error, match="pgem_update needs config.online_fill"):
        graph.update()


def test_to_gtsam_order():
    c = np.arange(36.0).reshape(6, 6)
    g = pgem.to_gtsam(c)
    assert g[0, 0] == c[3, 3] and g[0, 3] == c[3, 0] and g[3, 3] == c[0, 0]
    assert pgem.to_gtsam(np.stack([c, c])).shape == (2, 6, 6)
    assert pgem.to_gtsam(np.eye(3)) is not None


def test_one_graph_from_two_threads():
    """A Graph used from another thread while it solves (the solve releases the GIL): every
    call waits its turn, none sees a half-solved instance or crashes."""
    import threading

    graph = pgem.read_g2o(dataset("2d/input_M3500_g2o.g2o"))
    graph.fix_pose(0)
    results = {}
    worker = threading.Thread(target=lambda: results.update(summary=graph.optimize(robust="em")))
    worker.start()
    reads = 0
    while worker.is_alive() or reads == 0:
        ids, poses = graph.poses()
        assert len(ids) == 3500 and np.isfinite(poses).all()
        reads += 1
    worker.join()
    assert results["summary"].rejected == 0 and results["summary"].iterations > 0
    assert np.array_equal(graph.poses()[1], poses)  # the last read waited for the solve


def test_em_holds_a_part_its_pruned_loops_leave_alone():
    # two chains joined only by two contradicting loop closures: EM prunes both, and the
    # second chain is held at its own gauge (pose 100) instead of failing the solve
    graph = pgem.Graph(2, 20, 20)
    information = np.eye(3) * 100.0
    for part in range(2):
        for k in range(10):
            graph.add_pose(part * 100 + k, [k, part * 32.5, 0.0])
        for k in range(9):
            graph.add_edge(part * 100 + k, part * 100 + k + 1, [1.0, 0.0, 0.0], information)
    graph.add_edge(5, 105, [0.0, 5.0, 0.0], information, loop=True)
    graph.add_edge(6, 106, [0.0, 60.0, 0.0], information, loop=True)
    summary = graph.optimize(robust="em")
    assert summary.outcome == "all_rejected"
    assert summary.termination == "converged"
    assert summary.held_poses == (100,)
    assert summary.frames_placed == 0  # two loops that disagree place nothing


def test_em_places_a_robot_in_the_frame_its_loops_agree_on():
    # a second robot from its own origin, its true frame (30, -20, 2): three agreeing loop
    # closures place it before EM judges them
    graph = pgem.Graph(2, 20, 30)
    information = np.diag([400.0, 400.0, 1e4])
    frame = np.array([30.0, -20.0, 2.0])
    c, s = np.cos(frame[2]), np.sin(frame[2])
    for robot in range(2):
        for k in range(10):
            graph.add_pose(robot * 100 + k, [k, 0.0, 0.0])
        for k in range(9):
            graph.add_edge(robot * 100 + k, robot * 100 + k + 1, [1.0, 0.0, 0.0], information)
    for a, b in ((2, 3), (5, 7), (8, 1)):
        world_b = frame[:2] + np.array([c * b, s * b])  # robot 1's pose b in robot 0's frame
        delta = world_b - np.array([a, 0.0])
        graph.add_edge(a, 100 + b, [delta[0], delta[1], frame[2]], information, loop=True)
    summary = graph.optimize(robust="em")
    assert summary.frames_placed == 1 and summary.rejected == 0 and summary.held_poses == ()
    ids, poses = graph.poses()
    assert np.allclose(poses[list(ids).index(100)], frame, atol=1e-6)
