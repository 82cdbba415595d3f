"""The mount search: where to hang N cameras so that a standing person is seen and triangulated well.

Candidate mounts (:func:`candidate_mounts`): the room's top corners and the middle of each wall's top
edge, a little inside the walls, at a few heights, each aimed at the room's centre turned by a few
pan angles and tilted to look at a few heights there. A layout is N candidates on distinct spots.

The search runs in two passes:

1. **Screening** on a coarse grid with the triangulation's first-order error: for a joint seen by
   cameras c, the information of the least-squares triangulation is sum_c w_c J_c^T J_c / sigma_c^2
   (J_c the 2 x 3 pixel Jacobian of the projection, sigma_c the simulator's noise for that joint at
   that person size, w_c the chance the view is used: 1 when seen, the chance a hidden joint's
   guessed score passes ``min_score`` and its extra noise when hidden; times the chance the person
   is not missed). The expected error is 0.92 sqrt(trace(inverse)), exact for an isotropic Gaussian.
   The information adds over cameras, so every candidate's share is computed once and a swap costs
   one closed-form 3 x 3 inverse per joint. Joints seen by fewer than two cameras cost
   ``miss_penalty_mm``. A coordinate descent from several starts (the default layout, corners
   first, a greedy build) swaps one camera at a time for the candidate that lowers the objective
   most: ``(1 - worst_weight) x mean cell error + worst_weight x the worst region's mean error``.
2. **Mapping**: the ``top_k`` best layouts of the screening, and the default layout for reference,
   get the planner's full Monte Carlo map (:func:`pipeline.planner.coverage.coverage_map`), and
   are ranked by the same objective on those maps (invalid joints charged the penalty).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera, look_at
from pipeline.cave import CaveGeometry
from pipeline.errors import InputError
from pipeline.numbers import rounded
from pipeline.planner.config import PlannerConfig, SearchConfig
from pipeline.planner.coverage import CoverageMap, coverage_map, floor_grid, place, see, standing_poses
from pipeline.planner.room import REGIONS, Room, floor_polygon
from pipeline.sim.scene import PRESETS, camera_positions
from pipeline.sim.views import _NOISE_REL, _REF_HEIGHT_PX, FaultConfig

F64 = NDArray[np.float64]
B = NDArray[np.bool_]
I64 = NDArray[np.int64]

#: E|e| / sqrt(trace(cov)) of an isotropic 3D Gaussian: sqrt(8 / pi) / sqrt(3).
MEAN_NORM_FACTOR = float(np.sqrt(8.0 / np.pi) / np.sqrt(3.0))
_SYM = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))  # the 6 entries of a symmetric 3 x 3 kept
MAX_SWEEPS = 6


@dataclass(frozen=True, slots=True)
class Mount:
    """One candidate camera mount: where it hangs and how it is aimed.

    kind: ``corner`` or ``wall``; spot: index of the spot (distinct spots per layout).
    position_m: (3,) camera centre; target_m: (3,) the point it looks at.
    pan_deg: the turn away from the room's centre; aim_height_m: the height looked at there.
    """

    kind: str
    spot: int
    position_m: F64
    target_m: F64
    pan_deg: float
    aim_height_m: float

    @property
    def label(self) -> str:
        x, y, z = self.position_m
        return (
            f"{self.kind} ({x:+.2f}, {y:+.2f}) h {z:.2f} m, pan {self.pan_deg:+.0f}°, "
            f"aim {self.aim_height_m:.1f} m"
        )

    def camera(self, name: str, preset: str) -> Camera:
        p = PRESETS[preset]
        R, t = look_at(self.position_m, self.target_m)
        return Camera(name, p.image_size, p.K(), np.asarray(p.dist), R, t)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "position_m": [round(float(v), 4) for v in self.position_m],
            "target_m": [round(float(v), 4) for v in self.target_m],
            "pan_deg": self.pan_deg,
            "aim_height_m": self.aim_height_m,
            "label": self.label,
        }


def mount_spots(room: Room, kinds: Sequence[str], inset_m: float) -> list[tuple[str, F64]]:
    """(kind, (2,) floor position) of every spot: corners first, then the walls' middles."""
    a, b = room.edges
    d = b - a
    normals = np.stack([-d[:, 1], d[:, 0]], axis=1)  # left of each edge = inside (counter-clockwise)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    spots: list[tuple[str, F64]] = []
    if "corner" in kinds:
        for i in range(len(a)):
            n1, n2 = normals[i - 1], normals[i]  # the two edges that meet at vertex i
            denom = 1.0 + float(n1 @ n2)
            if denom < 1e-6:
                continue
            spots.append(("corner", a[i] + inset_m * (n1 + n2) / denom))
    if "wall" in kinds:
        for i in range(len(a)):
            spots.append(("wall", (a[i] + b[i]) / 2.0 + inset_m * normals[i]))
    return spots


