"""``cavewalk receive`` (the reference workstation receiver) and ``cavewalk bench``."""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from app.core.config import Settings, get_settings
from pipeline.demo_data import fetch_demo
from pipeline.emitter.receiver import open_receiver_socket, receive
from pipeline.errors import InputError
from pipeline.navigation.config import NavigationConfig
from pipeline.runtime.config import RuntimeConfig

if TYPE_CHECKING:
    from pipeline.runtime.bench import Scenario
    from pipeline.runtime.chain import SimWorldFactory
    from pipeline.runtime.pipeline import Pipeline

app = typer.Typer()


def _install_stop_handlers(stop: threading.Event) -> None:
    def handler(signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGINT, handler)


@app.command("receive")
def receive_cmd(
    port: Annotated[int, typer.Option("--port", "-p", help="UDP port to listen on.")],
    host: Annotated[str, typer.Option("--host", help="Address to bind.")] = "0.0.0.0",
    count: Annotated[int | None, typer.Option("--count", "-n", help="Stop after N datagrams.")] = None,
    duration: Annotated[float | None, typer.Option("--duration", help="Stop after S seconds.")] = None,
    multicast: Annotated[str | None, typer.Option("--multicast", help="Join this multicast group.")]
    = None,
    as_json: Annotated[bool, typer.Option("--json", help="One JSON object per datagram, then a "
                                          "summary object.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Only the summary.")] = False,
) -> None:
    """A reference workstation: validate each datagram (protocol v1), count drops by seq,
    print rate and latency (ts against the receive time). Exit 1 if any datagram was invalid."""
    if not 1 <= port <= 65535:
        raise InputError(f"--port must be 1-65535, got {port}")
    if count is not None and count < 1:
        raise InputError(f"--count must be >= 1, got {count}")
    if duration is not None and duration <= 0:
        raise InputError(f"--duration must be > 0, got {duration}")
    sock = open_receiver_socket(port, host, multicast)
    stop = threading.Event()
    _install_stop_handlers(stop)
    if not as_json:
        typer.echo(f"listening on udp://{host}:{port}" + (f" (group {multicast})" if multicast else ""),
                   err=True)

    def show(msg: dict[str, Any] | None, data: bytes) -> None:
        if quiet:
            return
        if as_json:
            typer.echo(json.dumps({"valid": msg is not None, "message": msg} if msg is not None else
                                  {"valid": False, "raw": data[:200].decode("utf-8", "replace")}))
        elif msg is None:
            typer.echo(f"INVALID {data[:120]!r}")
        elif msg["type"] == "locomotion":
            user = "group" if msg["user_id"] is None else msg["user_id"]
            typer.echo(f"#{msg['seq']:>6} locomotion user {user} {msg['action']:<8} "
                       f"conf {msg['confidence']:.2f} yaw {msg['yaw_deg']:7.1f} speed "
                       f"{msg['speed_mps']:.2f} pos {msg['position_m']}")
        elif msg["type"] == "head":
            typer.echo(f"#{msg['seq']:>6} head user {msg['user_id']} pos {msg['position_m']} forward "
                       f"{msg['forward']} up {msg['up']} predicted {msg['predicted_ms']:.0f} ms")
        elif msg["type"] == "navigation":
            typer.echo(f"#{msg['seq']:>6} navigation {msg['mode']} users {msg['user_ids']}")
        elif msg["type"] == "hold":
            said = f"on ({msg['by']}): every locomotion says still" if msg["held"] else "off"
            typer.echo(f"#{msg['seq']:>6} hold {said}")
        elif msg["type"] == "prompt":
            typer.echo(f"#{msg['seq']:>6} prompt {msg['label']:<8} {msg['remaining_s']:5.1f} s "
                       f"{msg['text']}")
        else:
            typer.echo(f"#{msg['seq']:>6} heartbeat {msg['state']}")

    try:
        stats = receive(sock, count=count, duration_s=duration, on_message=show, should_stop=stop.is_set)
    finally:
        sock.close()
    summary = stats.summary()
    if as_json:
        typer.echo(json.dumps({"summary": summary}))
    else:
        lat = summary["latency_ms"]
        typer.echo(
            f"received {summary['received']} ({summary['valid']} valid, {summary['invalid']} invalid), "
            f"dropped {summary['dropped']}, out of order {summary['out_of_order']}, "
            f"rate {summary['rate_hz'] or 0:.1f} Hz, "
            f"locomotion {summary['locomotion_rate_hz'] or 0:.1f} Hz"
            + (f", latency p50 {lat['p50']:.1f} / p95 {lat['p95']:.1f} / p99 {lat['p99']:.1f} ms"
               if lat else ""), err=True)
        if len(summary["by_user"]) > 1 or "group" in summary["by_user"]:
            typer.echo("streams: " + ", ".join(f"{k}: {n}" for k, n in sorted(summary["by_user"].items())),
                       err=True)
        for err in summary["errors"][:5]:
            typer.echo(f"  invalid: {err}", err=True)
    if stats.invalid:
        raise typer.Exit(1)

