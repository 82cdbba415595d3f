"""Virtual cameras: 3D joints -> the same :class:`ViewDetections` the YOLO-pose detector returns.

Faults modelled (:class:`FaultConfig`):

- pixel noise per keypoint, scaled by the person's size in the image and by the joint's
  COCO OKS sigma (hips are noisier than eyes, as in real detectors);
- keypoint confidence: visible joints score high (mean ``score_visible``), hidden ones low;
- visibility: a joint is hidden when it is behind another body part of anyone in the scene
  (torso, head, thighs and upper arms as spheres along the bones), when the face points away
  from the camera (nose, eyes) or the ear is on the far side of the head;
- joints outside the image: score 0 and their xy clipped to the image border. Convention,
  like YOLO-pose: every keypoint always has a finite xy; a score of 0 means "not detected";
- random per-joint dropouts, whole-person misses (also when too few joints are visible or
  the person is tiny), false detections (ghost people with low scores);
- camera timestamps with Gaussian jitter.

Detections come out sorted by box score, best first (as after NMS).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera, project, world_to_camera
from pipeline.errors import InputError
from pipeline.pose.types import ViewDetections
from pipeline.sim.config import FaultConfig
from pipeline.skeleton import NUM_JOINTS, J

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

# COCO keypoint OKS sigmas: how uncertain human annotators (and detectors) are per joint.
COCO_SIGMAS = np.array(
    [
        0.026,
        0.025,
        0.025,
        0.035,
        0.035,
        0.079,
        0.079,
        0.072,
        0.072,
        0.062,
        0.062,
        0.107,
        0.107,
        0.087,
        0.087,
        0.089,
        0.089,
    ]
)
_NOISE_REL = COCO_SIGMAS / COCO_SIGMAS.mean()
_REF_HEIGHT_PX = 600.0
_FACE = (J["nose"], J["l_eye"], J["r_eye"])


# --- visibility (pure) -----------------------------------------------------------------------


def body_spheres(joints_m: F64) -> tuple[F64, F64]:
    """Occluding volumes of one person: (S, 3) sphere centres and (S,) radii, metres."""
    j = np.asarray(joints_m, dtype=np.float64)
    pelvis = (j[J["l_hip"]] + j[J["r_hip"]]) / 2
    neck = (j[J["l_shoulder"]] + j[J["r_shoulder"]]) / 2
    sw = float(np.linalg.norm(j[J["l_shoulder"]] - j[J["r_shoulder"]]))
    centres = [pelvis + f * (neck - pelvis) for f in (0.1, 0.35, 0.6, 0.85)]
    radii = [0.3 * sw] * 4
    centres.append((j[J["l_ear"]] + j[J["r_ear"]]) / 2)
    radii.append(0.09)
    for side in ("l", "r"):
        hip, knee = j[J[f"{side}_hip"]], j[J[f"{side}_knee"]]
        centres += [hip + 0.35 * (knee - hip), hip + 0.7 * (knee - hip)]
        radii += [0.075, 0.065]
        sh, el = j[J[f"{side}_shoulder"]], j[J[f"{side}_elbow"]]
        centres.append((sh + el) / 2)
        radii.append(0.045)
    c = np.asarray(centres)
    r = np.asarray(radii)
    ok = np.all(np.isfinite(c), axis=1)
    return c[ok], r[ok]


def occluded(
    eye_m: F64, points_m: F64, centres: F64, radii: F64, clearance_m: float = 0.03
) -> NDArray[np.bool_]:
    """(N,) True where the line of sight from ``eye_m`` to a point passes through a sphere in front of it.

    A sphere that (nearly) contains the point itself does not hide it.
    """
    pts = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    if len(centres) == 0 or len(pts) == 0:
        return np.zeros(len(pts), dtype=bool)
    v = pts - eye_m
    length = np.linalg.norm(v, axis=1)
    u = v / np.maximum(length, 1e-9)[:, None]
    w = centres - eye_m  # (S, 3)
    along = u @ w.T  # (N, S) distance along each ray to the sphere's closest approach
    perp = np.linalg.norm(w[None, :, :] - along[:, :, None] * u[:, None, :], axis=2)
    own = np.linalg.norm(pts[:, None, :] - centres[None, :, :], axis=2) < radii[None, :] + clearance_m
    hides = (perp < radii[None, :]) & (along > 0) & (along < length[:, None] - radii[None, :] - clearance_m)
    return np.any(hides & ~own, axis=1)


def face_hidden(eye_m: F64, joints_m: F64, away_cos: float = -0.1) -> NDArray[np.bool_]:
    """(17,) True for face keypoints on the far side of the head from the camera."""
    j = np.asarray(joints_m, dtype=np.float64)
    out = np.zeros(NUM_JOINTS, dtype=bool)
    head = (j[J["l_ear"]] + j[J["r_ear"]]) / 2
    to_cam = eye_m - head
    to_cam /= max(float(np.linalg.norm(to_cam)), 1e-9)
    fwd = j[J["nose"]] - head
    fwd /= max(float(np.linalg.norm(fwd)), 1e-9)
    if float(fwd @ to_cam) < away_cos:
        out[list(_FACE)] = True
    across = j[J["l_ear"]] - j[J["r_ear"]]
    across /= max(float(np.linalg.norm(across)), 1e-9)
    side = float(across @ to_cam)
    if side < -0.5:
        out[J["l_ear"]] = True
    if side > 0.5:
        out[J["r_ear"]] = True
    return out


@dataclass(frozen=True, slots=True)
class Visibility:
    """Where one person's joints land in one camera.

    uv_px: (17, 2) projected pixels (NaN behind the camera). in_image: (17,) in front and
    inside the image. hidden: (17,) in the image but occluded / facing away.
    """

    uv_px: F64
    in_image: NDArray[np.bool_]
    hidden: NDArray[np.bool_]


def all_spheres(people_joints: list[F64]) -> tuple[F64, F64]:
    """The occluding spheres of everyone: (S, 3) centres and (S,) radii."""
    spheres = [body_spheres(pj) for pj in people_joints]
    return np.concatenate([s[0] for s in spheres]), np.concatenate([s[1] for s in spheres])


def visibility(
    cam: Camera,
    people_joints: list[F64],
    person: int,
    occlusion: bool = True,
    spheres: tuple[F64, F64] | None = None,
) -> Visibility:
    """Visibility of person ``person``'s joints in ``cam``, with everyone in ``people_joints`` occluding."""
    joints = np.asarray(people_joints[person], dtype=np.float64)
    uv = project(cam, joints)
    z = world_to_camera(cam, joints)[:, 2]
    w, h = cam.image_size
    finite = np.all(np.isfinite(uv), axis=1)
    inside = finite & (z > 0.05)
    inside[inside] &= (uv[inside, 0] >= 0) & (uv[inside, 0] < w) & (uv[inside, 1] >= 0) & (uv[inside, 1] < h)
    hidden = np.zeros(NUM_JOINTS, dtype=bool)
    if occlusion:
        eye = cam.center_m
        centres, radii = spheres if spheres is not None else all_spheres(people_joints)
        hidden = occluded(eye, joints, centres, radii) | face_hidden(eye, joints)
    return Visibility(uv, inside, hidden & inside)