def check_search(room: Room, search: SearchConfig) -> None:
    """Raise InputError unless the preset exists and the room has a spot for every camera."""
    if search.preset not in PRESETS:
        raise InputError(f"unknown camera preset {search.preset!r}; presets are {', '.join(PRESETS)}")
    n_spots = len(mount_spots(room, search.mounts, search.inset_m))
    if search.count > n_spots:
        raise InputError(
            f"{search.count} cameras need {search.count} mount spots; this room has {n_spots} "
            f"({', '.join(search.mounts)})"
        )


def candidate_mounts(room: Room, search: SearchConfig, above_walls_m: float) -> list[Mount]:
    """Every spot x height x pan x aim height of the search, with heights clipped into the room."""
    centre = room.centroid_xy
    top = room.height_m + above_walls_m
    heights = sorted({round(min(h, top - 0.01), 3) for h in search.heights_m if h > 0.0})
    out: list[Mount] = []
    for s, (kind, xy) in enumerate(mount_spots(room, search.mounts, search.inset_m)):
        to_centre = centre - xy
        for h in heights:
            for pan in search.pans_deg:
                a = np.radians(pan)
                rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
                txy = xy + rot @ to_centre
                for aim in search.aim_heights_m:
                    if abs(aim - h) < 0.05 and np.linalg.norm(to_centre) < 0.05:
                        continue
                    out.append(
                        Mount(
                            kind,
                            s,
                            np.array([xy[0], xy[1], h]),
                            np.array([txy[0], txy[1], aim]),
                            float(pan),
                            float(aim),
                        )
                    )
    return out


# --- screening: the first-order error ---------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Screen:
    """Every candidate's share of the information on the screening grid.

    info: (M, G, P, 17, 6) the symmetric 3 x 3 information (per m²) of each joint, from each candidate.
    seen: (M, G, P, 17) candidate m sees the joint. region: (G,) region of each screening cell.
    """

    info: F64
    seen: B
    region: NDArray[np.str_]


def _score_pass(faults: FaultConfig, min_score: float) -> float:
    """Chance that a hidden joint's guessed score (uniform in score_hidden) reaches ``min_score``."""
    lo, hi = faults.score_hidden
    if hi <= lo:
        return 1.0 if lo >= min_score else 0.0
    return float(np.clip((hi - max(lo, min_score)) / (hi - lo), 0.0, 1.0))


def screen(room: Room, cameras: Sequence[Camera], planner: PlannerConfig, step_m: float) -> Screen:
    """The information each camera would add for a standing person on a coarse grid."""
    grid = floor_grid(room, step_m, planner.wall_clearance_m, planner.region_band_m)
    heights = (float(np.mean(planner.heights_m)),)
    poses = standing_poses(heights, planner.facings_deg, planner.seed)
    cells = grid.cells_xy
    faults, params = planner.faults, planner.triangulation
    sight = see(room, cameras, poses, cells, faults)
    pts = place(poses, cells)  # (G, P, J, 3)
    R = np.stack([c.R for c in cameras])  # (M, 3, 3)
    t = np.stack([c.t for c in cameras])
    f = np.array([[c.K[0, 0], c.K[1, 1]] for c in cameras])  # (M, 2)
    pc = np.einsum("mij,gpkj->mgpki", R, pts) + t[:, None, None, None, :]
    z = np.where(pc[..., 2] > 1e-3, pc[..., 2], np.nan)
    x, y = pc[..., 0] / z, pc[..., 1] / z
    r0, r1, r2 = (R[:, None, None, None, i, :] for i in range(3))
    ju = f[:, 0, None, None, None, None] * (r0 - x[..., None] * r2) / z[..., None]
    jv = f[:, 1, None, None, None, None] * (r1 - y[..., None] * r2) / z[..., None]
    sigma = faults.pixel_noise_px * np.maximum(sight.body_px, 40.0)[..., None] / _REF_HEIGHT_PX * _NOISE_REL
    use_hidden = _score_pass(faults, params.min_score) / (1.0 + faults.hidden_noise_scale) ** 2
    w = np.where(sight.hidden, use_hidden, 1.0) * (sight.in_view & sight.detected[..., None])
    w = w * (1.0 - faults.person_miss_rate) / np.where(sigma > 0, sigma, 1.0) ** 2
    w = np.where(np.isfinite(w) & np.isfinite(z), w, 0.0)
    info = np.stack([w * (ju[..., a] * ju[..., b] + jv[..., a] * jv[..., b]) for a, b in _SYM], axis=-1)
    info = np.where(np.isfinite(info), info, 0.0)
    return Screen(info, sight.seen, grid.region[grid.used])


