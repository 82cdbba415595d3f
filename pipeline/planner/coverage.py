"""Coverage maps of a camera set: who sees each joint of a standing person, and how well it triangulates.

For every floor cell (:class:`FloorGrid`), standing people of several heights and facings
(:func:`standing_poses`, the simulator's body model) are placed on the cell's centre. Then:

- **visibility** (:func:`see`), the simulator's own model (``pipeline.sim.views``) vectorised over
  cells, poses and cameras: a joint is *in view* of a camera when it lies in front of it, projects
  inside the image and the straight line to it crosses no wall (:func:`pipeline.planner.room.wall_blocks`);
  it is *hidden* when the person's own body hides it (the simulator's occluding spheres along the
  torso, head, thighs and upper arms; the face turned away; the far ear). The person is *detected*
  in a view when at least ``faults.min_visible_keypoints`` joints are seen and the body is at least
  ``faults.min_box_height_px`` tall there. A joint is *seen* by a camera when it is in view, not hidden
  and the person is detected: the coverage count. Only the person herself occludes: other people and
  furniture are not modelled (one navigator in an empty CAVE).
- **expected 3D joint error** (:func:`monte_carlo_errors`): the simulator's 2D noise model
  (``FaultConfig``: pixel noise scaled with the person's size in the image and the joint's COCO
  sigma, hidden or dropped joints guessed with more noise and a low score, whole-person misses,
  joints outside the image scored 0) drawn ``samples`` times, put through the pipeline's real
  robust triangulation (``pipeline.triangulation.dlt.triangulate`` with the person-size outlier
  floor the reconstructor uses), compared with the truth: the mean joint error of the valid joints
  (MPJPE) and the fraction of joints triangulated.

Everything is vectorised in numpy; chunks bound the memory.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.cave import CaveGeometry
from pipeline.planner.config import PlannerConfig
from pipeline.planner.room import REGIONS, Room, check_cameras, floor_polygon, inside, regions, wall_blocks
from pipeline.planner.room import wall_distances as _wall_distances
from pipeline.sim.body import MotionStyle, body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from pipeline.sim.views import _FACE, _NOISE_REL, _REF_HEIGHT_PX, FaultConfig, body_spheres
from pipeline.skeleton import JOINT_NAMES, NUM_JOINTS, J
from pipeline.triangulation.config import TriangulationParams
from pipeline.triangulation.dlt import CameraRig, triangulate

F64 = NDArray[np.float64]
B = NDArray[np.bool_]

#: points per triangulation call (bounds the memory of the Monte Carlo).
CHUNK_POINTS = 60_000
_CLEARANCE_M = 0.03  # views.occluded's clearance: a sphere (nearly) containing the point never hides it
_AWAY_COS = -0.1  # views.face_hidden: the face is hidden when turned further away than this


# --- the floor and the people ------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class FloorGrid:
    """The floor cells of a map.

    x_m: (NX,) cell-centre x; y_m: (NY,) cell-centre y (metres, ascending).
    used: (NY, NX) True for cells inside the room and at least the clearance from every wall.
    region: (NY, NX) region names (``centre``, ``inner``, ``edges``, ``corners``; "" for unused cells).
    """

    x_m: F64
    y_m: F64
    used: B
    region: NDArray[np.str_]

    def __post_init__(self) -> None:
        shape = (len(self.y_m), len(self.x_m))
        if self.used.shape != shape or self.region.shape != shape:
            raise ValueError(f"used and region must be {shape}, got {self.used.shape}, {self.region.shape}")

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.y_m), len(self.x_m)

    @property
    def cells_xy(self) -> F64:
        """(G, 2) centres of the used cells, row-major (y, then x)."""
        xx, yy = np.meshgrid(self.x_m, self.y_m)
        out: F64 = np.stack([xx[self.used], yy[self.used]], axis=1)
        return out

    def to_map(self, values: F64) -> F64:
        """(G, ...) values of the used cells -> (NY, NX, ...) with NaN elsewhere."""
        v = np.asarray(values, dtype=np.float64)
        out = np.full((*self.shape, *v.shape[1:]), np.nan)
        out[self.used] = v
        return out


def floor_grid(room: Room, step_m: float, clearance_m: float, band_m: float) -> FloorGrid:
    """Cells of side ``step_m`` over the room's bounding box, centred in it."""
    x0, y0, x1, y1 = room.bounds
    nx = max(1, round((x1 - x0) / step_m))
    ny = max(1, round((y1 - y0) / step_m))
    xs = x0 + (x1 - x0) * (np.arange(nx) + 0.5) / nx
    ys = y0 + (y1 - y0) * (np.arange(ny) + 0.5) / ny
    xx, yy = np.meshgrid(xs, ys)
    xy = np.stack([xx, yy], axis=-1)
    used = inside(room, xy) & (_wall_distances(room, xy).min(axis=-1) >= clearance_m)
    if not np.any(used):
        raise ValueError(f"no floor cell of {step_m} m is {clearance_m} m clear of the walls")
    reg = np.where(used, regions(room, xy, band_m), "")
    return FloorGrid(xs, ys, used, reg)