# --- detections ------------------------------------------------------------------------------

# A frontal standing person in a unit box (x right, y down), for ghost detections.
_GHOST_TEMPLATE = np.array(
    [
        [0.5, 0.08],
        [0.46, 0.06],
        [0.54, 0.06],
        [0.41, 0.08],
        [0.59, 0.08],
        [0.3, 0.2],
        [0.7, 0.2],
        [0.22, 0.37],
        [0.78, 0.37],
        [0.2, 0.52],
        [0.8, 0.52],
        [0.38, 0.53],
        [0.62, 0.53],
        [0.37, 0.75],
        [0.63, 0.75],
        [0.37, 0.96],
        [0.63, 0.96],
    ]
)


def _person_detection(
    cam: Camera, vis: Visibility, rng: np.random.Generator, faults: FaultConfig
) -> tuple[F64, float, F64, F64] | None:
    """(box, box score, keypoints xy, keypoint scores) of one person, or None when not detected."""
    w, h = cam.image_size
    seen = vis.in_image & ~vis.hidden
    if seen.sum() < faults.min_visible_keypoints:
        return None
    front = np.all(np.isfinite(vis.uv_px), axis=1)
    pts = vis.uv_px[front]
    x1, y1 = pts.min(axis=0)
    x2, y2 = pts.max(axis=0)
    body_h = max(y2 - y1, x2 - x1, 1.0)
    if body_h < faults.min_box_height_px:
        return None
    if rng.random() < faults.person_miss_rate:
        return None
    sigma = faults.pixel_noise_px * max(body_h, 40.0) / _REF_HEIGHT_PX * _NOISE_REL
    n_drop = rng.random(NUM_JOINTS) < faults.joint_drop_rate
    scale = np.where(vis.hidden | n_drop, 1.0 + faults.hidden_noise_scale, 1.0)
    kp = np.where(front[:, None], vis.uv_px, np.array([w / 2, h / 2]))
    kp = kp + rng.standard_normal((NUM_JOINTS, 2)) * (sigma * scale)[:, None]
    kp[:, 0] = np.clip(kp[:, 0], 0.0, w - 1.0)
    kp[:, 1] = np.clip(kp[:, 1], 0.0, h - 1.0)
    m, sd = faults.score_visible
    lo, hi = faults.score_hidden
    scores = np.clip(rng.normal(m, sd, NUM_JOINTS), 0.3, 1.0)
    scores = np.where(vis.hidden | n_drop, rng.uniform(lo, hi, NUM_JOINTS), scores)
    scores = np.where(vis.in_image, scores, 0.0)
    bw = x2 - x1
    box = np.array(
        [
            x1 - 0.08 * max(bw, 0.3 * body_h),
            y1 - 0.12 * body_h,
            x2 + 0.08 * max(bw, 0.3 * body_h),
            y2 + 0.05 * body_h,
        ]
    )
    box = np.clip(box, [0, 0, 0, 0], [w - 1, h - 1, w - 1, h - 1])
    box_score = float(np.clip(0.45 + 0.5 * seen.mean() + rng.normal(0, 0.04 if sd > 0 else 0.0), 0.3, 0.97))
    return box, box_score, kp, scores