def first_order_error_mm(info: F64, seen_count: I64, penalty_mm: float) -> F64:
    """(...,) expected error from (..., 6) summed information and the count of cameras seeing each joint."""
    a, b, c, d, e, g = (info[..., k] for k in range(6))  # xx, yy, zz, xy, xz, yz
    det = a * (b * c - g * g) - d * (d * c - g * e) + e * (d * g - b * e)
    adj_trace = (b * c - g * g) + (a * c - e * e) + (a * b - d * d)
    with np.errstate(divide="ignore", invalid="ignore"):
        tr = adj_trace / det
    err = 1000.0 * MEAN_NORM_FACTOR * np.sqrt(np.where(tr > 0, tr, np.inf))
    out: F64 = np.where((seen_count >= 2) & np.isfinite(err), np.minimum(err, penalty_mm), penalty_mm)
    return out


def objective(cell_cost_mm: F64, region: NDArray[np.str_], worst_weight: float) -> F64:
    """(..., G) per-cell costs -> (...,) (1 - w) x their mean + w x the worst region's mean."""
    means = [cell_cost_mm[..., region == r].mean(axis=-1) for r in REGIONS if np.any(region == r)]
    worst = np.max(np.stack(means, axis=0), axis=0)
    out: F64 = (1.0 - worst_weight) * cell_cost_mm.mean(axis=-1) + worst_weight * worst
    return out


