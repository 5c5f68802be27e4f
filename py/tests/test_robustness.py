"""Degenerate inputs give results or ordinary exceptions, never a Rust panic
(pyo3's PanicException derives from BaseException, so `except Exception`
would not catch it)."""

import numpy as np
import pytest

import vpctl

EMPTY = vpctl.scene.Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
CAM = vpctl.scene.Camera.look_at(8, 8, 60.0, [0.0, 1.0, 5.0], [0.0, 0.0, 0.0])


def test_empty_mesh_queries_return_misses():
    caster = vpctl.scene.RayCaster(EMPTY)
    hits = caster.closest_hits(np.zeros((2, 3)), np.array([[0, 0, 1.0], [1.0, 0, 0]]))
    assert np.all(np.isinf(hits["t"])) and np.all(hits["face"] == -1)
    r = vpctl.sim.render(EMPTY, caster, CAM)
    assert np.all(r["depth"] == 0) and np.all(r["face_id"] == -1)
    maps = vpctl.sim.VirtualMvs().reconstruct(EMPTY, caster, [CAM] * 3)
    assert all(np.all(m == 0) for m in maps)
    assert len(vpctl.labelgen.generate_labels([])) == 0


@pytest.mark.parametrize(
    "call, exc",
    [
        (lambda: vpctl.planner.plan_grid(EMPTY), ValueError),
        (lambda: vpctl.planner.plan(EMPTY, []), ValueError),
        (lambda: vpctl.forest.ConfidenceImage(np.zeros((1, 1, 0), dtype=np.float32), 8, 8, 8), ValueError),
        (lambda: vpctl.mission.export(vpctl.planner.Plan.from_json('{"format_version": 1, "waypoints": []}')),
         ValueError),
        (lambda: vpctl.planner.Plan.from_json('{"format_version": 99, "waypoints": []}'), ValueError),
        (lambda: vpctl.planner.Plan.from_json("not json"), ValueError),
        (lambda: vpctl.scene.write_depth_map("/nonexistent/x.bin", np.zeros((0, 0), dtype=np.float32)), ValueError),
        (lambda: vpctl.scene.write_depth_map("/nonexistent/x.bin", np.ones((2, 2), dtype=np.float32)), OSError),
        (lambda: vpctl.forest.sparsification(np.zeros(0, dtype=np.float32), np.zeros(0, dtype=bool)), ValueError),
        (lambda: vpctl.scene.RayCaster(EMPTY).render_depth(CAM) and vpctl.scene.Camera(0, 8, 1, 1, 1, 1, np.eye(4)),
         ValueError),
    ],
)
def test_degenerate_inputs_raise_ordinary_exceptions(call, exc):
    with pytest.raises(exc):
        call()