def _ghost(cam: Camera, rng: np.random.Generator) -> tuple[F64, float, F64, F64]:
    w, h = cam.image_size
    bh = rng.uniform(0.15, 0.6) * h
    bw = bh * rng.uniform(0.3, 0.5)
    x1, y1 = rng.uniform(0, w - bw), rng.uniform(0, h - bh)
    kp = np.array([x1, y1]) + _GHOST_TEMPLATE * np.array([bw, bh]) + rng.normal(0, 0.05 * bh, (NUM_JOINTS, 2))
    kp = np.clip(kp, 0, [w - 1, h - 1])
    return (
        np.array([x1, y1, x1 + bw, y1 + bh]),
        float(rng.uniform(0.3, 0.55)),
        kp,
        rng.uniform(0.05, 0.6, NUM_JOINTS),
    )


def observe_with_ids(
    cameras: list[Camera],
    people_joints: list[F64],
    frame_index: int,
    timestamp_s: float,
    rng: np.random.Generator,
    faults: FaultConfig | None = None,
) -> list[tuple[ViewDetections, I64]]:
    """Like :func:`observe`, plus per detection the index of the true person (-1 = false detection)."""
    faults = faults or FaultConfig()
    people = [np.asarray(p, dtype=np.float64) for p in people_joints]
    for i, p in enumerate(people):
        if p.shape != (NUM_JOINTS, 3):
            raise InputError(f"person {i}: joints must have shape (17, 3), got {p.shape}")
    spheres = all_spheres(people) if faults.occlusion and people else None
    out = []
    for cam in cameras:
        dets: list[tuple[F64, float, F64, F64]] = []
        ids: list[int] = []
        for i in range(len(people)):
            vis = visibility(cam, people, i, faults.occlusion, spheres)
            det = _person_detection(cam, vis, rng, faults)
            if det is not None:
                dets.append(det)
                ids.append(i)
        for _ in range(int(rng.poisson(faults.false_detection_rate))):
            dets.append(_ghost(cam, rng))
            ids.append(-1)
        order = sorted(range(len(dets)), key=lambda k: -dets[k][1])
        ts = float(
            timestamp_s + (rng.normal(0.0, faults.timestamp_jitter_s) if faults.timestamp_jitter_s else 0.0)
        )
        if not dets:
            view = ViewDetections.empty(cam.name, int(frame_index), ts, cam.image_size)
        else:
            view = ViewDetections(
                camera=cam.name,
                frame_index=int(frame_index),
                timestamp_s=ts,
                image_size=cam.image_size,
                boxes_xyxy=np.array([dets[k][0] for k in order], dtype=np.float32),
                box_scores=np.array([dets[k][1] for k in order], dtype=np.float32),
                keypoints_xy=np.array([dets[k][2] for k in order], dtype=np.float32),
                keypoint_scores=np.array([dets[k][3] for k in order], dtype=np.float32),
            )
        out.append((view, np.array([ids[k] for k in order], dtype=np.int64)))
    return out


def observe(
    cameras: list[Camera],
    people_joints: list[F64],
    frame_index: int,
    timestamp_s: float,
    rng: np.random.Generator,
    faults: FaultConfig | None = None,
) -> list[ViewDetections]:
    """What the pose detector would report in each camera for people at ``people_joints`` ((17, 3) each)."""
    return [v for v, _ in observe_with_ids(cameras, people_joints, frame_index, timestamp_s, rng, faults)]