class _Screening:
    """Fast objective of layouts (tuples of candidate indices) on a :class:`Screen`."""

    def __init__(self, scr: Screen, spots: I64, search: SearchConfig) -> None:
        self.scr = scr
        self.spots = spots
        self.search = search
        self.evaluated: dict[tuple[int, ...], float] = {}

    def _cost(self, info: F64, count: I64) -> F64:
        err = first_order_error_mm(info, count, self.search.miss_penalty_mm)  # (..., G, P, J)
        cells = err.reshape(*err.shape[:-2], -1).mean(axis=-1)
        return objective(cells, self.scr.region, self.search.worst_weight)

    def value(self, layout: Sequence[int]) -> float:
        key = tuple(sorted(layout))
        if key not in self.evaluated:
            idx = list(key)
            info = self.scr.info[idx].sum(axis=0)
            count = self.scr.seen[idx].sum(axis=0)
            self.evaluated[key] = float(self._cost(info, count))
        return self.evaluated[key]

    def best_swap(self, layout: list[int], slot: int) -> tuple[int, float]:
        """The candidate for ``slot`` (others kept) with the lowest objective, and that objective."""
        rest = [m for k, m in enumerate(layout) if k != slot]
        info_rest = self.scr.info[rest].sum(axis=0)
        count_rest = self.scr.seen[rest].sum(axis=0)
        taken = set(self.spots[rest].tolist())
        free = np.array([m for m in range(len(self.spots)) if int(self.spots[m]) not in taken])
        best_m, best_v = layout[slot], self.value(layout)
        for chunk in np.array_split(free, max(1, len(free) // 24)):
            if chunk.size == 0:
                continue
            values = self._cost(
                info_rest[None] + self.scr.info[chunk], count_rest[None] + self.scr.seen[chunk]
            )
            for m, v in zip(chunk.tolist(), values.tolist(), strict=True):
                self.evaluated.setdefault(tuple(sorted([*rest, m])), float(v))
                if v < best_v - 1e-9:
                    best_m, best_v = m, float(v)
        return best_m, best_v

    def descend(self, layout: list[int]) -> list[int]:
        layout = list(layout)
        for _ in range(MAX_SWEEPS):
            improved = False
            for slot in range(len(layout)):
                m, v = self.best_swap(layout, slot)
                if m != layout[slot] and v < self.value(layout) - 1e-9:
                    layout[slot] = m
                    improved = True
            if not improved:
                break
        return layout


def _nearest(mounts: Sequence[Mount], eye: F64, target: F64, taken: set[int]) -> int:
    d = np.array(
        [
            float(np.linalg.norm(m.position_m - eye) + 0.3 * np.linalg.norm(m.target_m - target))
            if m.spot not in taken
            else np.inf
            for m in mounts
        ]
    )
    return int(np.argmin(d))


def _starts(
    room: Room, mounts: Sequence[Mount], scr: _Screening, count: int, cave: CaveGeometry
) -> list[list[int]]:
    """Start layouts: the default one (wall middles, then corners, where ``pipeline.sim.scene`` hangs
    its cameras), corners first, and a greedy build."""
    starts: list[list[int]] = []
    n_spots = len(set(scr.spots.tolist()))
    centre = np.array([*room.centroid_xy, 1.0])
    orders: list[list[F64]] = []
    with contextlib.suppress(InputError):  # more cameras than the default scene has places for
        orders.append([np.asarray(e, dtype=np.float64) for e in camera_positions(cave, count)])
    by_spot: dict[int, F64] = {}
    for mount in mounts:  # mount_spots lists the corners first
        by_spot.setdefault(mount.spot, mount.position_m)
    orders.append([by_spot[k] for k in sorted(by_spot)][:count])
    for order in orders:
        if len(order) != count:
            continue
        taken: set[int] = set()
        layout = []
        for eye in order:
            m = _nearest(mounts, eye, centre, taken)
            layout.append(m)
            taken.add(mounts[m].spot)
        if layout not in starts:
            starts.append(layout)
    # greedy: the candidate seeing most joints first, then whatever lowers the objective most
    first = int(np.argmax(scr.scr.seen.reshape(len(mounts), -1).sum(axis=1)))
    layout = [first]
    while len(layout) < min(count, n_spots):
        layout.append(layout[-1])
        m, _ = scr.best_swap(layout, len(layout) - 1)
        layout[-1] = m
    if len(layout) == count:
        starts.append(layout)
    return starts


# --- the search -----------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class LayoutResult:
    """One layout mapped by the full Monte Carlo.

    name: ``best 1`` ... or ``default``. mounts: the mounts (None for a given camera set).
    screen_objective_mm: the screening's objective; objective_mm: the same on the Monte Carlo map.
    """

    name: str
    cameras: tuple[Camera, ...]
    mounts: tuple[Mount, ...] | None
    map: CoverageMap
    screen_objective_mm: float
    objective_mm: float

    def to_dict(self) -> dict[str, Any]:
        m = self.map
        return {
            "name": self.name,
            "objective_mm": round(self.objective_mm, 3),
            "screen_objective_mm": round(self.screen_objective_mm, 3),
            "mean_error_mm": rounded(m.floor.error_mm),
            "worst_region": m.worst_region,
            "worst_region_error_mm": rounded(m.regions[m.worst_region].error_mm) if m.worst_region else None,
            "corner_error_mm": rounded(m.regions["corners"].error_mm) if "corners" in m.regions else None,
            "centre_error_mm": rounded(m.regions["centre"].error_mm) if "centre" in m.regions else None,
            "covered2": rounded(m.floor.covered2),
            "valid": rounded(m.floor.valid),
            "mounts": [x.to_dict() for x in self.mounts] if self.mounts else None,
            "calibration": {"cameras": [c.to_dict() for c in self.cameras]},
            "map": m.to_dict(),
        }


@dataclass(frozen=True, slots=True)
class SearchResult:
    """The best layouts (best first), the default layout mapped the same way, and the search's costs."""

    layouts: tuple[LayoutResult, ...]
    default: LayoutResult | None
    candidates: int
    evaluated: int
    timings_s: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "candidates": self.candidates,
            "evaluated_layouts": self.evaluated,
            "layouts": [r.to_dict() for r in self.layouts],
            "default": self.default.to_dict() if self.default else None,
            "timings_s": {k: round(v, 3) for k, v in self.timings_s.items()},
        }


def map_objective(m: CoverageMap, search: SearchConfig) -> float:
    """The search's objective on a Monte Carlo map: invalid joints cost the penalty."""
    used = m.grid.used
    err = np.where(np.isfinite(m.error_mm[used]), m.error_mm[used], search.miss_penalty_mm)
    valid = np.where(np.isfinite(m.valid[used]), m.valid[used], 0.0)
    cost = valid * err + (1.0 - valid) * search.miss_penalty_mm
    return float(objective(cost, m.grid.region[used], search.worst_weight))


def search_mounts(
    cave: CaveGeometry,
    search: SearchConfig | None = None,
    planner: PlannerConfig | None = None,
    default_cameras: Sequence[Camera] | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> SearchResult:
    """The ``top_k`` best layouts of ``search.count`` cameras, mapped; ``default_cameras`` mapped alike."""
    s = search or SearchConfig()
    p = planner or PlannerConfig()
    report = progress or (lambda _f, _m: None)
    room = floor_polygon(cave)
    t0 = time.perf_counter()
    check_search(room, s)
    mounts = candidate_mounts(room, s, p.above_walls_m)
    cams = [m.camera(f"m{i:03d}", s.preset) for i, m in enumerate(mounts)]
    report(0.05, f"screening {len(mounts)} candidate mounts")
    scr = screen(room, cams, replace(p, samples=1), s.screen_step_m)
    spots = np.array([m.spot for m in mounts])
    fast = _Screening(scr, spots, s)
    t1 = time.perf_counter()
    finals = []
    starts = _starts(room, mounts, fast, s.count, cave)
    for i, start in enumerate(starts):
        finals.append(fast.descend(start))
        report(0.1 + 0.4 * (i + 1) / len(starts), f"searched from start {i + 1} of {len(starts)}")
    ranked = sorted(fast.evaluated.items(), key=lambda kv: kv[1])
    chosen: list[tuple[tuple[int, ...], float]] = []
    spot_sets: set[tuple[int, ...]] = set()
    for key, value in ranked:  # the best layout of each set of spots: alternatives, not near-copies
        where = tuple(sorted(int(spots[m]) for m in key))
        if len(key) == s.count and len(set(where)) == s.count and where not in spot_sets:
            chosen.append((key, value))
            spot_sets.add(where)
        if len(chosen) == s.top_k:
            break
    t2 = time.perf_counter()
    results = []
    for i, (key, value) in enumerate(chosen):
        layout = tuple(mounts[m] for m in key)
        named = tuple(m.camera(f"cam{k + 1:02d}", s.preset) for k, m in enumerate(layout))
        cmap = coverage_map(room, named, p)
        results.append(LayoutResult(f"layout {i + 1}", named, layout, cmap, value, map_objective(cmap, s)))
        report(0.5 + 0.45 * (i + 1) / (len(chosen) + 1), f"mapped layout {i + 1} of {len(chosen)}")
    results.sort(key=lambda r: r.objective_mm)
    results = [replace(r, name=f"best {k + 1}") for k, r in enumerate(results)]
    default = None
    if default_cameras is not None:
        dmap = coverage_map(room, default_cameras, p)
        dscr = screen(room, list(default_cameras), replace(p, samples=1), s.screen_step_m)
        dval = float(fast._cost(dscr.info.sum(axis=0), dscr.seen.sum(axis=0)))
        default = LayoutResult("default", tuple(default_cameras), None, dmap, dval, map_objective(dmap, s))
    t3 = time.perf_counter()
    report(1.0, "done")
    return SearchResult(
        tuple(results),
        default,
        len(mounts),
        len(fast.evaluated),
        {"screen": t1 - t0, "search": t2 - t1, "maps": t3 - t2, "total": t3 - t0},
    )