@dataclass(frozen=True, slots=True)
class Poses:
    """Standing people placed at the floor origin.

    joints_m: (P, 17, 3) COCO joints, metres; height_m and facing_deg: (P,) of each.
    """

    joints_m: F64
    height_m: F64
    facing_deg: F64


def standing_poses(heights_m: Sequence[float], facings_deg: Sequence[float], seed: int = 0) -> Poses:
    """One quiet standing pose (the simulator's body and kinematics) per height x facing, at (0, 0)."""
    style = MotionStyle(gesture_rate_hz=0.0, sway_m=0.0, look_deg=0.0)
    joints, hs, fs = [], [], []
    for h in heights_m:
        body = body_from_height(float(h))
        for f in facings_deg:
            script = MotionScript((Segment("still", 0.1, gestures=()),), (0.0, 0.0), float(f))
            joints.append(simulate_user(script, body, fps=30.0, seed=seed, style=style).joints_m[0])
            hs.append(float(h))
            fs.append(float(f))
    return Poses(np.stack(joints), np.array(hs), np.array(fs))


# --- visibility ---------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Sight:
    """What each camera sees of each placed person: arrays (C, G, P, ...) for C cameras, G cells, P poses.

    uv_px: (C, G, P, 17, 2) projected pixels (NaN behind the camera).
    in_view: (C, G, P, 17) in front, inside the image and not behind a wall.
    hidden: (C, G, P, 17) in view but hidden by the person's own body (or the face turned away).
    body_px: (C, G, P) the person's size in the image (the larger side of the box of all
        joints in front of the camera), pixels; what the simulator scales the noise with.
    detected: (C, G, P) the detector would report the person (enough joints seen, tall enough).
    """

    uv_px: F64
    in_view: B
    hidden: B
    body_px: F64
    detected: B

    @property
    def seen(self) -> B:
        """(C, G, P, 17) the joint counts as seen by the camera."""
        out: B = self.in_view & ~self.hidden & self.detected[..., None]
        return out


def _spheres(poses: Poses) -> tuple[F64, F64]:
    """(P, S, 3) centres and (P, S) radii of the simulator's occluding spheres of each pose."""
    parts = [body_spheres(j) for j in poses.joints_m]
    s = max(len(r) for _, r in parts)
    centres = np.zeros((len(parts), s, 3))
    radii = np.zeros((len(parts), s))  # radius 0 pads: hides nothing
    for i, (c, r) in enumerate(parts):
        centres[i, : len(r)] = c
        radii[i, : len(r)] = r
    return centres, radii


def _hidden_by_body(eye: F64, points: F64, centres: F64, radii: F64, own: B) -> B:
    """views.occluded vectorised: (G, P, 17, 3) points, (G, P, S, 3) centres, (P, S) radii, (P, 17, S) own."""
    v = points - eye
    length = np.linalg.norm(v, axis=-1)  # (G, P, J)
    u = v / np.maximum(length, 1e-9)[..., None]
    w = centres - eye  # (G, P, S, 3)
    along = np.einsum("gpjk,gpsk->gpjs", u, w)
    perp2 = np.maximum((w * w).sum(axis=-1)[:, :, None, :] - along * along, 0.0)
    r = radii[None, :, None, :]
    hides = (perp2 < r * r) & (along > 0) & (along < length[..., None] - r - _CLEARANCE_M)
    out: B = np.any(hides & ~own[None], axis=-1)
    return out


