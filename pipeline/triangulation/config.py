"""Frozen configs of the triangulation stage: the settings' ``[triangulation]``, ``[association]``,
``[tracks3d]`` and ``[navigator]`` sections (no heavy imports here).

Units are in the names: ``_px`` pixels at the camera's resolution, ``_m`` metres, ``_s`` seconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from pipeline.identity.config import IdentityConfig


def _check(cond: bool, what: str, value: object) -> None:
    if not cond:
        raise ValueError(f"{what}, got {value!r}")


@dataclass(frozen=True, slots=True)
class TriangulationParams:
    """The robust multi-view triangulation of one batch of joints (pure math).

    min_score: 2D keypoints scored below this are ignored.
    outlier_ratio: a view whose reprojection error exceeds ``outlier_ratio`` x the median of the
        other views' errors (and ``outlier_min_px``) is dropped for that joint; repeated.
    outlier_min_px: a view is never dropped for an error below this.
    outlier_min_frac: ... nor below this fraction of the person's size in that view, when the caller
        gives the sizes (real detectors err by a few per cent of the body; a gross outlier such
        as a left/right swap or another person's limb is far larger).
    max_reproj_px: a joint whose mean reprojection error stays above this is unknown.
    refine_iterations: Gauss-Newton steps on the weighted reprojection error after the DLT (0 = none).
    """

    min_score: float = 0.3
    outlier_ratio: float = 3.0
    outlier_min_px: float = 12.0
    outlier_min_frac: float = 0.15
    max_reproj_px: float = 40.0
    refine_iterations: int = 1

    def __post_init__(self) -> None:
        _check(0.0 <= self.min_score <= 1.0, "min_score must be in [0, 1]", self.min_score)
        _check(self.outlier_ratio > 1.0, "outlier_ratio must be > 1", self.outlier_ratio)
        _check(self.outlier_min_px >= 0.0, "outlier_min_px must be >= 0", self.outlier_min_px)
        _check(0.0 <= self.outlier_min_frac <= 1.0, "outlier_min_frac must be in [0, 1]",
               self.outlier_min_frac)
        _check(self.max_reproj_px > 0.0, "max_reproj_px must be > 0", self.max_reproj_px)
        _check(0 <= self.refine_iterations <= 20, "refine_iterations must be in [0, 20]",
               self.refine_iterations)


@dataclass(frozen=True, slots=True)
class AssociationParams:
    """Cross-view association of 2D people.

    max_epipolar_px: mean symmetric epipolar distance (pixels) under which two views' people may be
        the same person.
    min_common_joints: joints confidently seen in both views needed to compare two people.
    memory_factor: distance multiplier for two people that were the same user last time (< 1 favours
        keeping the association; its inverse is applied to people known to be different users).
    memory_s: a (camera, track_id) -> user_id link is forgotten after this long unseen.
    """

    max_epipolar_px: float = 40.0
    min_common_joints: int = 4
    memory_factor: float = 0.5
    memory_s: float = 5.0

    def __post_init__(self) -> None:
        _check(self.max_epipolar_px > 0.0, "max_epipolar_px must be > 0", self.max_epipolar_px)
        _check(1 <= self.min_common_joints <= 17, "min_common_joints must be in [1, 17]",
               self.min_common_joints)
        _check(0.0 < self.memory_factor <= 1.0, "memory_factor must be in (0, 1]", self.memory_factor)
        _check(self.memory_s >= 0.0, "memory_s must be >= 0", self.memory_s)


@dataclass(frozen=True, slots=True)
class Tracks3DParams:
    """Persistent 3D tracks (user ids), smoothing and bone-length priors.

    max_missing_s: a user unseen this long is forgotten (a person returning later gets a new id).
    max_match_distance_m: floor distance from a track's predicted position within which a new
        skeleton may continue it.
    smoothing: ``one_euro`` (adaptive low-pass, low lag when moving) or ``none``.
    one_euro_min_cutoff_hz, one_euro_beta, one_euro_d_cutoff_hz: the One-Euro filter's parameters
        (Casiez et al. 2012), on metres and metres per second.
    bone_prior_s: seconds of a user's first valid frames over which their bone lengths are learned.
    bone_tolerance: afterwards, a limb joint whose bone to its parent differs from the learned
        length by more than this fraction is treated as an outlier (unknown).
    min_valid_joints: a multi-view person with fewer valid joints is not reported.
    """

    max_missing_s: float = 2.0
    max_match_distance_m: float = 0.7
    smoothing: Literal["none", "one_euro"] = "one_euro"
    one_euro_min_cutoff_hz: float = 4.0
    one_euro_beta: float = 30.0
    one_euro_d_cutoff_hz: float = 1.0
    bone_prior_s: float = 2.0
    bone_tolerance: float = 0.35
    min_valid_joints: int = 5

    def __post_init__(self) -> None:
        _check(self.max_missing_s >= 0.0, "max_missing_s must be >= 0", self.max_missing_s)
        _check(self.max_match_distance_m > 0.0, "max_match_distance_m must be > 0",
               self.max_match_distance_m)
        _check(self.smoothing in ("none", "one_euro"), "smoothing must be 'none' or 'one_euro'",
               self.smoothing)
        _check(self.one_euro_min_cutoff_hz > 0.0, "one_euro_min_cutoff_hz must be > 0",
               self.one_euro_min_cutoff_hz)
        _check(self.one_euro_beta >= 0.0, "one_euro_beta must be >= 0", self.one_euro_beta)
        _check(self.one_euro_d_cutoff_hz > 0.0, "one_euro_d_cutoff_hz must be > 0",
               self.one_euro_d_cutoff_hz)
        _check(self.bone_prior_s >= 0.0, "bone_prior_s must be >= 0", self.bone_prior_s)
        _check(self.bone_tolerance > 0.0, "bone_tolerance must be > 0", self.bone_tolerance)
        _check(1 <= self.min_valid_joints <= 17, "min_valid_joints must be in [1, 17]",
               self.min_valid_joints)


@dataclass(frozen=True, slots=True)
class ReconstructionConfig:
    """Everything the :class:`~pipeline.triangulation.reconstructor.Reconstructor` needs: the four
    parts' configs as they are (each its own settings section)."""

    triangulation: TriangulationParams = TriangulationParams()
    association: AssociationParams = AssociationParams()
    tracks: Tracks3DParams = Tracks3DParams()
    identity: IdentityConfig = IdentityConfig()  # noqa: RUF009 (frozen, as the three above)


@dataclass(frozen=True, slots=True)
class NavigatorConfig:
    """Choice of the primary navigator.

    mode: initial mode, ``auto`` or ``manual`` (manual waits for ``set_manual``).
    center_m: (x, y) of the CAVE centre on the floor, metres.
    dwell_s: in auto mode, a person must have been tracked (and nearest) this long to be chosen.
    hold_s: the navigator stays chosen through an occlusion this long.
    max_radius_m: in auto mode, only people within this floor distance of the centre are eligible.
    switch_margin_m: in auto mode, another person takes over only when nearer the centre by this
        much for ``dwell_s``.
    manual_grace_s: a manual navigator lost for longer than ``hold_s`` is waited for this much
        longer (or re-acquired, below); then the choice falls back to automatic, so a session never
        runs on with nobody steering.
    reacquire_radius_m: while the manual navigator is missing, a newly tracked user first seen
        within this floor distance of where the navigator was last seen (and within
        ``hold_s + manual_grace_s`` of that) is taken for the same person: the tracker gave them a
        new id. 0 turns re-acquisition off.
    """

    mode: Literal["auto", "manual"] = "auto"
    center_m: tuple[float, float] = (0.0, 0.0)
    dwell_s: float = 0.5
    hold_s: float = 1.5
    max_radius_m: float = 1.5
    switch_margin_m: float = 0.5
    manual_grace_s: float = 3.0
    reacquire_radius_m: float = 0.6

    def __post_init__(self) -> None:
        _check(self.mode in ("auto", "manual"), "mode must be 'auto' or 'manual'", self.mode)
        _check(len(self.center_m) == 2, "center_m must be (x, y)", self.center_m)
        _check(self.dwell_s >= 0.0, "dwell_s must be >= 0", self.dwell_s)
        _check(self.hold_s >= 0.0, "hold_s must be >= 0", self.hold_s)
        _check(self.max_radius_m > 0.0, "max_radius_m must be > 0", self.max_radius_m)
        _check(self.switch_margin_m >= 0.0, "switch_margin_m must be >= 0", self.switch_margin_m)
        _check(self.manual_grace_s >= 0.0, "manual_grace_s must be >= 0", self.manual_grace_s)
        _check(self.reacquire_radius_m >= 0.0, "reacquire_radius_m must be >= 0", self.reacquire_radius_m)
