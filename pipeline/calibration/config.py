"""The calibration stage's own frozen configuration (built from the settings once)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from pipeline.errors import InputError

CornerRefinement = Literal["subpix", "edges"]

#: ArUco dictionaries the layout may name (OpenCV's predefined ones), with their marker count.
DICTIONARY_SIZES: dict[str, int] = {
    "DICT_4X4_50": 50,
    "DICT_4X4_100": 100,
    "DICT_4X4_250": 250,
    "DICT_4X4_1000": 1000,
    "DICT_5X5_50": 50,
    "DICT_5X5_100": 100,
    "DICT_5X5_250": 250,
    "DICT_5X5_1000": 1000,
    "DICT_6X6_50": 50,
    "DICT_6X6_100": 100,
    "DICT_6X6_250": 250,
    "DICT_6X6_1000": 1000,
}


@dataclass(frozen=True, slots=True)
class CalibrationConfig:
    """How patterns are laid out and how cameras are solved.

    dictionary: the ArUco dictionary name (``DICT_4X4_250``).
    grid: (columns, rows) of markers on every wall.
    margin_frac: white margin around the grid, as a fraction of the wall's shorter side in pixels.
    quiet_frac: white gap between neighbouring markers, as a fraction of a grid cell (>= one module).
    nominal_hfov_deg: horizontal field of view of the focal-length prior (used when focal_prior_px is None).
    focal_prior_px: nominal focal length in pixels, or None to derive it from nominal_hfov_deg.
    min_markers: fewest markers a camera must see to be solved.
    min_walls: fewest distinct walls a camera must see (2: non-coplanar corners).
    ransac_px: RANSAC inlier threshold on corner reprojection, pixels.
    corner_refinement: ``subpix`` (OpenCV's; slightly biased towards the marker centre under
        blur, which costs little accuracy) or ``edges`` (corners from fitted marker edges: about
        half the corner error, a lower RMS; see pipeline.calibration.corners).
    estimate_k3: also solve the third radial coefficient (wide lenses) when the camera sees at least
        3 x min_markers markers; otherwise k3 stays 0.
    good_rms_px / fair_rms_px: RMS thresholds of the ``good`` and ``fair`` verdicts.
    """

    dictionary: str = "DICT_4X4_250"
    grid: tuple[int, int] = (6, 5)
    margin_frac: float = 0.04
    quiet_frac: float = 0.3
    nominal_hfov_deg: float = 70.0
    focal_prior_px: float | None = None
    min_markers: int = 6
    min_walls: int = 2
    ransac_px: float = 4.0
    estimate_k3: bool = True
    corner_refinement: CornerRefinement = "subpix"
    good_rms_px: float = 0.5
    fair_rms_px: float = 1.5

    def __post_init__(self) -> None:
        if self.dictionary not in DICTIONARY_SIZES:
            raise InputError(
                f"unknown ArUco dictionary {self.dictionary!r}; expected one of {', '.join(DICTIONARY_SIZES)}"
            )
        cols, rows = (int(v) for v in self.grid)
        if cols < 1 or rows < 1:
            raise InputError(f"marker grid must be at least 1x1, got {self.grid}")
        object.__setattr__(self, "grid", (cols, rows))
        if not 0.0 <= self.margin_frac < 0.45:
            raise InputError(f"margin_frac must be in [0, 0.45), got {self.margin_frac}")
        if not 0.15 <= self.quiet_frac < 0.9:
            raise InputError(f"quiet_frac must be in [0.15, 0.9), got {self.quiet_frac}")
        if not 10.0 <= self.nominal_hfov_deg <= 170.0:
            raise InputError(f"nominal_hfov_deg must be in [10, 170], got {self.nominal_hfov_deg}")
        if self.focal_prior_px is not None and self.focal_prior_px <= 0:
            raise InputError(f"focal_prior_px must be positive, got {self.focal_prior_px}")
        if self.min_markers < 2:
            raise InputError(f"min_markers must be at least 2, got {self.min_markers}")
        if self.min_walls < 1:
            raise InputError(f"min_walls must be at least 1, got {self.min_walls}")
        if self.corner_refinement not in ("subpix", "edges"):
            raise InputError(f"corner_refinement must be 'subpix' or 'edges', got {self.corner_refinement!r}")
        if self.ransac_px <= 0 or self.good_rms_px <= 0 or self.fair_rms_px < self.good_rms_px:
            raise InputError("ransac_px, good_rms_px must be positive and fair_rms_px >= good_rms_px")

    @property
    def markers_per_wall(self) -> int:
        return self.grid[0] * self.grid[1]
