"""The camera-coverage planner (issue 20 item 4): its predicted error against the simulator's measured
error by region, and how long its maps take.

  .venv/bin/python scripts/bench_planner.py [--section check|speed|all] [--sim-seconds S] [--seed N]
                                            [--repeats R] [--json OUT]

check: predicted vs measured for the default cameras; layout: the same for the cameras of
--calibration (e.g. a searched best_layout.json), people stepping.
predicted  ``pipeline.planner.coverage.coverage_map`` for the default CAVE and its four default
           ``kinect_color`` cameras: (a) on the 6 x 6 cells of the benchmark (0.5 m, centres at
           +-0.25, +-0.75, +-1.25 m), with heights 1.50 / 1.725 / 1.95 m (the simulator's range) and
           eight facings, 8 draws each; (b) the planner's default map (0.15 m cells, its default
           heights, facings and draws), grouped by its own regions.
measured   ``scripts/bench_triangulation.py``'s simulator section: in every one of the 6 x 6 cells a
           random simulated person (random body, style and facing; started within +-0.15 m of the
           cell centre) for S seconds at 30 fps, the simulator's cameras with their default faults,
           the whole reconstructor (association, robust triangulation, no smoothing); MPJPE of the
           valid joints against the ground truth. Run twice: people standing still (quiet standing
           with the simulator's sway, weight shifts and gestures) and people stepping (still,
           forward, left, right evenly, as the benchmark does).
speed: wall time of one map (visibility, Monte Carlo, total; median of R runs) for the default CAVE
       and cameras at the planner's default settings (0.15 m cells, 2 heights x 4 facings x 4 draws)
       and at the panel's quick setting (0.3 m cells), of drawing its PNG and SVG, and of a mount
       search for 4 cameras (144 candidate mounts, 3 best layouts and the default one mapped).
Regions as the benchmark groups its cells: centre 1 x 1 m, the ring around it up to 1 m from the
walls (inner), the 0.5 m strips along one wall (edges), the 0.5 m corner squares (corners); each
region's figure is the mean of its cells' figures.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.cave import box_cave  # noqa: E402
from pipeline.planner.config import PlannerConfig  # noqa: E402
from pipeline.planner.coverage import coverage_map  # noqa: E402
from pipeline.sim.scene import default_cameras  # noqa: E402

BENCH_REGIONS = {  # bench_triangulation's names -> the planner's
    "centre 1x1 m": "centre",
    "central 2x2 m (excl. centre)": "inner",
    "outer ring (edges)": "edges",
    "corners": "corners",
}


def _bench() -> Any:
    spec = importlib.util.spec_from_file_location(
        "bench_triangulation", ROOT / "scripts" / "bench_triangulation.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def speed(repeats: int, seed: int) -> dict[str, Any]:
    from pipeline.planner.config import SearchConfig
    from pipeline.planner.figures import freeze_layout, map_figure, render
    from pipeline.planner.search import search_mounts

    cave = box_cave()
    cams = default_cameras(cave, "kinect_color", 4)
    out: dict[str, Any] = {"cpu": _cpu(), "cores": os.cpu_count(), "repeats": repeats}
    print(f"\n== speed on {out['cpu']} ({out['cores']} cores), median of {repeats} ==")
    for name, cfg in (
        ("default 0.15 m", PlannerConfig(seed=seed)),
        ("quick 0.3 m", PlannerConfig(grid_step_m=0.3, seed=seed)),
    ):
        runs = [coverage_map(cave, cams, cfg) for _ in range(repeats)]
        t = {
            k: float(np.median([r.timings_s[k] for r in runs]))
            for k in ("visibility", "monte_carlo", "total")
        }
        t0 = time.perf_counter()
        fig = freeze_layout(map_figure(runs[0]))
        t_layout = time.perf_counter() - t0
        t0 = time.perf_counter()
        png = render(fig, "png")
        t_png = time.perf_counter() - t0
        t0 = time.perf_counter()
        render(fig, "svg")
        t_svg = time.perf_counter() - t0
        cells = int(runs[0].grid.used.sum())
        points = cells * len(cfg.heights_m) * len(cfg.facings_deg) * cfg.samples * 17
        print(
            f"  map {name}: {cells} cells, {points} joint draws: visibility {t['visibility']:.2f} s, "
            f"Monte Carlo {t['monte_carlo']:.2f} s, total {t['total']:.2f} s; "
            f"figure layout {t_layout:.2f} s, PNG {t_png:.2f} s "
            f"({len(png) // 1024} KiB), SVG {t_svg:.2f} s"
        )
        out[name] = {**t, "cells": cells, "joint_draws": points}
        out[name] |= {"layout_s": t_layout, "png_s": t_png, "svg_s": t_svg}
    t0 = time.perf_counter()
    result = search_mounts(cave, SearchConfig(count=4), PlannerConfig(grid_step_m=0.3, seed=seed), cams)
    total = time.perf_counter() - t0
    print(
        f"  search for 4 cameras: {result.candidates} candidates, {result.evaluated} layouts screened: "
        + ", ".join(f"{k} {v:.1f} s" for k, v in result.timings_s.items())
        + f" (wall {total:.1f} s)"
    )
    out["search_4"] = {**result.timings_s, "candidates": result.candidates, "evaluated": result.evaluated}
    return out


def check(sim_seconds: float, seed: int) -> dict[str, Any]:
    cave = box_cave()
    cams = default_cameras(cave, "kinect_color", 4)
    t0 = time.perf_counter()
    cells_cfg = PlannerConfig(
        grid_step_m=0.5,
        heights_m=(1.5, 1.725, 1.95),
        facings_deg=tuple(range(0, 360, 45)),
        samples=8,
        seed=seed,
    )
    pred_cells = coverage_map(cave, cams, cells_cfg)
    t1 = time.perf_counter()
    pred_map = coverage_map(cave, cams, PlannerConfig(seed=seed))
    t2 = time.perf_counter()
    print(
        f"predicted: 6 x 6 cells {t1 - t0:.1f} s, "
        f"default map {pred_map.grid.used.sum()} cells {t2 - t1:.1f} s"
    )

    bench = _bench()
    measured = {
        "still": bench.bench_sim(sim_seconds, seed, {"still": 1}),
        "stepping": bench.bench_sim(sim_seconds, seed, None),
    }
    t3 = time.perf_counter()

    # the benchmark's rows run from y = +1.25 (front) down; the planner's grid from y = -1.25 up
    pred_grid = pred_cells.error_mm[::-1]
    rows: list[dict[str, Any]] = []
    print(
        f"\n== predicted vs measured MPJPE (mm) by region; measured {sim_seconds:g} s per cell, "
        f"{t3 - t2:.0f} s =="
    )
    print(
        f"{'region':8s} {'pred 6x6':>9s} {'pred map':>9s} {'meas still':>11s} {'meas step':>10s} "
        f"{'valid pred':>10s} {'valid still':>11s} {'valid step':>10s}"
    )
    for bench_name, region in BENCH_REGIONS.items():
        row = {
            "region": region,
            "predicted_cells_mm": pred_cells.regions[region].error_mm,
            "predicted_map_mm": pred_map.regions[region].error_mm,
            "measured_still_mm": measured["still"]["by_region"][bench_name]["raw_mm"],
            "measured_stepping_mm": measured["stepping"]["by_region"][bench_name]["raw_mm"],
            "valid_predicted": pred_cells.regions[region].valid,
            "valid_still": measured["still"]["by_region"][bench_name]["valid_pct"] / 100,
            "valid_stepping": measured["stepping"]["by_region"][bench_name]["valid_pct"] / 100,
        }
        rows.append(row)
        print(
            f"{region:8s} {row['predicted_cells_mm']:9.1f} {row['predicted_map_mm']:9.1f} "
            f"{row['measured_still_mm']:11.1f} {row['measured_stepping_mm']:10.1f} "
            f"{100 * row['valid_predicted']:9.1f}% {100 * row['valid_still']:10.1f}% "
            f"{100 * row['valid_stepping']:9.1f}%"
        )
    out: dict[str, Any] = {"regions": rows}
    for name, m in measured.items():
        meas = np.array(m["mpjpe_raw_mm"], dtype=np.float64)
        ok = np.isfinite(meas) & np.isfinite(pred_grid)
        r = float(np.corrcoef(pred_grid[ok], meas[ok])[0, 1])
        ratio = float(np.median(meas[ok] / pred_grid[ok]))
        print(
            f"cells, {name}: Pearson r = {r:.2f} between predicted and measured MPJPE, "
            f"median measured / predicted = {ratio:.2f}"
        )
        out[f"cells_{name}"] = {"pearson_r": r, "median_ratio": ratio, "measured_mm": meas.tolist()}
    out["predicted_cells_mm"] = np.where(np.isfinite(pred_grid), pred_grid, None).tolist()
    out["timings_s"] = {"predicted_cells": t1 - t0, "predicted_map": t2 - t1, "measured": t3 - t2}
    print("predicted 6 x 6 (rows y = +1.25 .. -1.25, cols x = -1.25 .. +1.25):")
    for row_vals in pred_grid:
        print("  " + " ".join(f"{v:6.1f}" for v in row_vals))
    return out


def layout(path: Path, sim_seconds: float, seed: int) -> dict[str, Any]:
    """Predicted vs measured (stepping people) for the cameras of a calibration file, e.g. a
    searched ``best_layout.json``: does the simulator confirm what the planner promised?"""
    from pipeline.calibration.io import load_calibration

    cave = box_cave()
    cams = load_calibration(path)
    cells_cfg = PlannerConfig(
        grid_step_m=0.5,
        heights_m=(1.5, 1.725, 1.95),
        facings_deg=tuple(range(0, 360, 45)),
        samples=8,
        seed=seed,
    )
    pred_cells = coverage_map(cave, cams, cells_cfg)
    pred_map = coverage_map(cave, cams, PlannerConfig(seed=seed))
    measured = _bench().bench_sim(sim_seconds, seed, None, cams)
    print(f"\n== {path}: predicted vs measured MPJPE (mm), people stepping, {sim_seconds:g} s per cell ==")
    print(
        f"{'region':8s} {'pred 6x6':>9s} {'pred map':>9s} {'measured':>9s} "
        f"{'valid pred':>10s} {'valid meas':>10s}"
    )
    rows = []
    for bench_name, region in BENCH_REGIONS.items():
        m = measured["by_region"][bench_name]
        row = {
            "region": region,
            "predicted_cells_mm": pred_cells.regions[region].error_mm,
            "predicted_map_mm": pred_map.regions[region].error_mm,
            "measured_stepping_mm": m["raw_mm"],
            "valid_predicted": pred_cells.regions[region].valid,
            "valid_stepping": m["valid_pct"] / 100,
        }
        rows.append(row)
        print(
            f"{region:8s} {row['predicted_cells_mm']:9.1f} {row['predicted_map_mm']:9.1f} "
            f"{row['measured_stepping_mm']:9.1f} {100 * row['valid_predicted']:9.1f}% "
            f"{100 * row['valid_stepping']:9.1f}%"
        )
    return {"calibration": str(path), "regions": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--section", choices=("check", "speed", "layout", "all"), default="all")
    ap.add_argument("--calibration", type=Path, help="layout: the cameras to check (e.g. a best_layout.json)")
    ap.add_argument("--sim-seconds", type=float, default=6.0, help="simulated seconds per floor cell")
    ap.add_argument("--repeats", type=int, default=3, help="timing runs per map (median)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, help="also write the figures as JSON here")
    args = ap.parse_args()
    out: dict[str, Any] = {}
    if args.section in ("speed", "all"):
        out["speed"] = speed(args.repeats, args.seed)
    if args.section in ("check", "all"):
        out["check"] = check(args.sim_seconds, args.seed)
    if args.section == "layout":
        if args.calibration is None:
            ap.error("--section layout needs --calibration")
        out["layout"] = layout(args.calibration, args.sim_seconds, args.seed)
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
