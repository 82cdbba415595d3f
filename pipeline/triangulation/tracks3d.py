"""3D tracks: a persistent user id per person, One-Euro smoothing and bone-length priors.

A new multi-view skeleton continues the user whose (camera, track_id) links it carries (each
camera's tracker keeps its ids through short occlusions), else the user whose predicted floor
position is nearest within a gate (Hungarian assignment); otherwise it starts a new user. A user
unseen for ``max_missing_s`` is no longer tracked, so a short occlusion or a person briefly
leaving a view keeps the id.

Re-identification (issue 20 item 2, :mod:`pipeline.identity`): every track collects its body
measurements; a user no longer tracked goes to a gallery with their body signature. A new track
is measured for ``identity.window_s`` and then compared with the lost users (and with tracked users
unseen for ``identity.min_gap_s``, whose track may have broken); when one body fits, unambiguously
and within walking reach, the new track takes that user's id back (from then on: the frames
before keep the new id).
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from pipeline.identity.body import MEASURES, measure_distance, signature
from pipeline.identity.config import IdentityConfig
from pipeline.identity.gallery import Gallery, LostUser
from pipeline.skeleton import BONES, NUM_JOINTS, J
from pipeline.triangulation.config import Tracks3DParams

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
B = NDArray[np.bool_]
ViewKey = tuple[str, int]

# Limb bones checked against the learned lengths: (parent, child); the child becomes unknown.
LIMB_BONES: tuple[tuple[int, int], ...] = tuple(
    (J[a], J[b]) for a, b in (
        ("l_shoulder", "l_elbow"), ("l_elbow", "l_wrist"), ("r_shoulder", "r_elbow"),
        ("r_elbow", "r_wrist"), ("l_hip", "l_knee"), ("l_knee", "l_ankle"),
        ("r_hip", "r_knee"), ("r_knee", "r_ankle"),
    )
)
_BONE_INDEX = {bone: i for i, bone in enumerate(BONES)}
_MIN_BONE_SAMPLES = 5
_ONE_EURO_RESET_S = 0.5
_MAX_MEASURES = 300  # per-frame body measurements a track keeps (the newest)
_BODY_EVERY = 10


def bone_lengths(joints_m: F64) -> F64:
    """(..., 17, 3) joints -> (..., len(BONES)) bone lengths in metres (NaN where a joint is unknown)."""
    a = np.array([p for p, _ in BONES])
    b = np.array([c for _, c in BONES])
    d: F64 = np.linalg.norm(joints_m[..., a, :] - joints_m[..., b, :], axis=-1)
    return d


def bone_outliers(joints_m: F64, valid: B, prior_m: F64, tolerance: float) -> B:
    """(17,) True for limb joints whose bone to their parent deviates from ``prior_m`` (per BONES)
    by more than ``tolerance`` x the prior length."""
    lengths = bone_lengths(joints_m)
    out = np.zeros(NUM_JOINTS, dtype=bool)
    for parent, child in LIMB_BONES:
        k = _BONE_INDEX[(parent, child)]
        ref = prior_m[k]
        if not (valid[parent] and valid[child] and np.isfinite(ref) and ref > 0):
            continue
        if abs(lengths[k] - ref) > tolerance * ref:
            out[child] = True
    return out


def _alpha(cutoff_hz: float | F64, dt_s: F64) -> F64:
    tau = 1.0 / (2.0 * math.pi * np.asarray(cutoff_hz))
    a: F64 = 1.0 / (1.0 + tau / dt_s)
    return a


@dataclass(slots=True)
class OneEuroFilter:
    """The One-Euro filter (Casiez, Roussel, Vogel, CHI 2012) on (17, 3) joints, per joint.

    Cutoff = min_cutoff + beta |dx/dt|: strong smoothing when still, little lag when moving.
    Unknown joints pass as NaN and keep their state; a joint unseen for 0.5 s restarts.
    """

    min_cutoff_hz: float
    beta: float
    d_cutoff_hz: float
    x: F64 = field(default_factory=lambda: np.full((NUM_JOINTS, 3), np.nan))
    dx: F64 = field(default_factory=lambda: np.zeros((NUM_JOINTS, 3)))
    t: F64 = field(default_factory=lambda: np.full(NUM_JOINTS, -np.inf))

    def __call__(self, joints_m: F64, valid: B, timestamp_s: float) -> F64:
        dt = timestamp_s - self.t
        fresh = valid & ~((dt > 0) & (dt <= _ONE_EURO_RESET_S) & np.all(np.isfinite(self.x), axis=1))
        step = valid & ~fresh
        out = np.full((NUM_JOINTS, 3), np.nan)
        if np.any(fresh):
            self.x[fresh] = joints_m[fresh]
            self.dx[fresh] = 0.0
            self.t[fresh] = timestamp_s
            out[fresh] = joints_m[fresh]
        if np.any(step):
            dts = dt[step][:, None]
            dx = (joints_m[step] - self.x[step]) / dts
            dx_hat = self.dx[step] + _alpha(self.d_cutoff_hz, dts) * (dx - self.dx[step])
            speed = np.linalg.norm(dx_hat, axis=1, keepdims=True)
            a = _alpha(self.min_cutoff_hz + self.beta * speed, dts)
            x_hat = self.x[step] + a * (joints_m[step] - self.x[step])
            self.x[step] = x_hat
            self.dx[step] = dx_hat
            self.t[step] = timestamp_s
            out[step] = x_hat
        return out


@dataclass(slots=True)
class UserTrack:
    """The state of one user (mutable, owned by :class:`Tracks3D`)."""

    user_id: int
    first_seen_s: float
    last_seen_s: float
    position_m: F64
    velocity_mps: F64 = field(default_factory=lambda: np.zeros(3))
    bone_samples: list[F64] = field(default_factory=list)
    bone_prior_m: F64 | None = None
    smoother: OneEuroFilter | None = None
    measures: list[F64] = field(default_factory=list)  # per-frame body measurements (identity)
    reid_open: bool = False  # a new track that may still turn out to be a lost user

    n_measured: int = 0  # measurements ever added (the list keeps the newest _MAX_MEASURES)
    _body: F64 | None = None  # the signature, cached; recomputed every _BODY_EVERY new measurements
    _body_at: int = -1

    def add_measures(self, measures_m: F64) -> None:
        self.measures.append(np.asarray(measures_m, dtype=np.float64))
        del self.measures[:-_MAX_MEASURES]
        self.n_measured += 1

    def body(self) -> F64:
        """The body signature: the median of the (newest) measurements."""
        n = self.n_measured
        if self._body is None or n - self._body_at >= _BODY_EVERY or n < 2 * _BODY_EVERY:
            empty = np.full(len(MEASURES), np.nan)
            self._body = signature(np.array(self.measures)) if self.measures else empty
            self._body_at = n
        return self._body

    def predict(self, timestamp_s: float) -> F64:
        dt = min(max(timestamp_s - self.last_seen_s, 0.0), 0.5)
        p: F64 = self.position_m + self.velocity_mps * dt
        return p


@dataclass(frozen=True, slots=True)
class Candidate:
    """A multi-view skeleton waiting for a user id.

    views: the (camera, track_id) pairs it was triangulated from.
    position_m: (3,) floor position (x, y, 0), metres.
    """

    views: tuple[ViewKey, ...]
    position_m: F64
    measures_m: F64 | None = None  # body measurements of this frame (pipeline.identity.body)

    def __post_init__(self) -> None:
        p = np.asarray(self.position_m, dtype=np.float64)
        if p.shape != (3,):
            raise ValueError(f"position_m must have shape (3,), got {p.shape}")
        object.__setattr__(self, "position_m", p)


class Tracks3D:
    """Persistent user ids, the (camera, track_id) -> user_id memory, and per-user post-processing."""

    def __init__(self, params: Tracks3DParams, memory_s: float = 5.0,
                 identity: IdentityConfig | None = None) -> None:
        self.params = params
        self.memory_s = memory_s
        self.identity = identity or IdentityConfig(enabled=False)
        self.gallery = Gallery(self.identity)
        self.users: dict[int, UserTrack] = {}
        self.memory: dict[ViewKey, tuple[int, float]] = {}
        self._next_id = 1

    def number_from(self, first_user_id: int) -> None:
        """Give the next new user ``first_user_id`` at least (the ids of a fusion worker that went
        before in the same run are never given out again)."""
        self._next_id = max(self._next_id, int(first_user_id))

    def prior_user(self, key: ViewKey) -> int:
        """The user this (camera, track_id) belonged to recently, or -1."""
        hit = self.memory.get(key)
        return -1 if hit is None else hit[0]

    def _expire(self, timestamp_s: float) -> None:
        limit = self.params.max_missing_s
        for uid in [u for u, tr in self.users.items() if timestamp_s - tr.last_seen_s > limit]:
            log.info("user %d lost (unseen for %.1f s)", uid, timestamp_s - self.users[uid].last_seen_s)
            tr = self.users.pop(uid)
            if self.identity.enabled and len(tr.measures) >= self.identity.min_samples:
                self.gallery.add(
                    LostUser(uid, tr.body(), tr.last_seen_s, tr.position_m.copy(), tr.bone_prior_m)
                )
        self.gallery.expire(timestamp_s)
        for key in [k for k, (_, t) in self.memory.items() if timestamp_s - t > self.memory_s]:
            del self.memory[key]

    def assign(self, candidates: Sequence[Candidate], timestamp_s: float) -> list[int]:
        """A user id for each candidate (distinct), updating the tracks and the memory."""
        self._expire(timestamp_s)
        uids = list(self.users)
        n, u = len(candidates), len(uids)
        out = [-1] * n
        if n and u:
            gate = self.params.max_match_distance_m
            cost = np.full((n, u), 1e6)
            bodies = self._bodies(uids) if self.identity.enabled and n > 1 else {}
            for i, cand in enumerate(candidates):
                votes = [self.prior_user(k) for k in cand.views]
                for j, uid in enumerate(uids):
                    frac = sum(v == uid for v in votes) / max(len(votes), 1)
                    d = float(np.linalg.norm((cand.position_m - self.users[uid].predict(timestamp_s))[:2]))
                    if d < gate * (1.0 + 2.0 * frac):
                        cost[i, j] = d / gate - 2.0 * frac + self._body_cost(cand, bodies.get(uid))
            rows, cols = linear_sum_assignment(cost)
            for r, c in zip(rows, cols, strict=True):
                if cost[r, c] < 1e5:
                    out[r] = uids[c]
        for i, cand in enumerate(candidates):
            if out[i] < 0:
                out[i] = self._next_id
                self._next_id += 1
                self.users[out[i]] = UserTrack(out[i], timestamp_s, timestamp_s, cand.position_m.copy(),
                                               reid_open=self.identity.enabled)
                log.info("user %d appears at (%.2f, %.2f) m from %s", out[i], cand.position_m[0],
                         cand.position_m[1], ", ".join(f"{c}#{t}" for c, t in cand.views))
            else:
                tr = self.users[out[i]]
                dt = timestamp_s - tr.last_seen_s
                if 0 < dt < 0.5:
                    v = (cand.position_m - tr.position_m) / dt
                    tr.velocity_mps = 0.7 * tr.velocity_mps + 0.3 * v
                elif dt >= 0.5:
                    tr.velocity_mps = np.zeros(3)
                tr.position_m = cand.position_m.copy()
                tr.last_seen_s = timestamp_s
            if cand.measures_m is not None and self.identity.enabled:
                self.users[out[i]].add_measures(cand.measures_m)
            for key in cand.views:
                self.memory[key] = (out[i], timestamp_s)
        if self.identity.enabled:
            remap = self._reidentify(timestamp_s)
            out = [remap.get(u, u) for u in out]
        return out

    def _bodies(self, uids: list[int]) -> dict[int, F64]:
        """The body signatures of the users measured long enough (for the assignment's body term)."""
        need = self.identity.min_samples
        return {u: self.users[u].body() for u in uids if len(self.users[u].measures) >= need}

    def _body_cost(self, cand: Candidate, body: F64 | None) -> float:
        """Assignment cost of a candidate's body against a user's signature (0 when unknown): people
        who cross paths, and whose cameras' trackers swap their ids, keep their own user ids."""
        if body is None or cand.measures_m is None:
            return 0.0
        d = measure_distance(cand.measures_m, body)
        if not np.isfinite(d):
            return 0.0
        return self.identity.body_weight * min(d / self.identity.max_distance_m, 3.0)

    def _reidentify(self, timestamp_s: float) -> dict[int, int]:
        """New tracks measured long enough, compared with the lost users: {new id: old id} taken back."""
        cfg = self.identity
        remap: dict[int, int] = {}
        for uid in sorted(u for u, tr in self.users.items() if tr.reid_open):
            tr = self.users[uid]
            age = timestamp_s - tr.first_seen_s
            if age > cfg.decide_s:
                tr.reid_open = False
                continue
            if age < cfg.window_s or len(tr.measures) < cfg.min_samples:
                continue
            missing = [LostUser(u, o.body(), o.last_seen_s, o.position_m.copy(), o.bone_prior_m)
                       for u, o in self.users.items()
                       if u != uid and timestamp_s - o.last_seen_s >= cfg.min_gap_s
                       and len(o.measures) >= cfg.min_samples]
            pool = list(self.gallery.lost.values()) + missing
            best, why = self.gallery.match(tr.body(), tr.first_seen_s, tr.position_m, pool)
            if best is None:
                continue
            log.info("user %d is user %d again (%s)", uid, best.user_id, why)
            self._relabel(uid, best)
            remap[uid] = best.user_id
        return remap

    def _relabel(self, new_id: int, old: LostUser) -> None:
        """The track ``new_id`` continues as ``old.user_id`` (whose broken track, if any, it replaces)."""
        tr = self.users.pop(new_id)
        prev = self.users.pop(old.user_id, None)
        self.gallery.lost.pop(old.user_id, None)
        tr.user_id, tr.reid_open = old.user_id, False
        if prev is not None:
            tr.measures = (prev.measures + tr.measures)[-_MAX_MEASURES:]
            tr.n_measured += prev.n_measured
        tr._body = None
        if old.bone_prior_m is not None:
            tr.bone_prior_m = old.bone_prior_m
            tr.bone_samples.clear()
        self.users[old.user_id] = tr
        for key, (u, t) in list(self.memory.items()):
            if u == new_id:
                self.memory[key] = (old.user_id, t)

    def postprocess(self, user_id: int, joints_m: F64, valid: B, timestamp_s: float) -> tuple[F64, B]:
        """Bone-length outlier check (after the learning period), then smoothing. Returns copies."""
        tr = self.users[user_id]
        p = self.params
        joints = joints_m.copy()
        ok = valid.copy()
        if tr.bone_prior_m is None:
            if timestamp_s - tr.first_seen_s <= p.bone_prior_s:
                tr.bone_samples.append(bone_lengths(np.where(ok[:, None], joints, np.nan)))
            else:
                samples = np.array(tr.bone_samples) if tr.bone_samples else np.full((1, len(BONES)), np.nan)
                counts = np.isfinite(samples).sum(axis=0)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN bones
                    med = np.nanmedian(samples, axis=0)
                tr.bone_prior_m = np.where(counts >= _MIN_BONE_SAMPLES, med, np.nan)
                tr.bone_samples.clear()
        if tr.bone_prior_m is not None:
            bad = bone_outliers(joints, ok, tr.bone_prior_m, p.bone_tolerance)
            if np.any(bad):
                ok &= ~bad
                joints[bad] = np.nan
        if p.smoothing == "one_euro":
            if tr.smoother is None:
                tr.smoother = OneEuroFilter(p.one_euro_min_cutoff_hz, p.one_euro_beta, p.one_euro_d_cutoff_hz)
            joints = tr.smoother(joints, ok, timestamp_s)
        return joints, ok