def _face_hidden(eye: F64, points: F64) -> B:
    """views.face_hidden vectorised over (G, P, 17, 3) points -> (G, P, 17)."""
    head = (points[:, :, J["l_ear"]] + points[:, :, J["r_ear"]]) / 2.0
    to_cam = eye - head
    to_cam /= np.maximum(np.linalg.norm(to_cam, axis=-1, keepdims=True), 1e-9)
    fwd = points[:, :, J["nose"]] - head
    fwd /= np.maximum(np.linalg.norm(fwd, axis=-1, keepdims=True), 1e-9)
    across = points[:, :, J["l_ear"]] - points[:, :, J["r_ear"]]
    across /= np.maximum(np.linalg.norm(across, axis=-1, keepdims=True), 1e-9)
    out = np.zeros(points.shape[:3], dtype=bool)
    away = (fwd * to_cam).sum(axis=-1) < _AWAY_COS
    for j in _FACE:
        out[:, :, j] = away
    side = (across * to_cam).sum(axis=-1)
    out[:, :, J["l_ear"]] |= side < -0.5
    out[:, :, J["r_ear"]] |= side > 0.5
    return out


def place(poses: Poses, cells_xy: F64) -> F64:
    """(G, P, 17, 3) the poses moved onto each of the (G, 2) cell centres."""
    offset = np.zeros((len(cells_xy), 1, 1, 3))
    offset[:, 0, 0, :2] = cells_xy
    out: F64 = poses.joints_m[None] + offset
    return out


def see(room: Room, cameras: Sequence[Camera], poses: Poses, cells_xy: F64, faults: FaultConfig) -> Sight:
    """The visibility of every pose on every cell in every camera (the simulator's model, see the module)."""
    rig = CameraRig.from_cameras(cameras)
    pts = place(poses, cells_xy)  # (G, P, J, 3)
    g, p = pts.shape[:2]
    flat = pts.reshape(-1, 3)
    uv = rig.project(flat).reshape(len(rig), g, p, NUM_JOINTS, 2)
    z = (flat @ rig.Rt[:, :, :3].transpose(0, 2, 1) + rig.Rt[:, None, :, 3])[..., 2]
    z = z.reshape(len(rig), g, p, NUM_JOINTS)
    sizes = np.array([cam.image_size for cam in cameras], dtype=np.float64)[:, None, None, None, :]
    finite = np.all(np.isfinite(uv), axis=-1)
    with np.errstate(invalid="ignore"):
        in_image = finite & (z > 0.05) & np.all((uv >= 0) & (uv < sizes), axis=-1)
    centres_local, radii = _spheres(poses)
    offset = np.zeros((g, 1, 1, 3))
    offset[:, 0, 0, :2] = cells_xy
    centres = centres_local[None] + offset  # (G, P, S, 3)
    own = (
        np.linalg.norm(poses.joints_m[:, :, None, :] - centres_local[:, None, :, :], axis=-1)
        < radii[:, None, :] + _CLEARANCE_M
    )  # (P, J, S): translation does not change it
    hidden = np.zeros_like(in_image)
    in_view = in_image.copy()
    for c, cam in enumerate(cameras):
        eye = cam.center_m
        in_view[c] &= ~wall_blocks(room, eye, pts)
        if faults.occlusion:
            hidden[c] = (_hidden_by_body(eye, pts, centres, radii, own) | _face_hidden(eye, pts)) & in_view[c]
    lo = np.where(finite[..., None], uv, np.inf).min(axis=3)
    hi = np.where(finite[..., None], uv, -np.inf).max(axis=3)
    extent = np.where(np.isfinite(hi - lo), hi - lo, 0.0)
    body_px = np.maximum(extent.max(axis=-1), 1.0)
    n_seen = np.count_nonzero(in_view & ~hidden, axis=-1)
    detected = (n_seen >= faults.min_visible_keypoints) & (body_px >= faults.min_box_height_px)
    return Sight(uv, in_view, hidden, body_px, detected)


# --- the Monte Carlo ------------------------------------------------------------------------------


