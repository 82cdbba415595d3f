"""``cavewalk process`` end to end on the real demo, and its bad-input cases (exit 2, one message,
no output file touched). Runs the real entry point ``app.cli.main`` in this process."""

from __future__ import annotations

import json
import logging
import sys
from collections import Counter
from pathlib import Path

import pytest

from app.cli import main
from app.core.config import Settings, set_settings
from pipeline.demo_data import DemoData


def cavewalk(args: list[str], monkeypatch: pytest.MonkeyPatch) -> int:
    """Run the CLI entry point; its log handler and settings do not outlive the call."""
    root = logging.getLogger()

    def drop_handlers() -> None:
        for h in [h for h in root.handlers if getattr(h, "_cavewalk", False)]:
            root.removeHandler(h)

    drop_handlers()
    monkeypatch.setattr(sys, "argv", ["cavewalk", *args])
    try:
        main()
    except SystemExit as exc:
        return int(exc.code or 0)
    finally:
        drop_handlers()
        set_settings(None)  # the CLI installs the settings it read; later tests read their own
    return 0


def video_args(demo: DemoData) -> list[str]:
    return [a for cam, path in demo.videos.items() for a in ("--video", f"{cam}={path}")]


@pytest.mark.slow
def test_process_writes_views_for_every_frame(
    demo_data: DemoData, pose_model_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "r.jsonl"
    monkeypatch.setenv("CAVEWALK_POSE__MODEL", str(pose_model_path))
    rc = cavewalk(["process", *video_args(demo_data), "--calibration", str(demo_data.calibration),
                   "--out", str(out), "--frames", "12", "--roi"], monkeypatch)
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    assert "frame 12/12" in captured.err, "progress on the terminal"
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [rec["frame"] for rec in lines] == list(range(12))
    assert lines[1]["t"] == pytest.approx(1 / 60, abs=1e-6), "timestamps from the videos' 60 fps"
    for rec in lines:
        assert set(rec) == {"frame", "t", "views", "people3d", "navigator", "action"}
        assert [v["camera"] for v in rec["views"]] == list(demo_data.videos)
        for view in rec["views"]:
            assert view["people"], f"frame {rec['frame']} {view['camera']}: the subject is tracked"
            p = view["people"][0]
            assert len(p["bbox"]) == 4 and len(p["keypoints"]) == 17 and len(p["keypoints"][0]) == 3
    ids = {(v["camera"], p["track_id"]) for rec in lines for v in rec["views"] for p in v["people"]}
    assert {cam for cam, _ in ids} == set(demo_data.videos)
    assert not out.with_name(out.name + ".partial").exists()


@pytest.mark.slow
def test_process_writes_3d_people_navigator_and_action(
    demo_data: DemoData, pose_model_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The whole pipeline on the real demo with its Qualisys calibration: 3D skeletons of a
    person-sized subject, one persistent user id, an automatic navigator and its action."""
    out = tmp_path / "r.jsonl"
    monkeypatch.setenv("CAVEWALK_POSE__MODEL", str(pose_model_path))
    rc = cavewalk(["process", *video_args(demo_data), "--calibration", str(demo_data.calibration),
                   "--out", str(out), "--frames", "60"], monkeypatch)
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(lines) == 60
    seen = Counter(p["user_id"] for rec in lines for p in rec["people3d"])
    subject, frames_seen = seen.most_common(1)[0]
    assert frames_seen >= 55, f"the subject (user {subject}) is in only {frames_seen} of 60 frames: {seen}"
    for rec in lines[::10]:
        person = next((p for p in rec["people3d"] if p["user_id"] == subject), None)
        if person is None:
            continue
        nose, l_ankle = person["joints"][0], person["joints"][15]
        if nose is not None and l_ankle is not None:
            height = abs(nose[2] - l_ankle[2])
            assert 1.2 < height < 2.0, f"frame {rec['frame']}: nose-to-ankle {height:.2f} m is not a person"
        assert person["reproj_px"] is not None and person["reproj_px"] < 40
    navigated = [rec for rec in lines if rec["navigator"] is not None]
    assert navigated, "auto mode picks a navigator within the first second"
    assert {rec["navigator"] for rec in navigated} == {subject}, "the subject, not the bystander, navigates"
    assert all(rec["action"] is not None for rec in navigated[5:]), "the navigator's action is reported"
    labels = {rec["action"]["label"] for rec in navigated if rec["action"]}
    assert labels <= {"still", "forward", "left", "right"}
    assert "a navigator in" in captured.out


@pytest.mark.parametrize(
    ("make_args", "message"),
    [
        (lambda d, t: ["--video", "cam01", "--calibration", str(d.calibration)], "expected NAME=PATH"),
        (lambda d, t: ["--video", f"cam01={t / 'missing.mp4'}", "--calibration", str(d.calibration)],
         "video file not found"),
        (lambda d, t: ["--video", f"cam01={d.calibration}", "--calibration", str(d.calibration)],
         "cannot decode video"),
        (lambda d, t: ["--video", f"cam07={d.videos['cam01']}", "--calibration", str(d.calibration)],
         "must match the calibration"),
        (lambda d, t: ["--video", f"cam01={d.videos['cam01']}", "--calibration", str(t / "none.json")],
         "calibration file not found"),
        (lambda d, t: ["--video", f"cam01={d.videos['cam01']}", "--video", f"cam01={d.videos['cam02']}",
                       "--calibration", str(d.calibration)], "given twice"),
    ],
)
def test_bad_input_is_one_message_and_exit_2(
    make_args: object, message: str, demo_data: DemoData, tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "r.jsonl"
    out.write_text("previous results\n")
    args = make_args(demo_data, tmp_path)  # type: ignore[operator]
    rc = cavewalk(["process", *args, "--out", str(out)], monkeypatch)
    err = capsys.readouterr().err
    assert rc == 2
    assert "error:" in err and message in err, err
    assert "Traceback" not in err
    assert out.read_text() == "previous results\n", "rejected input leaves the output file unchanged"


def test_missing_model_is_a_clear_error(
    demo_data: DemoData, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str], isolated_settings: Settings,
) -> None:
    monkeypatch.setenv("CAVEWALK_POSE__MODEL", str(tmp_path / "absent.onnx"))
    out = tmp_path / "r.jsonl"
    rc = cavewalk(["process", *video_args(demo_data), "--calibration", str(demo_data.calibration),
                   "--out", str(out)], monkeypatch)
    err = capsys.readouterr().err
    assert rc == 2 and "cavewalk models prepare" in err, err
    assert not out.exists()


def truncated_copy(video: Path, out: Path, keep: float) -> None:
    """``video`` remuxed with its index first (faststart), then cut to ``keep`` of its bytes: the
    container still reports every frame, the decoder runs out part-way (a copy cut short)."""
    import av

    full = out.with_suffix(".full.mp4")
    with av.open(str(video)) as src, av.open(str(full), "w", options={"movflags": "faststart"}) as dst:
        stream = dst.add_stream_from_template(src.streams.video[0])
        for packet in src.demux(src.streams.video[0]):
            if packet.dts is not None:
                packet.stream = stream
                dst.mux(packet)
    data = full.read_bytes()
    out.write_bytes(data[: int(len(data) * keep)])


@pytest.mark.slow
def test_a_truncated_video_is_reported_with_the_frames_each_view_had(
    demo_data: DemoData, pose_model_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Issue 15: a cut-short video said '100 frames', wrote 55 and exited 0 without a word."""
    import cv2

    cut = tmp_path / "cam03.mp4"
    truncated_copy(demo_data.videos["cam03"], cut, 0.55)
    cap = cv2.VideoCapture(str(cut))
    reported = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
    really = 0
    while cap.grab():
        really += 1
    cap.release()
    assert reported == 100 and 10 < really < 90, (reported, really)
    videos = {**demo_data.videos, "cam03": cut}
    out = tmp_path / "r.jsonl"
    monkeypatch.setenv("CAVEWALK_POSE__MODEL", str(pose_model_path))
    args = [a for cam, path in videos.items() for a in ("--video", f"{cam}={path}")]
    rc = cavewalk(["process", *args, "--calibration", str(demo_data.calibration), "--out", str(out)],
                  monkeypatch)
    err = capsys.readouterr().err
    assert rc == 0, "frames were written: the run is not a failure"
    assert len(out.read_text().splitlines()) == really, "one line per multi-view frame written"
    warning = next(line for line in err.splitlines() if line.startswith("warning:"))
    assert f"ran out after {really} multi-view frames" in warning and "100 their files report" in warning
    assert f"cam03: {really} frames (its file reports 100: it ends at frame {really})" in warning, warning
    for cam in ("cam01", "cam02", "cam04"):
        assert f"{cam}: 100 frames;" in warning or f"{cam}: 100 frames." in warning, warning

    empty = tmp_path / "empty.mp4"
    truncated_copy(demo_data.videos["cam03"], empty, 0.03)  # the index and no frame
    out.write_text("previous\n")
    rc = cavewalk(["process", "--video", f"cam01={demo_data.videos['cam01']}", "--video", f"cam03={empty}",
                   "--calibration", str(demo_data.calibration), "--out", str(out)], monkeypatch)
    err = capsys.readouterr().err
    assert rc == 2 and "error:" in err and "Traceback" not in err, err
    assert out.read_text() == "previous\n", "nothing processed, nothing replaced"
