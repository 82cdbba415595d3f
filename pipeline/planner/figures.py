"""The planner's maps as figures: floor heat maps seen from above, cameras drawn with their field of view.

matplotlib's object API on its own ``Figure`` (no pyplot, no global state); :func:`render`
returns PNG or SVG bytes.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import Any, Final

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from pipeline.camera import Camera
from pipeline.errors import InputError
from pipeline.planner.coverage import CoverageMap
from pipeline.planner.room import REGIONS
from pipeline.planner.search import LayoutResult, SearchResult

FORMATS: Final[dict[str, str]] = {"png": "image/png", "svg": "image/svg+xml"}
_FOV_REACH_M = 0.6


def freeze_layout(fig: Figure) -> Figure:
    """Lay ``fig`` out once (constrained layout) and keep that layout, so that drawing it as PNG and
    then SVG does not solve the layout again each time (it costs as much as the drawing)."""
    fig.draw_without_rendering()
    fig.set_layout_engine("none")
    return fig


def render(fig: Figure, fmt: str) -> bytes:
    """``fig`` as PNG or SVG bytes."""
    if fmt not in FORMATS:
        raise InputError(f"figure format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=110)
    return buf.getvalue()


def _edges(centres: np.ndarray) -> np.ndarray:
    step = centres[1] - centres[0] if len(centres) > 1 else 1.0
    return np.concatenate([centres - step / 2, [centres[-1] + step / 2]])


def _draw_cameras(ax: Axes, cameras: Sequence[Camera]) -> None:
    for cam in cameras:
        c = cam.center_m
        fwd = cam.R[2, :2]
        if np.linalg.norm(fwd) < 1e-6:
            fwd = np.array([0.0, 1.0])
        fwd = fwd / np.linalg.norm(fwd)
        half = np.arctan(cam.image_size[0] / (2 * cam.K[0, 0]))
        for s in (-1, 1):
            a = s * half
            d = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]) @ fwd
            ax.plot(
                [c[0], c[0] + _FOV_REACH_M * d[0]],
                [c[1], c[1] + _FOV_REACH_M * d[1]],
                color="#1b5e20",
                lw=0.8,
                alpha=0.8,
            )
        ax.annotate(
            "",
            xy=(c[0] + 0.35 * fwd[0], c[1] + 0.35 * fwd[1]),
            xytext=(c[0], c[1]),
            arrowprops={"arrowstyle": "->", "color": "#1b5e20", "lw": 1.4},
        )
        ax.plot(c[0], c[1], marker="o", ms=6, color="#1b5e20", mec="white", mew=0.8)
        ax.text(c[0], c[1], f" {cam.name}\n {c[2]:.2f} m", fontsize=7, color="#1b5e20", va="top")


def region_borders(m: CoverageMap) -> list[list[tuple[float, float]]]:
    """Line segments between neighbouring used cells of different regions."""
    reg = m.grid.region
    xe, ye = _edges(m.grid.x_m), _edges(m.grid.y_m)
    segs: list[list[tuple[float, float]]] = []
    iy, ix = np.nonzero((reg[:, :-1] != reg[:, 1:]) & (reg[:, :-1] != "") & (reg[:, 1:] != ""))
    segs += [
        [(xe[i + 1], ye[j]), (xe[i + 1], ye[j + 1])] for j, i in zip(iy.tolist(), ix.tolist(), strict=True)
    ]
    iy, ix = np.nonzero((reg[:-1] != reg[1:]) & (reg[:-1] != "") & (reg[1:] != ""))
    segs += [
        [(xe[i], ye[j + 1]), (xe[i + 1], ye[j + 1])] for j, i in zip(iy.tolist(), ix.tolist(), strict=True)
    ]
    return segs


def _floor_axes(
    ax: Axes, m: CoverageMap, values: np.ndarray, cmap: str, vmin: float, vmax: float, label: str, fig: Figure
) -> None:
    mesh = ax.pcolormesh(
        _edges(m.grid.x_m),
        _edges(m.grid.y_m),
        np.ma.masked_invalid(values),
        cmap=cmap,
        vmin=vmin,
        vmax=vmax,
        shading="flat",
    )
    ax.add_patch(Polygon(m.room.polygon_xy, closed=True, fill=False, lw=1.6, ec="black"))
    ax.add_collection(LineCollection(region_borders(m), colors="white", linewidths=0.6, alpha=0.7))
    for wall in m.room.walls:
        bottom = wall.corners_m[np.argsort(wall.corners_m[:, 2])[:2], :2].mean(axis=0)
        toward = m.room.centroid_xy - bottom
        toward = toward / max(float(np.linalg.norm(toward)), 1e-9)
        ax.text(*(bottom - 0.12 * toward), wall.name, ha="center", va="center", fontsize=8, color="0.3")
    _draw_cameras(ax, m.cameras)
    x0, y0, x1, y1 = m.room.bounds
    pad = 0.3
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m), + = right wall")
    ax.set_ylabel("y (m), + = front wall")
    fig.colorbar(mesh, ax=ax, shrink=0.8, label=label)


def _region_text(m: CoverageMap) -> str:
    rows = [f"{'region':8s} {'cells':>5s} {'error':>8s} {'valid':>6s} {'views':>6s} {'>=2 cams':>8s}"]
    for name in (*REGIONS, "floor"):
        f = m.floor if name == "floor" else m.regions.get(name)
        if f is None:
            continue
        rows.append(
            f"{name:8s} {f.cells:5d} {f.error_mm:6.1f}mm {100 * f.valid:5.1f}% {f.views:6.2f} "
            f"{100 * f.covered2:7.1f}%"
        )
    return "\n".join(rows)


def error_vmax(maps: Sequence[CoverageMap]) -> float:
    """A shared colour-scale top for error maps: the 98th percentile of their cells, but at least 2.5 x
    their median (so that an even map does not look dark all over), rounded up to 5 mm."""
    vals = np.concatenate([m.error_mm[np.isfinite(m.error_mm)] for m in maps] or [np.array([10.0])])
    top = max(float(np.percentile(vals, 98)), 2.5 * float(np.median(vals))) if vals.size else 10.0
    return max(5.0, float(np.ceil(top / 5.0) * 5.0))


def map_figure(m: CoverageMap, title: str = "camera coverage") -> Figure:
    """Two floor maps of one camera set: cameras that see a joint, and the expected 3D joint error;
    the region figures below them."""
    fig = Figure(figsize=(13, 7.6), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[6.2, 1.0])
    axes = top.subplots(1, 2)
    n = len(m.cameras)
    _floor_axes(
        axes[0], m, m.views, "viridis", 0.0, float(n), "cameras seeing a joint (mean over joints)", top
    )
    axes[0].set_title(f"visibility: {100 * m.floor.covered2:.0f} % of joints seen by >= 2 cameras")
    vmax = error_vmax([m])
    _floor_axes(axes[1], m, m.error_mm, "magma_r", 0.0, vmax, "expected 3D joint error (mm)", top)
    worst = m.regions[m.worst_region].error_mm if m.worst_region else float("nan")
    axes[1].set_title(f"expected error: mean {m.floor.error_mm:.1f} mm, {m.worst_region} {worst:.1f} mm")
    c = m.config
    top.suptitle(
        f"{title}: standing person, heights {', '.join(f'{h:.2f}' for h in c.heights_m)} m, "
        f"{len(c.facings_deg)} facings, {c.samples} draws, noise {c.faults.pixel_noise_px:g} px "
        f"at 600 px, grid {c.grid_step_m:g} m"
    )
    bottom.text(0.02, 0.95, _region_text(m), family="monospace", fontsize=8, va="top")
    bottom.text(
        0.5,
        0.95,
        "visibility: in the image, in front of the camera, no wall in between, not hidden\n"
        "by the person's own body (simulator spheres, face turned away, far ear); nobody else\n"
        "in the room. Error: Monte Carlo of the simulator's 2D noise through the pipeline's\n"
        "triangulation (mean over valid joints). White lines: region borders.",
        fontsize=8,
        va="top",
    )
    return fig


def _caption(r: LayoutResult) -> str:
    m = r.map
    corner = m.regions.get("corners")
    centre = m.regions.get("centre")
    parts = [
        f"{r.name}: objective {r.objective_mm:.1f}",
        f"mean {m.floor.error_mm:.1f} mm, worst {m.worst_region} {m.regions[m.worst_region].error_mm:.1f} mm"
        if m.worst_region
        else "",
        f"centre {centre.error_mm:.1f} / corners {corner.error_mm:.1f} mm" if centre and corner else "",
        f">=2 cams {100 * m.floor.covered2:.0f} %, valid {100 * m.floor.valid:.0f} %",
    ]
    return "\n".join(p for p in parts if p)


def search_figure(result: SearchResult) -> Figure:
    """The best layouts (and the default one) side by side: error maps on one colour scale, cameras,
    figures."""
    layouts = [*result.layouts, *([result.default] if result.default else [])]
    if not layouts:
        raise InputError("the search found no layout to draw")
    fig = Figure(figsize=(5.2 * len(layouts), 6.2), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(layouts)))
    vmax = error_vmax([r.map for r in layouts])
    for ax, r in zip(axes, layouts, strict=True):
        m = r.map
        mesh = ax.pcolormesh(
            _edges(m.grid.x_m),
            _edges(m.grid.y_m),
            np.ma.masked_invalid(m.error_mm),
            cmap="magma_r",
            vmin=0.0,
            vmax=vmax,
            shading="flat",
        )
        ax.add_patch(Polygon(m.room.polygon_xy, closed=True, fill=False, lw=1.6, ec="black"))
        _draw_cameras(ax, m.cameras)
        x0, y0, x1, y1 = m.room.bounds
        ax.set_xlim(x0 - 0.3, x1 + 0.3)
        ax.set_ylim(y0 - 0.3, y1 + 0.3)
        ax.set_aspect("equal")
        ax.set_title(_caption(r), fontsize=9)
    fig.colorbar(mesh, ax=list(axes), shrink=0.8, label="expected 3D joint error (mm)")
    fig.suptitle(
        f"mount search: {len(result.layouts[0].cameras) if result.layouts else 0} cameras, "
        f"{result.candidates} candidate mounts, {result.evaluated} layouts screened"
    )
    return fig


def figure_files(m: CoverageMap | None, result: SearchResult | None) -> dict[str, Any]:
    """name -> Figure of everything a plan draws: ``coverage`` (a given set or the best layout) and
    ``search``."""
    out: dict[str, Any] = {}
    if m is not None:
        out["coverage"] = map_figure(m)
    if result is not None:
        if result.layouts:
            best = result.layouts[0]
            out["coverage"] = map_figure(best.map, f"best layout of {len(best.cameras)}")
        out["search"] = search_figure(result)
    return {name: freeze_layout(fig) for name, fig in out.items()}