def _person_size_px(kp: F64, ok: B) -> F64:
    """pipeline.triangulation.reconstructor.person_size_px over (..., 17, 2): the larger side of the
    confident keypoints' box (0 with fewer than two)."""
    lo = np.where(ok[..., None], kp, np.inf).min(axis=-2)
    hi = np.where(ok[..., None], kp, -np.inf).max(axis=-2)
    ext = (hi - lo).max(axis=-1)
    out: F64 = np.where(ok.sum(axis=-1) >= 2, ext, 0.0)
    return out


def draw_detections(
    sight: Sight, sizes_px: F64, faults: FaultConfig, samples: int, rng: np.random.Generator
) -> tuple[F64, F64]:
    """The simulator's detector faults drawn ``samples`` times for every (camera, cell, pose).

    sizes_px: (C, 2) image (width, height). Returns ((C, G, P, S, 17, 2) keypoints, (C, G, P, S, 17)
    scores): as ``pipeline.sim.views`` makes them, with score 0 where the person is missed or the
    joint is out of view.
    """
    c, g, p = sight.detected.shape
    shape = (c, g, p, samples, NUM_JOINTS)
    body = np.maximum(sight.body_px, 40.0)[..., None, None]  # (C, G, P, 1, 1)
    sigma = faults.pixel_noise_px * body / _REF_HEIGHT_PX * _NOISE_REL  # (C, G, P, 1, 17)
    hidden = sight.hidden[:, :, :, None, :]
    drop = rng.random(shape) < faults.joint_drop_rate
    guessed = hidden | drop
    scale = np.where(guessed, 1.0 + faults.hidden_noise_scale, 1.0)
    w = sizes_px[:, None, None, None, None, :]
    uv = sight.uv_px[:, :, :, None]
    front = np.all(np.isfinite(uv), axis=-1, keepdims=True)
    kp = np.where(front, uv, w / 2.0) + rng.standard_normal((*shape, 2)) * (sigma * scale)[..., None]
    kp = np.clip(kp, 0.0, w - 1.0)
    m, sd = faults.score_visible
    lo, hi = faults.score_hidden
    scores = np.clip(rng.normal(m, sd, shape), 0.3, 1.0)
    scores = np.where(guessed, rng.uniform(lo, hi, shape), scores)
    missed = rng.random((c, g, p, samples)) < faults.person_miss_rate
    reported = sight.detected[:, :, :, None] & ~missed
    scores = np.where(sight.in_view[:, :, :, None] & reported[..., None], scores, 0.0)
    return kp, scores


