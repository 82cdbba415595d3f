"""Models of the live pipeline: status, people, navigator, start/stop."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

Source = Literal["simulator", "cameras", "videos"]


class Health(BaseModel):
    status: Literal["ok"] = "ok"
    version: str
    database: str


class PipelineStart(BaseModel):
    model_config = ConfigDict(extra="forbid")

    source: Source = "simulator"
    videos: dict[str, str] | None = Field(
        None, description="Camera name -> video file path on the server (source 'videos').", max_length=16
    )

    @model_validator(mode="after")
    def _videos_for_videos(self) -> PipelineStart:
        if self.source == "videos" and not self.videos:
            raise ValueError("source 'videos' needs videos: {camera: path}")
        if self.source != "videos" and self.videos:
            raise ValueError(f"videos are only used with source 'videos', not {self.source!r}")
        return self


class LatencyPublic(BaseModel):
    p50: float | None = None
    p95: float | None = None
    p99: float | None = None


class CameraStatusPublic(BaseModel):
    name: str
    ok: bool
    fps: float | None = None
    last_error: str | None = None


class PersonPublic(BaseModel):
    user_id: int
    position_m: list[float] | None = None
    reproj_px: float | None = None
    is_navigator: bool = False


class ActionPublic(BaseModel):
    label: str
    probs: dict[str, float]
    yaw_deg: float | None = None
    speed_mps: float | None = None
    # the step evidence and the stepping-bout gate's verdict (pipeline.recognition.steps.StepFrame
    # .to_dict() + "gate"), for the dashboard's step strip
    steps: dict[str, Any] | None = None


class AlarmPublic(BaseModel):
    """No locomotion command has gone out for more than 2 s during a running session."""

    kind: Literal["no_locomotion"]
    session_id: int
    since_ts: float = Field(description="Unix time of the last command (or of the session's start).")
    gap_s: float
    reason: str


class StatusPublic(BaseModel):
    """Everything the dashboard shows live (also the WebSocket message, with ``type: "status"``)."""

    state: str
    source: str | None = None
    fps: float = 0.0
    dropped: int = 0
    latency_ms: dict[str, LatencyPublic] = Field(default_factory=dict)
    cameras: list[CameraStatusPublic] = Field(default_factory=list)
    people: list[PersonPublic] = Field(default_factory=list)
    navigator: int | None = None
    navigator_mode: Literal["auto", "manual"] = "auto"
    action: ActionPublic | None = None
    running_session_id: int | None = None
    active_calibration_id: int | None = None
    alarm: AlarmPublic | None = None
    ts: float = 0.0
    extra: dict[str, Any] = Field(default_factory=dict)


class NavigatorUpdate(BaseModel):
    """``{"user_id": 3}`` to pick a navigator, or ``{"mode": "auto"}`` to let the pipeline choose."""

    model_config = ConfigDict(extra="forbid")

    user_id: int | None = Field(None, ge=0, le=2**31 - 1)
    mode: Literal["auto", "manual"] | None = None

    @model_validator(mode="after")
    def _one_of(self) -> NavigatorUpdate:
        if self.user_id is None and self.mode != "auto":
            raise ValueError('give {"user_id": N} or {"mode": "auto"}')
        if self.user_id is not None and self.mode == "auto":
            raise ValueError('"user_id" and {"mode": "auto"} contradict each other')
        return self


class NavigatorPublic(BaseModel):
    navigator: int | None
    mode: Literal["auto", "manual"]
