"""The façade over frames: association, persistent user ids, occlusions, bad input."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from pipeline.camera import project
from pipeline.errors import InputError
from pipeline.pose.types import ViewDetections
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.config import (
    AssociationParams,
    ReconstructionConfig,
    Tracks3DParams,
    TriangulationParams,
)
from pipeline.triangulation.reconstructor import FLIP_PERM, Reconstructor, flipped_views
from tests.pipeline.triangulation.scene import corner_cameras, observe, skeleton_at

CAMS = corner_cameras()
FPS = 30.0
RAW = ReconstructionConfig(tracks=Tracks3DParams(smoothing="none"))


def _ids(track_base: int, n: int) -> list[list[int]]:
    """Per-camera track ids: camera c gives person p the id track_base + 10 c + p."""
    return [[track_base + 10 * c + p for p in range(n)] for c in range(len(CAMS))]


def _by_position(people, truth):
    """user_id of the reconstructed person nearest each true skeleton."""
    out = []
    for gt in truth:
        best = min(people, key=lambda p: np.nanmean(np.linalg.norm(p.joints_m - gt, axis=1)))
        out.append(best.user_id)
    return out


@pytest.mark.parametrize("n_people", [1, 2, 3, 4])
def test_people_are_reconstructed_with_stable_ids(n_people: int) -> None:
    rng = np.random.default_rng(n_people)
    truth = [skeleton_at(0.0, 0.0), skeleton_at(0.9, 0.5, 90), skeleton_at(-0.8, -0.6, 200),
             skeleton_at(0.5, -0.9, 30)][:n_people]
    rec = Reconstructor(CAMS, RAW)
    first = None
    for f in range(6):
        views = observe(CAMS, truth, rng, track_ids=_ids(1, n_people), shuffle=True, timestamp_s=f / FPS)
        people = rec.update(views, f / FPS)
        assert len(people) == n_people, f"frame {f}: expected {n_people} people, got {len(people)}"
        ids = _by_position(people, truth)
        assert len(set(ids)) == n_people, f"each person gets their own id, got {ids}"
        first = first or ids
        assert ids == first, f"frame {f}: ids changed from {first} to {ids}"
        for p, gt in zip(sorted(people, key=lambda p: ids.index(p.user_id)), truth, strict=True):
            err = np.linalg.norm(p.joints_m - gt, axis=1)
            assert p.joint_valid.all() and err.mean() < 0.01, f"error {err.mean():.4f} m"
            assert len(p.views) == 4 and p.reproj_px < 5.0


def test_id_survives_a_short_occlusion_but_not_a_long_one() -> None:
    rng = np.random.default_rng(0)
    a = skeleton_at(0.2, 0.1)
    rec = Reconstructor(CAMS, RAW)
    t = 0.0
    uid = rec.update(observe(CAMS, [a], rng, track_ids=_ids(1, 1)), t)[0].user_id
    t += 0.8  # hidden from every camera for 0.8 s, back with new per-view track ids
    assert rec.update(observe(CAMS, [], rng), t - 0.4) == []
    again = rec.update(observe(CAMS, [a], rng, track_ids=_ids(50, 1)), t)
    assert [p.user_id for p in again] == [uid], "a short occlusion keeps the user id"
    t += RAW.tracks.max_missing_s + 0.5
    later = rec.update(observe(CAMS, [a], rng, track_ids=_ids(90, 1)), t)
    assert len(later) == 1 and later[0].user_id != uid, "a user lost for longer gets a new id"


def test_person_briefly_leaving_a_view_keeps_the_id() -> None:
    rng = np.random.default_rng(1)
    a, b = skeleton_at(-0.6, 0.0), skeleton_at(0.6, 0.2, 180)
    rec = Reconstructor(CAMS, RAW)
    ids0 = _by_position(rec.update(observe(CAMS, [a, b], rng, track_ids=_ids(1, 2)), 0.0), [a, b])
    for f in range(1, 10):  # a leaves cam01 and cam02 (two views left), then returns with new track ids
        views = observe(CAMS, [a, b], rng, track_ids=_ids(1 if f < 6 else 100, 2), timestamp_s=f / FPS)
        if f < 6:
            for c in (0, 1):
                d = views[c].detections
                keep = np.array([tid != _ids(1, 2)[c][0] for tid in views[c].track_ids])
                views[c] = type(views[c])(d, views[c].track_ids[keep], views[c].detection_index[keep])
        people = rec.update(views, f / FPS)
        assert _by_position(people, [a, b]) == ids0, f"frame {f}: ids changed"
        pa = next(p for p in people if p.user_id == ids0[0])
        assert len(pa.views) == (2 if f < 6 else 4)


def test_a_tracker_id_switch_in_one_view_does_not_swap_users() -> None:
    rng = np.random.default_rng(2)
    a, b = skeleton_at(-0.7, 0.0), skeleton_at(0.7, 0.0, 180)
    rec = Reconstructor(CAMS, RAW)
    ids0 = _by_position(rec.update(observe(CAMS, [a, b], rng, track_ids=_ids(1, 2)), 0.0), [a, b])
    swapped = _ids(1, 2)
    swapped[2] = swapped[2][::-1]  # cam03's tracker swaps the two ids
    people = rec.update(observe(CAMS, [a, b], rng, track_ids=swapped), 1 / FPS)
    assert _by_position(people, [a, b]) == ids0, "geometry outweighs one view's swapped ids"
    pa = next(p for p in people if p.user_id == ids0[0])
    assert ("cam03", swapped[2][0]) in pa.views


def test_a_person_seen_by_one_camera_is_not_reported() -> None:
    rng = np.random.default_rng(3)
    views = observe(CAMS[:1], [skeleton_at(0.0, 0.0)], rng)
    assert Reconstructor(CAMS, RAW).update(views, 0.0) == []


def test_smoothing_reduces_jitter_of_a_still_person() -> None:
    rng = np.random.default_rng(4)
    a = skeleton_at(0.0, 0.0)
    outs = {}
    for mode in ("none", "one_euro"):
        rec = Reconstructor(CAMS, ReconstructionConfig(tracks=Tracks3DParams(smoothing=mode)))
        r = np.random.default_rng(4)
        seq = [rec.update(observe(CAMS, [a], r, noise_px=4.0), f / FPS)[0].joints_m for f in range(60)]
        outs[mode] = np.mean([np.linalg.norm(s - a, axis=1).mean() for s in seq[30:]])
    assert outs["one_euro"] < 0.8 * outs["none"], f"One-Euro should cut jitter, got {outs}"
    del rng


@pytest.mark.parametrize(
    ("mutate", "match"),
    [
        (lambda v: [*v, v[0]], "two views from camera 'cam01'"),
        (lambda v: [_rename(v[0], "cam09"), *v[1:]], "unknown camera 'cam09'"),
        (lambda v: [*v[:3], "not a view"], "expected TrackedView"),
    ],
)
def test_bad_views_are_rejected_and_state_is_unchanged(mutate, match) -> None:
    rng = np.random.default_rng(5)
    a = skeleton_at(0.0, 0.0)
    rec = Reconstructor(CAMS, RAW)
    uid = rec.update(observe(CAMS, [a], rng), 0.0)[0].user_id
    users, memory = copy.deepcopy(rec.tracks.users), dict(rec.tracks.memory)
    with pytest.raises(InputError, match=match):
        rec.update(mutate(observe(CAMS, [a], rng)), 0.1)
    assert rec.tracks.memory == memory and set(rec.tracks.users) == set(users)
    assert rec.tracks.users[uid].last_seen_s == users[uid].last_seen_s, "rejected input changed a track"
    with pytest.raises(InputError, match="finite"):
        rec.update(observe(CAMS, [a], rng), float("nan"))
    assert rec.update(observe(CAMS, [a], rng), 0.2)[0].user_id == uid


def _rename(view, name):
    d = view.detections
    det = ViewDetections(name, d.frame_index, d.timestamp_s, d.image_size, d.boxes_xyxy, d.box_scores,
                         d.keypoints_xy, d.keypoint_scores)
    return TrackedView(det, view.track_ids, view.detection_index)


def test_the_reconstructor_keeps_its_three_configs() -> None:
    cfg = ReconstructionConfig(TriangulationParams(outlier_ratio=4.0), AssociationParams(memory_s=9.0),
                               Tracks3DParams(smoothing="none"))
    assert cfg.triangulation.outlier_ratio == 4.0
    assert cfg.tracks.smoothing == "none" and cfg.association.memory_s == 9.0
    with pytest.raises(TypeError, match="bogus"):
        TriangulationParams(bogus=1)  # type: ignore[call-arg]
    rec = Reconstructor(CAMS, cfg)
    assert rec.config == cfg and rec.rig.names == tuple(c.name for c in CAMS)


@pytest.mark.parametrize("flipped_camera", [0, 2])
def test_a_view_with_left_and_right_swapped_is_unswapped(flipped_camera: int) -> None:
    rng = np.random.default_rng(6)
    a = skeleton_at(0.1, 0.0, 30)
    views = observe(CAMS, [a], rng)
    d = views[flipped_camera].detections
    swapped = ViewDetections(d.camera, d.frame_index, d.timestamp_s, d.image_size, d.boxes_xyxy,
                             d.box_scores, d.keypoints_xy[:, FLIP_PERM], d.keypoint_scores[:, FLIP_PERM])
    views[flipped_camera] = TrackedView(swapped, views[flipped_camera].track_ids,
                                        views[flipped_camera].detection_index)
    (p,) = Reconstructor(CAMS, RAW).update(views, 0.0)
    err = np.linalg.norm(p.joints_m - a, axis=1)
    assert p.joint_valid.all() and err.max() < 0.02, f"max error {err.max():.3f} m after unswapping"
    assert len(p.views) == 4, "the unswapped view is used again"
    assert not flipped_views(np.array([project(CAMS[0], a)]), np.array([project(CAMS[0], a)]),
                             np.ones((1, 17)), np.array([600.0]))[0], "a correct view is not flipped"