def monte_carlo_errors(
    cameras: Sequence[Camera],
    sight: Sight,
    truth_m: F64,
    faults: FaultConfig,
    params: TriangulationParams,
    samples: int,
    rng: np.random.Generator,
) -> F64:
    """(G, P, S, 17) 3D error of each joint in each draw, metres; NaN where it was not triangulated.

    truth_m: (G, P, 17, 3) the placed poses. The draws go through ``triangulate`` with the same
    weights and person-size outlier floor as the reconstructor.
    """
    rig = CameraRig.from_cameras(cameras)
    sizes = np.array([cam.image_size for cam in cameras], dtype=np.float64)
    c, g, p = sight.detected.shape
    per_cell = p * samples * NUM_JOINTS
    step = max(1, CHUNK_POINTS // per_cell)
    out = np.full((g, p, samples, NUM_JOINTS), np.nan)
    for start in range(0, g, step):
        sl = slice(start, min(g, start + step))
        part = Sight(
            sight.uv_px[:, sl],
            sight.in_view[:, sl],
            sight.hidden[:, sl],
            sight.body_px[:, sl],
            sight.detected[:, sl],
        )
        kp, scores = draw_detections(part, sizes, faults, samples, rng)
        ok = np.isfinite(scores) & (scores >= params.min_score) & (scores > 0)
        w = np.where(ok, scores, 0.0)
        size = np.broadcast_to(_person_size_px(kp, ok)[..., None], ok.shape)
        n = kp.shape[1]
        tri = triangulate(
            rig,
            kp.reshape(c, -1, 2),
            w.reshape(c, -1),
            params,
            scale_px=np.ascontiguousarray(size).reshape(c, -1),
        )
        est = tri.points_m.reshape(n, p, samples, NUM_JOINTS, 3)
        truth = truth_m[sl][:, :, None]
        out[sl] = np.where(
            tri.valid.reshape(n, p, samples, NUM_JOINTS), np.linalg.norm(est - truth, axis=-1), np.nan
        )
    return out


# --- the map ---------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class RegionFigures:
    """Means over the cells of one region (or the whole floor).

    cells: how many cells. error_mm: mean of the cells' mean joint error. valid: fraction of joints
    triangulated. views: cameras seeing a joint, on average. covered2: fraction of joints seen by at
    least two cameras.
    """

    cells: int
    error_mm: float
    valid: float
    views: float
    covered2: float

    def to_dict(self) -> dict[str, Any]:
        return {k: _num(getattr(self, k)) for k in ("cells", "error_mm", "valid", "views", "covered2")}


@dataclass(frozen=True, slots=True)
class CoverageMap:
    """The maps of one camera set (arrays (NY, NX) over the grid, NaN on unused cells).

    views: mean number of cameras that see a joint (over joints, heights and facings).
    views_joint: (17, NY, NX) the same per joint.
    covered2: fraction of joints (and heights, facings) seen by at least two cameras.
    error_mm: expected 3D joint error (the Monte Carlo's mean over valid joints, draws, heights,
        facings), millimetres.
    error_joint_mm: (17, NY, NX) the same per joint.
    valid: fraction of joints the triangulation gave.
    regions / floor: the region means and the whole floor's.
    timings_s: seconds spent on ``visibility`` and ``monte_carlo``.
    """

    cameras: tuple[Camera, ...]
    room: Room
    grid: FloorGrid
    config: PlannerConfig
    views: F64
    views_joint: F64
    covered2: F64
    error_mm: F64
    error_joint_mm: F64
    valid: F64
    regions: dict[str, RegionFigures]
    floor: RegionFigures
    timings_s: dict[str, float] = field(default_factory=dict)

    @property
    def worst_region(self) -> str:
        """The region with the largest mean error."""
        known = {k: v.error_mm for k, v in self.regions.items() if np.isfinite(v.error_mm)}
        return max(known, key=lambda k: known[k]) if known else ""

    def to_dict(self) -> dict[str, Any]:
        """The numbers of the map as plain JSON values (NaN -> null)."""
        return {
            "cameras": [camera_summary(c) for c in self.cameras],
            "room": {
                "polygon_xy_m": self.room.polygon_xy.tolist(),
                "height_m": self.room.height_m,
                "walls": [w.name for w in self.room.walls],
            },
            "config": {
                "grid_step_m": self.config.grid_step_m,
                "wall_clearance_m": self.config.wall_clearance_m,
                "heights_m": list(self.config.heights_m),
                "facings_deg": list(self.config.facings_deg),
                "samples": self.config.samples,
                "seed": self.config.seed,
                "region_band_m": self.config.region_band_m,
                "pixel_noise_px": self.config.faults.pixel_noise_px,
                "person_miss_rate": self.config.faults.person_miss_rate,
                "occlusion": "the person's own body (simulator spheres, face turned away, far ear) "
                "and the walls; nobody else in the room"
                if self.config.faults.occlusion
                else "walls only",
            },
            "grid": {
                "x_m": self.grid.x_m.tolist(),
                "y_m": self.grid.y_m.tolist(),
                "region": self.grid.region.tolist(),
            },
            "joints": list(JOINT_NAMES),
            "maps": {
                "views": _nums(self.views),
                "covered2": _nums(self.covered2),
                "error_mm": _nums(self.error_mm),
                "valid": _nums(self.valid),
                "views_joint": _nums(self.views_joint),
                "error_joint_mm": _nums(self.error_joint_mm),
            },
            "regions": {k: v.to_dict() for k, v in self.regions.items()},
            "floor": self.floor.to_dict(),
            "worst_region": self.worst_region,
            "timings_s": {k: round(v, 4) for k, v in self.timings_s.items()},
        }


def _num(v: float | int) -> float | int | None:
    if isinstance(v, int | np.integer):
        return int(v)
    f = float(v)
    return round(f, 4) if np.isfinite(f) else None


def _nums(a: F64) -> Any:
    """An array as nested lists, rounded, NaN -> None (JSON null)."""
    arr = np.asarray(a, dtype=np.float64)
    out = np.round(arr, 4).astype(object)
    out[~np.isfinite(arr)] = None
    return out.tolist()


def camera_summary(cam: Camera) -> dict[str, Any]:
    """Name, centre, viewing direction and field of view of a camera, for reports."""
    forward = cam.R[2]
    w, h = cam.image_size
    fx, fy = cam.K[0, 0], cam.K[1, 1]
    return {
        "name": cam.name,
        "center_m": [round(float(v), 4) for v in cam.center_m],
        "forward": [round(float(v), 4) for v in forward],
        "pan_deg": round(float(np.degrees(np.arctan2(-forward[0], forward[1]))), 2),
        "tilt_deg": round(float(np.degrees(np.arcsin(np.clip(-forward[2], -1, 1)))), 2),
        "hfov_deg": round(float(np.degrees(2 * np.arctan(w / (2 * fx)))), 2),
        "vfov_deg": round(float(np.degrees(2 * np.arctan(h / (2 * fy)))), 2),
        "image_size": [int(w), int(h)],
    }


def summarise(values: dict[str, F64], mask: B) -> RegionFigures:
    """RegionFigures of the cells under ``mask`` from (NY, NX) maps named error_mm, valid, views, covered2."""

    def mean(name: str) -> float:
        v = values[name][mask]
        v = v[np.isfinite(v)]
        return float(v.mean()) if v.size else float("nan")

    return RegionFigures(int(mask.sum()), mean("error_mm"), mean("valid"), mean("views"), mean("covered2"))


def coverage_map(
    cave: CaveGeometry | Room, cameras: Sequence[Camera], config: PlannerConfig | None = None
) -> CoverageMap:
    """The coverage and expected-error maps of ``cameras`` in the CAVE.

    Raises InputError when the walls do not close, a camera hangs outside the room, or fewer than
    two cameras are given.
    """
    cfg = config or PlannerConfig()
    room = cave if isinstance(cave, Room) else floor_polygon(cave)
    cams = tuple(cameras)
    check_cameras(room, cams, above_walls_m=cfg.above_walls_m)
    t0 = time.perf_counter()
    grid = floor_grid(room, cfg.grid_step_m, cfg.wall_clearance_m, cfg.region_band_m)
    poses = standing_poses(cfg.heights_m, cfg.facings_deg, cfg.seed)
    cells = grid.cells_xy
    sight = see(room, cams, poses, cells, cfg.faults)
    seen = sight.seen  # (C, G, P, J)
    n_views = seen.sum(axis=0)  # (G, P, J)
    t1 = time.perf_counter()
    rng = np.random.default_rng(cfg.seed)
    err = monte_carlo_errors(
        cams, sight, place(poses, cells), cfg.faults, cfg.triangulation, cfg.samples, rng
    )  # (G, P, S, J)
    t2 = time.perf_counter()
    valid = np.isfinite(err)
    with warnings.catch_warnings():  # cells or joints never triangulated stay NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        err_cell = np.nanmean(err.reshape(len(cells), -1), axis=1)
        err_joint = np.nanmean(err, axis=(1, 2))  # (G, J)
    maps = {
        "views": grid.to_map(n_views.mean(axis=(1, 2))),
        "covered2": grid.to_map((n_views >= 2).mean(axis=(1, 2))),
        "error_mm": grid.to_map(1000.0 * err_cell),
        "valid": grid.to_map(valid.mean(axis=(1, 2, 3))),
    }
    figures = {r: summarise(maps, grid.region == r) for r in REGIONS if np.any(grid.region == r)}
    return CoverageMap(
        cameras=cams,
        room=room,
        grid=grid,
        config=cfg,
        views=maps["views"],
        views_joint=np.moveaxis(grid.to_map(n_views.mean(axis=1)), -1, 0),
        covered2=maps["covered2"],
        error_mm=maps["error_mm"],
        error_joint_mm=np.moveaxis(grid.to_map(1000.0 * err_joint), -1, 0),
        valid=maps["valid"],
        regions=figures,
        floor=summarise(maps, grid.used),
        timings_s={"visibility": t1 - t0, "monte_carlo": t2 - t1, "total": t2 - t0},
    )