@app.command("bench")
def bench_cmd(
    source: Annotated[str, typer.Option("--source", help="demo, sim or both.")] = "both",
    duration: Annotated[float, typer.Option("--duration", help="Seconds measured per scenario.")] = 20.0,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the figures to this file.")]
    = None,
    flat_out: Annotated[bool, typer.Option("--flat-out/--no-flat-out",
                                           help="Also run the demo videos flat out.")] = True,
    warmup: Annotated[float, typer.Option("--warmup", help="Seconds run before measuring.")] = 2.0,
    people: Annotated[list[int] | None, typer.Option(
        "--people", help="Simulated stepping people, each a navigator of their own (navigation mode "
        "each, 30 fps): one scenario per count given (repeatable, 1-4), in place of sim_60fps.")] = None,
    navigation: Annotated[list[str] | None, typer.Option(
        "--navigation", help="The navigation mode(s) of the --people scenarios: each (default), group or "
        "single (repeatable: one scenario per mode and count, side by side in one run).")] = None,
    videos: Annotated[str, typer.Option("--videos", help="off, on (record every camera's MP4 while "
                                        "measuring, as a take does) or both (each demo scenario "
                                        "without, then with).")] = "off",
) -> None:
    """Throughput, dropped frames, per-stage and end-to-end latency, CPU and memory of the live
    pipeline: the four real demo views paced at 30 fps (and flat out), and the simulator at 60 fps
    (or, with ``--people``, with 1-4 navigators at once: the cost of each extra navigator)."""
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # SIGTERM ends like Ctrl-C: clean stop
    if source not in ("demo", "sim", "both"):
        raise InputError(f"--source must be demo, sim or both, got {source!r}")
    if duration <= 0:
        raise InputError(f"--duration must be > 0, got {duration}")
    if warmup < 0:
        raise InputError(f"--warmup must be >= 0, got {warmup}")
    if json_out is not None and json_out.exists() and json_out.is_dir():
        raise InputError(f"--json {json_out} is a folder")
    counts = list(dict.fromkeys(people or []))
    if any(not 1 <= n <= 4 for n in counts):
        raise InputError(f"--people must be 1-4 (the simulator's stepping people), got {counts}")
    if counts and source == "demo":
        raise InputError("--people needs the simulator: use --source sim or both")
    modes = list(dict.fromkeys(navigation or ["each"]))
    bad = [m for m in modes if m not in ("single", "each", "group")]
    if bad:
        raise InputError(f"--navigation must be single, each or group, got {bad[0]!r}")
    if videos not in ("off", "on", "both"):
        raise InputError(f"--videos must be off, on or both, got {videos!r}")
    if videos != "off" and source == "sim":
        raise InputError("--videos needs the demo (--source demo or both): the simulator has no images")
    # the pipeline, cv2 and scipy are imported by the command that runs them (cavewalk's start-up time)
    from pipeline.runtime.bench import machine_info, run_scenario

    scenarios = _scenarios(source, flat_out, counts, modes, videos)
    settings = get_settings()
    report: dict[str, Any] = {"machine": machine_info(settings.pose, settings.pose_model_path),
                              "duration_s": duration, "warmup_s": warmup,
                              "scenarios": {}}
    for sc in scenarios:
        typer.echo(f"== {sc.name}: {sc.notes}", err=True)
        report["scenarios"][sc.name] = run_scenario(sc, duration, warmup_s=warmup,
                                                    progress=lambda m: typer.echo(m, err=True))
    report["machine"]["load_avg_end"] = [round(v, 2) for v in os.getloadavg()]
    _print_report(report)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps(_finite(report), indent=1, allow_nan=False, default=_nan_none))
        typer.echo(f"wrote {json_out}", err=True)


def _nan_none(obj: Any) -> Any:
    return None


def _finite(obj: Any) -> Any:
    """The report with NaN (a scenario that measured nothing) as null: JSON has no NaN."""
    if isinstance(obj, float):
        return obj if obj == obj and obj not in (float("inf"), float("-inf")) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


