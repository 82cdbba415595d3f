"""``cavewalk tune``: measure the pose stage's variants on this machine, keep the fastest that holds
the accuracy check, and write it where the settings read it (see :mod:`pipeline.pose.tune`)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from app.core.config import Settings, get_settings, read_tuned, reload_settings, set_settings, tuned_file
from pipeline.errors import InputError
from pipeline.machine import machine_facts

if TYPE_CHECKING:
    from pipeline.pose.tune import TuneResult

app = typer.Typer()


def run_tune(settings: Settings, out: Path, progress: Callable[[str], None] = typer.echo,
             repeats: int | None = None, sides: tuple[int, ...] | None = None) -> TuneResult:
    """Tune, write ``out`` (atomically), say what was chosen and what the settings now hold."""
    # the pose stage (cv2, onnxruntime) is imported when it is tuned, not at the top: start-up time
    from pipeline.pose.tune import tune, tuned_settings, tuned_toml

    config = settings.tune
    if repeats is not None or sides is not None:
        from dataclasses import replace

        config = replace(config, repeats=repeats or config.repeats, crop_sides=sides or config.crop_sides)
    progress(f"tuning the pose stage on {machine_facts().summary()}, load average "
             f"{os.getloadavg()[0]:.1f}")
    result = tune(settings.paths.models_dir, settings.paths.cache_dir, settings.pose, config, progress)
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(f"{out.name}.partial")
    partial.write_text(tuned_toml(result))
    partial.replace(out)
    best, before = result.best, result.baseline(settings.pose)
    if result.chosen is None or best is None:
        progress(f"no variant kept the accuracy check; wrote the measurements to {out} "
                 "(the settings keep their pose values)")
        return result
    progress(f"chosen: {result.chosen.describe()}: {best.wall_min_ms:.1f} ms per four-view frame of crops"
             + (f" (the settings before: {before.wall_min_ms:.1f} ms, {before.variant.describe()})"
                if before is not None and before.variant != result.chosen else "")
             + f"; keypoints a median {best.median_keypoint_px:.1f} px from the float32 reference")
    progress(f"wrote {out} ({result.seconds:.0f} s of measuring)")
    effective = reload_settings().pose if out == tuned_file() else None
    for key, value in tuned_settings(result).items():
        now = getattr(effective, key) if effective is not None else value
        now = list(now) if isinstance(now, tuple) else now
        wins = "" if now == value else f"  (but cavewalk.toml / CAVEWALK_* set {now!r}: that wins)"
        progress(f"  pose.{key} = {value!r}{wins}")
    return result


@app.command("tune")
def tune_cmd(
    out: Annotated[Path | None, typer.Option("--out", help="Write the result here (default: the "
                                             "tuned file the settings read).")] = None,
    repeats: Annotated[int | None, typer.Option("--repeats", help="Timed rounds per variant.")] = None,
    sides: Annotated[str | None, typer.Option("--sides", help="Crop sizes to measure, e.g. 320,256.")] = None,
) -> None:
    """Measure precision (fp32/int8), full/crop model, crop sizes, threads and parallel lanes and the
    installed execution providers on the real demo frames; keep the fastest that agrees with the
    float32 full model (the int8 check's criteria) and write it to the settings' tuned file."""
    if repeats is not None and repeats < 1:
        raise InputError(f"--repeats must be >= 1, got {repeats}")
    parsed: tuple[int, ...] | None = None
    if sides is not None:
        try:
            parsed = tuple(int(s) for s in sides.split(","))
        except ValueError:
            raise InputError(f"--sides must be comma-separated integers, got {sides!r}") from None
        if not parsed or any(s < 32 or s % 32 for s in parsed):
            raise InputError(f"--sides must be multiples of 32, got {sides!r}")
    target = out or tuned_file()
    if target.exists() and target.is_dir():
        raise InputError(f"--out {target} is a folder")
    settings = get_settings()
    run_tune(settings, target, repeats=repeats, sides=parsed)
    if target == tuned_file():
        set_settings(reload_settings())


def first_start(settings: Settings, progress: Callable[[str], None] = typer.echo) -> Settings:
    """The set-up's first start (``cavewalk demo`` / ``serve``): when this machine has no tune
    result yet, tune now and return the settings read again; else ``settings`` as they are.
    Skipped with ``tune.on_first_start = false`` or when the pose model is not prepared."""
    path = tuned_file()
    if not settings.tune.on_first_start:
        return settings
    _, why = read_tuned(path)
    if why is None:  # a result for this machine (whatever it chose)
        return settings
    if not settings.pose_model_path.is_file():
        progress(f"not tuning: no pose model yet ({settings.pose_model_path}; run  cavewalk models prepare)")
        return settings
    progress(f"first start on this machine ({why}): tuning the pose stage first "
             "(tune.on_first_start = false skips this; `cavewalk tune` re-runs it)")
    run_tune(settings, path, progress)
    fresh = reload_settings()
    set_settings(fresh)
    return fresh
