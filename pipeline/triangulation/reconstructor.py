"""The triangulation stage's façade: tracked 2D views in, 3D skeletons with user ids out.

Used the same way by the live runtime and the offline ``process`` command::

    rec = Reconstructor(cameras, ReconstructionConfig())
    people = rec.update(tracked_views, timestamp_s)     # list[Person3D]
    change = navigator.update(people, timestamp_s)       # NavigatorSelector, separately
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera, undistort_points
from pipeline.errors import InputError
from pipeline.identity.body import body_measures
from pipeline.skeleton import FLIP_PAIRS, NUM_JOINTS
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.association import FLIP_PERM, associate
from pipeline.triangulation.config import ReconstructionConfig
from pipeline.triangulation.dlt import CameraRig, triangulate, triangulate_linear
from pipeline.triangulation.tracks3d import Candidate, Tracks3D
from pipeline.triangulation.types import Person3D

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
MIN_VIEW_AGREEMENT = 0.5  # a view must be used for half its confident joints to stay in a person


def person_size_px(keypoints_xy: F64, confident: NDArray[np.bool_]) -> F64:
    """(P, 17, 2) keypoints -> (P,) the larger side of each person's confident-keypoint box, pixels
    (0 with fewer than two confident keypoints)."""
    pts = np.where(confident[..., None], keypoints_xy, np.nan)
    out = np.zeros(keypoints_xy.shape[0])
    enough = confident.sum(axis=1) >= 2
    if np.any(enough):
        p = pts[enough]
        extent = np.nanmax(p, axis=1) - np.nanmin(p, axis=1)
        out[enough] = extent.max(axis=1)
    return out


_PAIRED = np.array(sorted({j for pair in FLIP_PAIRS for j in pair}))


def flipped_views(projected_px: F64, keypoints_px: F64, weights: F64, size_px: F64,
                  ratio: float = 0.6, min_frac: float = 0.03) -> NDArray[np.bool_]:
    """(R,) True for views whose 2D skeleton has left and right swapped.

    projected_px: (R, 17, 2) the 3D person projected into each view; keypoints_px, weights: that
    view's (R, 17, 2) keypoints and (R, 17) weights (0 = unseen); size_px: (R,) person size.
    A view is flipped when its left/right joints, swapped, fit the projection better by ``ratio``
    and the unswapped misfit is large (``min_frac`` x size: a person seen from the side, whose left
    and right project close together, is never flipped). Pooled over all paired joints, so a
    single noisy joint cannot flip a view.
    """
    ok_proj = np.all(np.isfinite(projected_px), axis=2)
    sw_uv, sw_w = keypoints_px[:, FLIP_PERM], weights[:, FLIP_PERM]
    mask = (weights > 0) & (sw_w > 0) & ok_proj
    mask[:, np.setdiff1d(np.arange(NUM_JOINTS), _PAIRED)] = False
    n = mask.sum(axis=1)
    e_keep = np.where(mask, np.linalg.norm(keypoints_px - projected_px, axis=2), 0.0).sum(axis=1)
    e_swap = np.where(mask, np.linalg.norm(sw_uv - projected_px, axis=2), 0.0).sum(axis=1)
    e_keep, e_swap = e_keep / np.maximum(n, 1), e_swap / np.maximum(n, 1)
    out: NDArray[np.bool_] = (n >= 4) & (e_swap < ratio * e_keep) & (e_keep > min_frac * size_px)
    return out


class Reconstructor:
    """Cross-view association, robust triangulation and 3D tracks, one multi-view frame at a time."""

    def __init__(self, cameras: Sequence[Camera], config: ReconstructionConfig | None = None) -> None:
        self.config = config or ReconstructionConfig()
        self.rig = CameraRig.from_cameras(cameras)
        self._cam_index = {name: i for i, name in enumerate(self.rig.names)}
        self._first_user_id = 1
        self.tracks = self._new_tracks()

    def _new_tracks(self) -> Tracks3D:
        tracks = Tracks3D(self.config.tracks, memory_s=self.config.association.memory_s,
                          identity=self.config.identity)
        tracks.number_from(self._first_user_id)
        return tracks

    def number_from(self, first_user_id: int) -> None:
        """New users get ids from ``first_user_id`` on (also after a :meth:`reset`)."""
        self._first_user_id = max(self._first_user_id, int(first_user_id))
        self.tracks.number_from(self._first_user_id)

    @property
    def cameras(self) -> tuple[Camera, ...]:
        return self.rig.cameras

    def reset(self) -> None:
        """Forget every user and (camera, track) link (e.g. when the pipeline restarts)."""
        self.tracks = self._new_tracks()

    def _check(self, views: Sequence[TrackedView], timestamp_s: float) -> None:
        if not math.isfinite(timestamp_s):
            raise InputError(f"timestamp_s must be finite, got {timestamp_s!r}")
        seen: set[str] = set()
        for v in views:
            if not isinstance(v, TrackedView):
                raise InputError(f"expected TrackedView objects, got {type(v).__name__}")
            if v.camera not in self._cam_index:
                raise InputError(f"view from unknown camera {v.camera!r}; calibrated cameras are "
                                 f"{', '.join(self.rig.names)}")
            if v.camera in seen:
                raise InputError(f"two views from camera {v.camera!r} in one frame")
            seen.add(v.camera)

    def _stack(self, clusters: list[list[int]], cam_idx: NDArray[np.int64], uv_all: F64, xy_all: F64,
               w_all: F64, size_all: F64) -> tuple[F64, F64, F64, F64]:
        """(C, K*17, ...) arrays of all clusters: cluster k's joints are columns k*17 .. k*17+16."""
        c_count, k_count = len(self.rig), len(clusters)
        uv = np.full((c_count, k_count * NUM_JOINTS, 2), np.nan)
        xy = np.full((c_count, k_count * NUM_JOINTS, 2), np.nan)
        w = np.zeros((c_count, k_count * NUM_JOINTS))
        size = np.zeros((c_count, k_count * NUM_JOINTS))
        for k, members in enumerate(clusters):
            sl = slice(k * NUM_JOINTS, (k + 1) * NUM_JOINTS)
            for r in members:
                uv[cam_idx[r], sl], xy[cam_idx[r], sl], w[cam_idx[r], sl] = uv_all[r], xy_all[r], w_all[r]
                size[cam_idx[r], sl] = size_all[r]
        return uv, xy, w, size

    def _flipped_rows(self, clusters: list[list[int]], cam_idx: NDArray[np.int64], xy: F64, w: F64,
                      uv_all: F64, w_all: F64, size_all: F64) -> list[int]:
        """Rows (views of people seen by at least three cameras) whose left and right are swapped.

        Each view is judged against the person triangulated from the *other* views (one batched
        linear triangulation), so a swapped view cannot bend the reference it is compared with.
        """
        rows = [(k, r) for k, members in enumerate(clusters) if len(members) >= 3 for r in members]
        if not rows:
            return []
        cols = np.concatenate([np.arange(k * NUM_JOINTS, (k + 1) * NUM_JOINTS) for k, _ in rows])
        w_others = w[:, cols].copy()
        for i, (_, r) in enumerate(rows):
            w_others[cam_idx[r], i * NUM_JOINTS:(i + 1) * NUM_JOINTS] = 0.0
        pts = triangulate_linear(self.rig.Rt, xy[:, cols], w_others, self.rig.quad)
        proj_all = self.rig.project(pts)  # (C, R*17, 2)
        idx = [r for _, r in rows]
        proj = np.stack([proj_all[cam_idx[r], i * NUM_JOINTS:(i + 1) * NUM_JOINTS]
                         for i, r in enumerate(idx)])
        flip = flipped_views(proj, uv_all[idx], w_all[idx], size_all[idx])
        return [r for r, f in zip(idx, flip, strict=True) if f]

    def update(self, views: Sequence[TrackedView], timestamp_s: float) -> list[Person3D]:
        """One multi-view frame -> the 3D people seen by at least two cameras, sorted by user id.

        Raises InputError (leaving the tracks unchanged) for views of unknown or repeated cameras.
        """
        t = float(timestamp_s)
        self._check(views, t)
        tp = self.config.triangulation
        cam_rows: list[int] = []
        keys: list[tuple[str, int]] = []
        uv_rows: list[F64] = []
        xy_rows: list[F64] = []
        w_rows: list[F64] = []
        size_rows: list[F64] = []
        for v in views:
            if len(v) == 0:
                continue
            ci = self._cam_index[v.camera]
            uv = np.asarray(v.keypoints_xy, dtype=np.float64)
            sc = np.asarray(v.keypoint_scores, dtype=np.float64)
            ok = np.all(np.isfinite(uv), axis=2) & np.isfinite(sc) & (sc >= tp.min_score) & (sc > 0)
            uv_rows.append(uv)
            xy_rows.append(undistort_points(self.rig.cameras[ci], uv))
            w_rows.append(np.where(ok, sc, 0.0))
            size_rows.append(person_size_px(uv, ok))
            cam_rows.extend([ci] * len(v))
            keys.extend((v.camera, int(tid)) for tid in v.track_ids)
        if not keys:
            self.tracks.assign([], t)
            return []
        cam_idx = np.asarray(cam_rows, dtype=np.int64)
        uv_all, xy_all, w_all = np.concatenate(uv_rows), np.concatenate(xy_rows), np.concatenate(w_rows)
        size_all = np.concatenate(size_rows)
        prior = np.array([self.tracks.prior_user(k) for k in keys], dtype=np.int64)
        clusters = [c for c in associate(self.rig, cam_idx, xy_all, w_all, prior, self.config.association)
                    if len(c) >= 2]
        if not clusters:
            self.tracks.assign([], t)
            return []

        uv, xy, w, size = self._stack(clusters, cam_idx, uv_all, xy_all, w_all, size_all)
        flips = self._flipped_rows(clusters, cam_idx, xy, w, uv_all, w_all, size_all)
        if flips:
            for r in flips:
                log.debug("view %s#%d has left and right swapped; unswapped", keys[r][0], keys[r][1])
                uv_all[r] = uv_all[r][FLIP_PERM]
                xy_all[r] = xy_all[r][FLIP_PERM]
                w_all[r] = w_all[r][FLIP_PERM]
            uv, xy, w, size = self._stack(clusters, cam_idx, uv_all, xy_all, w_all, size_all)
        tri = triangulate(self.rig, uv, w, tp, normalized=xy, scale_px=size)

        kept: list[tuple[F64, NDArray[np.bool_], F64, tuple[tuple[str, int], ...]]] = []
        candidates: list[Candidate] = []
        for k, members in enumerate(clusters):
            sl = slice(k * NUM_JOINTS, (k + 1) * NUM_JOINTS)
            valid = tri.valid[sl]
            if int(valid.sum()) < self.config.tracks.min_valid_joints:
                continue
            views_kept = []
            for r in members:
                confident = w_all[r] > 0
                agree = tri.used[cam_idx[r], sl][confident].mean() if confident.any() else 0.0
                if agree >= MIN_VIEW_AGREEMENT:
                    views_kept.append(keys[r])
                else:
                    log.debug("view %s#%d disagrees with its person (%.0f%% of joints used)",
                              keys[r][0], keys[r][1], 100 * agree)
            person = Person3D(-1, tri.points_m[sl], valid, float("nan"), tuple(views_kept))
            kept.append((tri.points_m[sl], valid, tri.reproj_px[sl], tuple(views_kept)))
            measures = body_measures(tri.points_m[sl], valid) if self.config.identity.enabled else None
            candidates.append(Candidate(tuple(views_kept), person.position_m, measures))
        user_ids = self.tracks.assign(candidates, t)

        people: list[Person3D] = []
        for uid, (joints, valid, reproj, vk) in zip(user_ids, kept, strict=True):
            raw_err = float(np.mean(reproj[valid])) if valid.any() else float("nan")
            joints_out, valid_out = self.tracks.postprocess(uid, joints, valid, t)
            people.append(Person3D(uid, joints_out, valid_out, raw_err, vk))
        people.sort(key=lambda p: p.user_id)
        return people
