"""A whole plan: the maps of a camera set, or a mount search for N cameras, and the files they make.

:func:`make_plan` is what ``cavewalk plan`` and ``POST /api/v1/plan`` run; :func:`write_plan` puts
``plan.json`` (the numbers), ``coverage.png/svg`` (the maps), and for a search ``search.png/svg`` (the
best layouts side by side) and ``best_layout.json`` (the best layout as a calibration JSON, to
plan with again or to mount by) into a folder.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipeline.camera import Camera
from pipeline.cave import CaveGeometry
from pipeline.errors import InputError
from pipeline.planner.config import PlannerConfig, SearchConfig
from pipeline.planner.coverage import CoverageMap, coverage_map
from pipeline.planner.room import check_cameras, floor_polygon
from pipeline.planner.search import SearchResult, search_mounts

PLAN_VERSION = 1


@dataclass(frozen=True, slots=True)
class Plan:
    """What a plan found: the maps of a given camera set (``coverage``) or a mount search (``search``)."""

    source: str
    coverage: CoverageMap | None
    search: SearchResult | None
    elapsed_s: float

    def __post_init__(self) -> None:
        if (self.coverage is None) == (self.search is None):
            raise ValueError("a plan holds either a coverage map or a search result")

    @property
    def best(self) -> CoverageMap:
        """The map to show first: the given set's, or the best layout's."""
        if self.coverage is not None:
            return self.coverage
        assert self.search is not None  # __post_init__ guarantees one of the two
        if not self.search.layouts:
            raise InputError("the search found no layout")
        return self.search.layouts[0].map

    def to_dict(self) -> dict[str, Any]:
        best = self.best
        summary = {
            "mean_error_mm": best.floor.to_dict()["error_mm"],
            "worst_region": best.worst_region,
            "regions": {k: v.to_dict() for k, v in best.regions.items()},
            "covered2": best.floor.to_dict()["covered2"],
            "valid": best.floor.to_dict()["valid"],
            "map_seconds": round(best.timings_s.get("total", float("nan")), 3),
        }
        return {
            "version": PLAN_VERSION,
            "kind": "coverage" if self.coverage is not None else "search",
            "source": self.source,
            "elapsed_s": round(self.elapsed_s, 3),
            "summary": summary,
            "coverage": self.coverage.to_dict() if self.coverage is not None else None,
            "search": self.search.to_dict() if self.search is not None else None,
        }


def make_plan(
    cave: CaveGeometry,
    *,
    cameras: Sequence[Camera] | None = None,
    count: int | None = None,
    planner: PlannerConfig | None = None,
    search: SearchConfig | None = None,
    default_cameras: Sequence[Camera] | None = None,
    source: str = "",
    progress: Callable[[float, str], None] | None = None,
) -> Plan:
    """The maps of ``cameras``, or (``count``) the best mounts for that many cameras.

    Raises InputError for walls that do not close, cameras outside the room, zero (or one) cameras,
    or both / neither of ``cameras`` and ``count``.
    """
    if (cameras is None) == (count is None):
        raise InputError("plan either a camera set or a camera count for the mount search, not both")
    p = planner or PlannerConfig()
    room = floor_polygon(cave)
    t0 = time.perf_counter()
    if cameras is not None:
        check_cameras(room, list(cameras), above_walls_m=p.above_walls_m)
        if progress:
            progress(0.1, f"mapping {len(cameras)} cameras")
        cmap = coverage_map(room, list(cameras), p)
        if progress:
            progress(1.0, "done")
        return Plan(source or "cameras", cmap, None, time.perf_counter() - t0)
    assert count is not None
    s = SearchConfig(**{**_fields(search or SearchConfig()), "count": count})
    if default_cameras is not None:
        check_cameras(room, list(default_cameras), above_walls_m=p.above_walls_m)
    result = search_mounts(cave, s, p, default_cameras, progress)
    return Plan(source or f"search for {count} cameras", None, result, time.perf_counter() - t0)


def _fields(obj: Any) -> dict[str, Any]:
    return {name: getattr(obj, name) for name in obj.__dataclass_fields__}


def write_plan(plan: Plan, out_dir: Path | str) -> list[Path]:
    """Write the plan's JSON, figures (PNG and SVG) and, for a search, the best layout's calibration."""
    from pipeline.calibration.io import save_calibration
    from pipeline.planner.figures import figure_files, render

    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the output folder {out}: {exc}") from exc
    written: list[Path] = []
    path = out / "plan.json"
    path.write_text(json.dumps(plan.to_dict(), indent=1) + "\n", encoding="utf-8")
    written.append(path)
    for name, fig in figure_files(plan.coverage, plan.search).items():
        for fmt in ("png", "svg"):
            path = out / f"{name}.{fmt}"
            path.write_bytes(render(fig, fmt))
            written.append(path)
    if plan.search is not None and plan.search.layouts:
        path = out / "best_layout.json"
        save_calibration(path, plan.search.layouts[0].cameras)
        written.append(path)
    return written
