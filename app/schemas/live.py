"""Models of the live pipeline: status, people, navigator, start/stop."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, model_validator

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


class CommandPublic(BaseModel):
    """A person's own command (navigation modes each and group, issue 20; single: the navigator's)."""

    label: str
    confidence: float
    yaw_deg: float | None = None
    speed_mps: float | None = None
    steps: dict[str, Any] | None = None  # the step strip's evidence and gate verdict


class PersonPublic(BaseModel):
    user_id: int
    position_m: list[float] | None = None
    reproj_px: float | None = None
    is_navigator: bool = False
    navigating: bool = False  # has a command of their own now
    command: CommandPublic | None = None


NavigationMode = Literal["single", "each", "group"]


class GroupPublic(BaseModel):
    """The room's command in group mode: a strict majority of the members, else still."""

    label: str
    confidence: float
    members: list[int]
    votes: dict[str, int]


class NavigationPublic(BaseModel):
    mode: NavigationMode = "single"
    chosen: list[int] = Field(default_factory=list,
                              description="The chosen people; empty = everyone tracked.")
    group: GroupPublic | None = None


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


class StoragePublic(BaseModel):
    """Free disk space where the server writes (``app/services/storage.py``)."""

    level: Literal["ok", "low", "full"] = "ok"
    free_gb: float | None = Field(None, description="The least free of the file systems, GB.")
    where: str | None = Field(None, description="What it holds: database, backups or takes.")
    path: str | None = None
    message: str = ""


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
    navigation: NavigationPublic = Field(default_factory=NavigationPublic)
    action: ActionPublic | None = None
    held: bool = Field(False, description="Navigation is held (PUT /navigation/hold, or a controller "
                       "session's own hold): every locomotion datagram says still; action and people show "
                       "what the recogniser says.")
    held_by: Literal["operator", "session"] | None = Field(
        None, description="Whose hold it is: the operator's, or the running controller (CC) session's own "
        "(released when that session stops; [study] hold_controller_sessions); null while not held.")
    running_session_id: int | None = None
    active_calibration_id: int | None = None
    restart_for: list[Literal["calibration", "model"]] = Field(
        default_factory=list,
        description="What the running pipeline does not use until it starts again (POST "
        "/pipeline/restart): a calibration or action model made active since it started.")
    alarm: AlarmPublic | None = None
    storage: StoragePublic = Field(default_factory=StoragePublic)
    ts: float = 0.0
    extra: dict[str, Any] = Field(default_factory=dict)


class NavigatorUpdate(BaseModel):
    """Who navigates.

    - ``{"user_id": 3}``: single mode, user 3 chosen (``{"mode": "manual", "user_id": 3}`` too);
    - ``{"mode": "auto"}`` or ``{"mode": "single"}``: single mode, the pipeline chooses;
    - ``{"mode": "each"}`` / ``{"mode": "group"}``, optionally with ``"user_ids": [...]`` (the
      chosen people; default everyone tracked): several navigators (issue 20).
    """

    model_config = ConfigDict(extra="forbid")

    user_id: int | None = Field(None, ge=0, le=2**31 - 1)
    mode: Literal["auto", "manual", "single", "each", "group"] | None = None
    user_ids: list[int] | None = Field(None, max_length=64)

    @model_validator(mode="after")
    def _one_of(self) -> NavigatorUpdate:
        if self.mode in ("each", "group"):
            if self.user_id is not None:
                raise ValueError(f'{self.mode} mode takes "user_ids": [...], not "user_id"')
            ids = self.user_ids or []
            if any(not 0 <= u <= 2**31 - 1 for u in ids):
                raise ValueError(f"user_ids must be integers >= 0, got {ids}")
            if len(set(ids)) != len(ids):
                raise ValueError(f"user_ids must be distinct, got {ids}")
            return self
        if self.user_ids is not None:
            raise ValueError('"user_ids" go with {"mode": "each"} or {"mode": "group"}')
        if self.user_id is None and self.mode not in ("auto", "single"):
            raise ValueError('give {"user_id": N}, {"mode": "auto"}, {"mode": "each"} or {"mode": "group"}')
        if self.user_id is not None and self.mode in ("auto", "single"):
            raise ValueError(f'"user_id" and {{"mode": "{self.mode}"}} contradict each other '
                             '(single mode with a chosen navigator is {"user_id": N})')
        return self

    @property
    def navigation(self) -> NavigationMode:
        return self.mode if self.mode in ("each", "group") else "single"  # type: ignore[return-value]


class NavigatorPublic(BaseModel):
    navigator: int | None
    mode: Literal["auto", "manual"]
    navigation: NavigationMode = "single"
    user_ids: list[int] = Field(default_factory=list, description="The chosen people (each, group).")


class HoldUpdate(BaseModel):
    """``{"held": true}``: hold navigation (every locomotion datagram says ``still``, whatever the
    participant does); ``{"held": false}``: release it."""

    model_config = ConfigDict(extra="forbid")

    held: StrictBool


class HoldPublic(BaseModel):
    held: bool = Field(description="Every locomotion datagram says still while true.")
    changed: bool = Field(False, description="Whether this request changed it.")
