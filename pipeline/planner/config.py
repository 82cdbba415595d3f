"""Frozen configs of the camera-coverage planner: the settings' ``[planner]`` (no heavy imports).

Units are in the names: ``_m`` metres, ``_deg`` degrees, ``_px`` pixels. A bad value raises
:class:`~pipeline.errors.InputError` (a ``ValueError``) naming it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pipeline.errors import InputError
from pipeline.sim.config import FaultConfig
from pipeline.triangulation.config import TriangulationParams


def _check(cond: bool, what: str, value: object) -> None:
    """InputError (a ValueError) naming what was expected and what came."""
    if not cond:
        raise InputError(f"{what}, got {value!r}")


def _floats(values: object, what: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in values)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a list of numbers, got {values!r}") from None
    _check(len(out) > 0 and all(math.isfinite(v) for v in out), f"{what} must be finite numbers", values)
    return out


@dataclass(frozen=True, slots=True)
class SearchConfig:
    """The mount search for N cameras.

    count: how many cameras to place.
    mounts: the kinds of spots tried: ``corner`` (the room's top corners) and ``wall`` (the middle
        of each wall's top edge).
    inset_m: the spots hang this far inside the walls.
    heights_m: mount heights tried (clipped to the walls' top plus the planner's ``above_walls_m``).
    pans_deg: aims tried, as a horizontal turn away from looking at the room's centre.
    aim_heights_m: tilts tried, as the height the camera looks at over the room's centre.
    preset: the camera model (``pipeline.sim.scene.PRESETS``) of every proposed camera.
    screen_step_m: the coarse grid of the fast screening pass (the expected error from the
        triangulation's first-order covariance); the best layouts are then mapped with the
        planner's full Monte Carlo.
    top_k: how many of the best layouts are mapped and reported.
    miss_penalty_mm: error charged for a joint seen by fewer than two cameras.
    worst_weight: objective = (1 - w) x mean cell error + w x the worst region's mean error.
    """

    count: int = 4
    mounts: tuple[str, ...] = ("corner", "wall")
    inset_m: float = 0.15
    heights_m: tuple[float, ...] = (2.0, 2.3, 2.45)
    pans_deg: tuple[float, ...] = (-25.0, 0.0, 25.0)
    aim_heights_m: tuple[float, ...] = (0.4, 1.0)
    preset: str = "kinect_color"
    screen_step_m: float = 0.3
    top_k: int = 3
    miss_penalty_mm: float = 150.0
    worst_weight: float = 0.5

    def __post_init__(self) -> None:
        _check(int(self.count) == self.count, "count must be a whole number", self.count)
        _check(
            2 <= int(self.count) <= 16,
            "count must be in [2, 16] cameras (triangulation needs two)",
            self.count,
        )
        object.__setattr__(self, "count", int(self.count))
        mounts = tuple(self.mounts)
        _check(
            len(mounts) > 0 and set(mounts) <= {"corner", "wall"},
            "mounts must name 'corner' and/or 'wall'",
            self.mounts,
        )
        object.__setattr__(self, "mounts", mounts)
        _check(0.0 <= self.inset_m <= 1.0, "inset_m must be in [0, 1] m", self.inset_m)
        heights = _floats(self.heights_m, "heights_m")
        _check(all(0.5 <= h <= 5.0 for h in heights), "heights_m must lie in [0.5, 5] m", heights)
        object.__setattr__(self, "heights_m", heights)
        pans = _floats(self.pans_deg, "pans_deg")
        _check(all(abs(p) <= 90.0 for p in pans), "pans_deg must lie in [-90, 90]", pans)
        object.__setattr__(self, "pans_deg", pans)
        aims = _floats(self.aim_heights_m, "aim_heights_m")
        _check(all(0.0 <= a <= 2.5 for a in aims), "aim_heights_m must lie in [0, 2.5] m", aims)
        object.__setattr__(self, "aim_heights_m", aims)
        _check(0.05 <= self.screen_step_m <= 2.0, "screen_step_m must be in [0.05, 2] m", self.screen_step_m)
        _check(1 <= int(self.top_k) <= 10, "top_k must be in [1, 10]", self.top_k)
        object.__setattr__(self, "top_k", int(self.top_k))
        _check(self.miss_penalty_mm > 0, "miss_penalty_mm must be > 0", self.miss_penalty_mm)
        _check(0.0 <= self.worst_weight <= 1.0, "worst_weight must be in [0, 1]", self.worst_weight)


@dataclass(frozen=True, slots=True)
class PlannerConfig:
    """How a coverage map is computed.

    grid_step_m: side of a floor cell; the map has one standing person per cell centre.
    wall_clearance_m: cells whose centre is nearer a wall than this are left out (nobody stands there).
    heights_m: standing heights of the people tried in every cell (the simulator's body proportions).
    facings_deg: their facing directions (0 = +Y, counter-clockwise).
    samples: Monte Carlo draws of the 2D detections per cell, height and facing.
    seed: the Monte Carlo's random numbers (the same seed gives the same map).
    region_band_m: width of the bands along the walls that define the edge and corner regions.
    above_walls_m: a camera may hang this far above the walls' top (on the frame) and still be inside.
    faults: the simulator's 2D noise model (pixel noise scaled with person size, misses, low scores
        for hidden joints) that the Monte Carlo draws from.
    triangulation: the triangulation the detections go through (the pipeline's own settings).
    search: the mount search for N cameras (``[planner.search]``).

    In the settings (``[planner]``), ``faults`` and ``triangulation`` are not keys of their own:
    they are the simulator's ``[sim.faults]`` and the pipeline's ``[triangulation]``.
    """

    grid_step_m: float = 0.15
    wall_clearance_m: float = 0.2
    heights_m: tuple[float, ...] = (1.6, 1.85)
    facings_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)
    samples: int = 4
    seed: int = 0
    region_band_m: float = 0.5
    above_walls_m: float = 0.5
    faults: FaultConfig = field(default_factory=FaultConfig)
    triangulation: TriangulationParams = field(default_factory=TriangulationParams)
    search: SearchConfig = field(default_factory=SearchConfig)

    def __post_init__(self) -> None:
        _check(0.02 <= self.grid_step_m <= 2.0, "grid_step_m must be in [0.02, 2] m", self.grid_step_m)
        _check(
            0.0 <= self.wall_clearance_m <= 1.0, "wall_clearance_m must be in [0, 1] m", self.wall_clearance_m
        )
        heights = _floats(self.heights_m, "heights_m")
        _check(all(1.0 <= h <= 2.3 for h in heights), "heights_m must lie in [1.0, 2.3] m", heights)
        object.__setattr__(self, "heights_m", heights)
        object.__setattr__(self, "facings_deg", _floats(self.facings_deg, "facings_deg"))
        _check(1 <= int(self.samples) <= 256, "samples must be in [1, 256]", self.samples)
        object.__setattr__(self, "samples", int(self.samples))
        _check(0.05 <= self.region_band_m <= 2.0, "region_band_m must be in [0.05, 2] m", self.region_band_m)
        _check(0.0 <= self.above_walls_m <= 3.0, "above_walls_m must be in [0, 3] m", self.above_walls_m)
