"""The planner's predicted error map against the simulator's measured error, by region (issue 20 item 4).

  .venv/bin/python scripts/check_planner.py [--sim-seconds S] [--seed N] [--json OUT]

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
Regions as the benchmark groups its cells: centre 1 x 1 m, the ring around it up to 1 m from the
walls (inner), the 0.5 m strips along one wall (edges), the 0.5 m corner squares (corners); each
region's figure is the mean of its cells' figures.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sim-seconds", type=float, default=6.0, help="simulated seconds per floor cell")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, help="also write the figures as JSON here")
    args = ap.parse_args()
    cave = box_cave()
    cams = default_cameras(cave, "kinect_color", 4)

    t0 = time.perf_counter()
    cells_cfg = PlannerConfig(
        grid_step_m=0.5,
        heights_m=(1.5, 1.725, 1.95),
        facings_deg=tuple(range(0, 360, 45)),
        samples=8,
        seed=args.seed,
    )
    pred_cells = coverage_map(cave, cams, cells_cfg)
    t1 = time.perf_counter()
    pred_map = coverage_map(cave, cams, PlannerConfig(seed=args.seed))
    t2 = time.perf_counter()
    print(
        f"predicted: 6 x 6 cells {t1 - t0:.1f} s, "
        f"default map {pred_map.grid.used.sum()} cells {t2 - t1:.1f} s"
    )

    bench = _bench()
    measured = {
        "still": bench.bench_sim(args.sim_seconds, args.seed, {"still": 1}),
        "stepping": bench.bench_sim(args.sim_seconds, args.seed, None),
    }
    t3 = time.perf_counter()

    # the benchmark's rows run from y = +1.25 (front) down; the planner's grid from y = -1.25 up
    pred_grid = pred_cells.error_mm[::-1]
    rows: list[dict[str, Any]] = []
    print(
        f"\n== predicted vs measured MPJPE (mm) by region; measured {args.sim_seconds:g} s per cell, "
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
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
