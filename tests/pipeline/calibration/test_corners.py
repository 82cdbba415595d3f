"""Edge-based marker corners against the simulator's exact ground truth."""

from __future__ import annotations

import numpy as np

from pipeline.calibration.config import CalibrationConfig
from pipeline.calibration.corners import refine_corners_by_edges
from pipeline.calibration.patterns import make_layout
from pipeline.calibration.pnp import calibrate_camera, detect_markers
from pipeline.cave import box_cave
from pipeline.sim.walls import marker_corners_px
from tests.pipeline.calibration.synthetic import render, small_cameras


def test_edge_corners_are_closer_to_the_truth_than_opencv_subpix() -> None:
    cave = box_cave()
    layout = make_layout(cave)
    cam = small_cameras(cave, 1)[0]
    img = render(cam, cave, layout, seed=5)
    subpix = detect_markers(img, layout.dictionary, "subpix")
    edges = detect_markers(img, layout.dictionary, "edges")
    assert np.array_equal(subpix.ids, edges.ids) and len(edges.ids) >= 20
    truth = marker_corners_px(cam, layout)
    gt = np.stack([truth[int(i)] for i in edges.ids])
    rms = {
        name: float(np.sqrt(np.mean(np.sum((d.corners_px - gt) ** 2, axis=2))))
        for name, d in (("subpix", subpix), ("edges", edges))
    }
    assert rms["edges"] < 0.3 and rms["edges"] < 0.8 * rms["subpix"], rms
    res = calibrate_camera("cam01", [edges], layout, CalibrationConfig(corner_refinement="edges"))
    assert res.rms_px < 0.3 and res.corners_rejected == 0, res.summary()
    assert np.linalg.norm(res.camera.center_m - cam.center_m) < 0.02


def test_a_quad_without_clean_edges_keeps_its_corners() -> None:
    flat = np.full((100, 100), 128, np.uint8)
    quad = np.array([[[20.0, 20.0], [60.0, 20.0], [60.0, 60.0], [20.0, 60.0]]])
    assert np.array_equal(refine_corners_by_edges(flat, quad), quad)