def _scenarios(source: str, flat_out: bool, people: list[int] | None = None,
               modes: tuple[str, ...] | list[str] = ("each",), videos: str = "off") -> list[Scenario]:
    from app.services.pipeline_factory import build_pipeline, simulator_factory
    from pipeline.calibration.io import load_calibration
    from pipeline.runtime.bench import Scenario

    settings = get_settings()
    base = replace(settings.runtime, latency_window=1_000_000)
    out = []
    if source in ("demo", "both"):
        demo = fetch_demo(settings.paths.cache_dir, progress=lambda m: typer.echo(m, err=True))
        cameras = load_calibration(demo.calibration)

        def demo_pipeline(pace: float) -> Callable[[], Pipeline]:
            config = replace(base, video_pace_fps=pace, video_loop=True, target_fps=30.0)
            return lambda: build_pipeline(settings, cameras, runtime=config)

        out.append(Scenario("demo_paced_30fps", demo_pipeline(30.0), "videos", demo.videos,
                            "4 real views (Pose2Sim demo), paced at 30 fps, ROI detection "
                            f"{'on' if settings.pose.roi else 'off'}"))
        if flat_out:
            out.append(Scenario("demo_flat_out", demo_pipeline(0.0), "videos", demo.videos,
                                "4 real views read as fast as they decode"))
        if videos != "off":  # the same scenarios recording every camera's MP4, after each one without
            with_videos = [replace(sc, name=f"{sc.name}_videos", notes=f"{sc.notes}; recording an MP4 "
                                   "per camera (takes.video_*)", record_videos=settings.takes)
                           for sc in out]
            out = ([x for pair in zip(out, with_videos, strict=True) for x in pair] if videos == "both"
                   else with_videos)
    for navigation, n in ((m, n) for m in modes for n in people or ()):  # issue 20: each extra navigator
        mode = NavigationConfig(navigation, (), max(4, n))  # type: ignore[arg-type]
        crowd = settings.model_copy(update={"navigation": mode})
        sim_n = simulator_factory(crowd, replace(settings.sim, fps=30.0, people=n, bystanders=0))
        config_n = replace(base, target_fps=30.0)
        out.append(Scenario(f"sim_30fps_{navigation}_{n}p", _sim_pipeline(crowd, sim_n, config_n),
                            "simulator", None,
                            f"simulator at 30 fps, {n} stepping people, navigation {navigation}"))
    if source in ("sim", "both") and not people:
        sim = simulator_factory(settings, replace(settings.sim, fps=60.0))
        config = replace(base, target_fps=60.0)
        out.append(Scenario("sim_60fps", lambda: build_pipeline(settings, None, sim, runtime=config),
                            "simulator", None, "simulator at 60 fps (detections, no pose model)"))
    return out


def _sim_pipeline(settings: Settings, sim: SimWorldFactory, config: RuntimeConfig) -> Callable[[], Pipeline]:
    from app.services.pipeline_factory import build_pipeline

    return lambda: build_pipeline(settings, None, sim, runtime=config)


def _print_report(report: dict[str, Any]) -> None:
    m = report["machine"]
    typer.echo(f"machine: {m['cpus']} CPUs, load {m['load_avg']} at the start, {m.get('load_avg_end')} at "
               f"the end, python {m['python']}")
    typer.echo(f"cpu: {m['summary']}")
    if "execution_provider" in m:
        pose = m["pose"]
        typer.echo(f"pose: {m['execution_provider']}, {pose['precision']}, crop model "
                   f"{'on' if pose['crop_model_file'] else 'off'}, crops up to {pose['roi_long_side']} px, "
                   f"threads {pose['threads'] or 'auto'}, parallel {pose['parallel'] or 'auto'}")
    for name, r in report["scenarios"].items():
        lat = r["latency_ms"]
        typer.echo(f"{name}: {r['processed_fps']:.1f} multi-view frames/s, dropped {r['dropped_frames']} "
                   f"({100 * r['dropped_fraction']:.1f} %), cpu {r['cpu_percent']['mean']} % (of one core), "
                   f"rss {r['rss_mb']['max']} MB")
        for stage, q in lat.items():
            typer.echo(f"  {stage:<11} p50 {q['p50']:8.2f}  p95 {q['p95']:8.2f}  p99 {q['p99']:8.2f} ms")
        streams = (r.get("receiver") or {}).get("by_user") or {}
        if len(streams) > 1:
            typer.echo("  locomotion streams: "
                       + ", ".join(f"user {k}: {n}" for k, n in sorted(streams.items())))
        if r.get("videos"):
            v = r["videos"]
            typer.echo(f"  videos: {v['written_frames']} frames written "
                       f"({v['written_fps_per_camera']:.1f} fps per camera), {v['dropped_frames']} dropped "
                       f"by the encoders, {v['megabytes']} MB")
    sys.stdout.flush()
