"""The one settings object of cavewalk (pydantic-settings).

Sources, highest priority first: keyword arguments, ``CAVEWALK_*`` environment
variables (nested with ``__``, e.g. ``CAVEWALK_SERVER__PORT=9000``), the TOML file
(``cavewalk.toml`` in the working directory, or the path given by ``--config`` /
``CAVEWALK_CONFIG``), then the defaults below. Unknown keys are errors, so a typo
in the file is reported by name instead of silently ignored.

Each pipeline stage gets its own small frozen config dataclass, built here once
(``*.to_config()``) and passed to the stage's constructor.
"""

from __future__ import annotations

import os
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from pydantic_settings import (
    BaseSettings,
    PydanticBaseSettingsSource,
    SettingsConfigDict,
    TomlConfigSettingsSource,
)

from pipeline.cave import CaveGeometry, Wall, box_cave
from pipeline.errors import ConfigError
from pipeline.pose.model_files import pose_model_file

DEFAULT_CONFIG_FILE = Path("cavewalk.toml")
# The TOML file given to load_settings(); read by Settings.settings_customise_sources.
_TOML_FILE: ContextVar[Path | None] = ContextVar("cavewalk_toml_file", default=None)
_HOME = Path.home()


def _user_dir(xdg_variable: str, fallback: Path) -> Path:
    """cavewalk's folder in the user's data directory (``$XDG_DATA_HOME``, else ``fallback``)."""
    value = os.environ.get(xdg_variable)
    base = Path(value) if value and Path(value).is_absolute() else fallback
    return base / "cavewalk"


#: Where the database lives unless told otherwise (``paths.db``, ``--db``): the user's data directory.
USER_DATA_DIR = _user_dir("XDG_DATA_HOME", _HOME / ".local" / "share")
USER_CACHE_DIR = _HOME / ".cache" / "cavewalk"  # the pose model and the demo data (shared by installs)


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class WallSettings(_Section):
    name: str
    corners: Annotated[list[list[float]], Field(min_length=4, max_length=4)]
    resolution_px: tuple[int, int] = (1920, 1600)


class CaveSettings(_Section):
    """CAVE geometry. Without ``walls``, a box of width x depth x height with four walls."""

    width_m: float = Field(3.0, gt=0)
    depth_m: float = Field(3.0, gt=0)
    height_m: float = Field(2.5, gt=0)
    wall_resolution_px: tuple[int, int] = (1920, 1600)
    walls: list[WallSettings] | None = None

    def geometry(self) -> CaveGeometry:
        if self.walls is None:
            return box_cave(self.width_m, self.depth_m, self.height_m, self.wall_resolution_px)
        return CaveGeometry(
            walls=tuple(Wall(w.name, w.corners, w.resolution_px) for w in self.walls),  # type: ignore[arg-type]
            floor_half_size_m=(self.width_m / 2, self.depth_m / 2),
        )


class CameraSettings(_Section):
    """One camera: a name and a source URI.

    Source URIs: an integer device index (``"0"``), an RTSP/HTTP URL, a video file
    path, an image folder path, or ``sim`` (a virtual camera of the simulator).
    """

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")]
    source: str = "sim"


def _default_cameras() -> list[CameraSettings]:
    return [CameraSettings(name=f"cam0{i}", source="sim") for i in range(1, 5)]


class ServerSettings(_Section):
    host: str = "127.0.0.1"
    port: int = Field(8000, ge=1, le=65535)
    viser_port: int = Field(8080, ge=1, le=65535)
    token: str | None = None
    cors_origins: list[str] = Field(default_factory=list)
    max_request_bytes: int = Field(1_000_000, gt=0)
    live_rate_hz: float = Field(10.0, gt=0, le=60)  # WebSocket status messages per second
    event_flush_s: float = Field(0.5, gt=0, le=1.0)  # event log batch interval (loss bound on a crash)
    viser: bool = True  # serve the 3D view
    # the address a participant's tablet opens (the participant link and its QR code); None = this
    # server's own address on the network (or loopback when it listens on loopback only)
    public_url: str | None = Field(None, pattern=r"^https?://[^\s/?#]+$")


class PathSettings(_Section):
    db: Path = USER_DATA_DIR / "cavewalk.db"  # the user's data directory, unless told otherwise
    models_dir: Path = USER_CACHE_DIR / "models"
    cache_dir: Path = USER_CACHE_DIR
    calibration: Path | None = None


class PoseSettings(_Section):
    model: Path | None = None  # default: the prepared model in paths.models_dir (see `precision`)
    # long side of the network input, px (multiple of 32); the short side follows the
    # images' aspect, so 1088x1920 portrait views run at 384x640, not padded to a square
    input_long_side: int = Field(640, ge=32, multiple_of=32)
    roi: bool = True  # ROI mode: run tracked views on crops around their tracks
    roi_long_side: int = Field(320, ge=32, multiple_of=32)  # network long side of the crops
    roi_margin: float = Field(0.15, ge=0, le=2)  # crop margin, fraction of the tracks' box size
    roi_full_every: int = Field(30, ge=1)  # each view looked at whole (for newcomers) this often, frames
    score_threshold: float = Field(0.35, ge=0, le=1)
    nms_iou: float = Field(0.6, ge=0, le=1)
    keypoint_threshold: float = Field(0.3, ge=0, le=1)
    providers: list[Literal["cpu", "cuda"]] = Field(default_factory=lambda: ["cpu"])  # type: ignore[arg-type]
    threads: int = Field(0, ge=0)  # onnxruntime threads per model call (0 = its choice; 1 if parallel > 1)
    # model calls of a frame run side by side on this many threads (0 = one per CPU core)
    parallel: int = Field(0, ge=0)
    # ROI crops run on the crop model beside the model file (made by `cavewalk models prepare`:
    # the head without its stride-8 level, a third faster in int8; see pipeline.pose.model_files)
    crop_model: bool = True
    # which prepared model file: the float32 one or the int8 copy `cavewalk models prepare`
    # makes beside it; ignored when `model` names a file
    precision: Literal["fp32", "int8"] = "int8"  # int8: 6-14 % faster, same tracks (bench_detect)


class RecognitionSettings(_Section):
    model: Path | None = None  # default: the committed pipeline/recognition/action.onnx
    # defaults tuned by scripts/eval_action.py --tune (see pipeline/recognition/MODEL_CARD.md)
    ema_alpha: float = Field(0.5, gt=0, le=1)  # weight of a new model output, per model frame
    min_dwell_s: float = Field(0.0, ge=0)  # a new class must lead this long before the command changes
    stop_dwell_s: float = Field(0.0, ge=0)  # ... before a change to still (stopping late feels worse)
    switch_prob: float = Field(0.6, ge=0, le=1)  # ... with at least this smoothed probability
    yaw_alpha: float = Field(0.3, gt=0, le=1)  # facing-direction smoothing, per model frame
    max_gap_s: float = Field(0.5, gt=0)  # a longer gap between skeletons resets the recogniser
    speed_alpha: float = Field(0.15, gt=0, le=1)  # speed smoothing, per model frame
    forward_step_m: float = Field(0.4, gt=0)  # virtual distance per forward step (speed = cadence x this)
    side_step_m: float = Field(0.3, gt=0)  # ... per side step
    threads: int = Field(1, ge=0)  # onnxruntime intra-op threads (0 = its choice)
    # the stepping-bout gate on the step evidence (no movement without a step; one command per
    # bout); off = the network's EMA + hysteresis alone (pipeline/recognition/MODEL_CARD.md)
    gate: bool = False

    def to_config(self) -> Any:
        """The recogniser's frozen :class:`pipeline.recognition.recognizer.RecognizerConfig`."""
        from pipeline.recognition.recognizer import RecognizerConfig

        return RecognizerConfig.from_settings(self)


class RuntimeSettings(_Section):
    """The live pipeline (see pipeline.runtime.config.RuntimeConfig)."""

    target_fps: float = Field(30.0, gt=0)
    emit_rate_hz: float = Field(60.0, gt=0)
    heartbeat_s: float = Field(1.0, gt=0)
    video_pace_fps: float | None = Field(None, ge=0)  # None = the videos' own rate, 0 = flat out
    video_loop: bool = True
    group_tolerance_s: float = Field(0.02, ge=0)  # frames this close in time form one multi-view frame
    group_max_wait_s: float = Field(0.015, ge=0)  # how long to wait for a late camera
    camera_gone_s: float = Field(1.0, gt=0)  # a camera silent this long is reported and not waited for
    camera_retry_s: float = Field(1.0, gt=0)
    capture_nice: int = Field(5, ge=0, le=19)  # capture workers' niceness: decoding gives way to detection
    osc: list[str] = Field(default_factory=list)  # HOST:PORT destinations of /cave/locomotion (OSC)

    @field_validator("osc")
    @classmethod
    def _osc_host_port(cls, v: list[str]) -> list[str]:
        for item in v:
            parse_endpoint(item)
        return v


class TrackingSettings(_Section):
    """OC-SORT per camera view (pipeline.tracking.ocsort.OCSortConfig)."""

    det_thresh: float = Field(0.3, ge=0, le=1)  # detections below neither match nor start tracks
    max_age: int = Field(30, ge=1)  # frames a track survives unseen
    min_hits: int = Field(3, ge=0)  # consecutive matches before a track is reported
    iou_threshold: float = Field(0.3, ge=0, le=1)
    delta_t: int = Field(3, ge=1)  # frames between the observations that give a direction (OCM)
    inertia: float = Field(0.2, ge=0)  # weight of the direction-consistency cost (OCM)
    history: int = Field(30, ge=1)  # recent observations (box + keypoints) kept per track


class SimSettings(_Section):
    """The simulator (``cavewalk demo``, ``cavewalk simulate``): scene, people and camera faults."""

    camera_preset: Literal["kinect_color", "depth"] = "kinect_color"
    fps: float = Field(30.0, gt=0, le=240)
    bystanders: int = Field(1, ge=0, le=8)
    seed: int = 0
    script: Path | None = None  # the navigator's routine (JSON/TOML); None = random routines
    navigator_height_m: float | None = Field(None, ge=1.0, le=2.3)  # None = random 1.50-1.95 m
    pixel_noise_px: float = Field(2.5, ge=0)  # keypoint noise sigma for a person 600 px tall
    person_miss_rate: float = Field(0.02, ge=0, le=1)
    false_detection_rate: float = Field(0.01, ge=0)  # ghost detections per view and frame
    timestamp_jitter_s: float = Field(0.002, ge=0)

    def to_config(self, **overrides: Any) -> Any:
        """The simulator's own frozen config (``pipeline.sim.world.SimConfig``)."""
        from pipeline.sim.views import FaultConfig
        from pipeline.sim.world import SimConfig

        faults = FaultConfig(
            pixel_noise_px=self.pixel_noise_px,
            person_miss_rate=self.person_miss_rate,
            false_detection_rate=self.false_detection_rate,
            timestamp_jitter_s=self.timestamp_jitter_s,
        )
        fields: dict[str, Any] = {
            "fps": self.fps, "bystanders": self.bystanders, "seed": self.seed,
            "camera_preset": self.camera_preset, "navigator_height_m": self.navigator_height_m,
            "faults": faults,
        }
        fields.update(overrides)
        return SimConfig(**fields)


class StudySettings(_Section):
    """The user study's design and analysis (see app.study)."""

    min_gap_days: float = Field(2.0, ge=0)  # minimum time between a participant's two sessions
    alpha: float = Field(0.05, gt=0, lt=1)  # significance level (Shapiro-Wilk decision, stars)
    correction: Literal["holm", "bonferroni", "none"] = "holm"  # multiple comparisons over the measures


class CalibrationSettings(_Section):
    """Wall marker patterns and the PnP calibration (see pipeline.calibration.config)."""

    dictionary: str = "DICT_4X4_250"
    grid: tuple[int, int] = (6, 5)  # (columns, rows) of ArUco markers on every wall
    margin_frac: float = Field(0.04, ge=0, lt=0.45)
    quiet_frac: float = Field(0.3, ge=0.15, lt=0.9)
    nominal_hfov_deg: float = Field(70.0, ge=10, le=170)  # focal-length prior when focal_prior_px is unset
    focal_prior_px: float | None = Field(None, gt=0)
    min_markers: int = Field(6, ge=2)
    min_walls: int = Field(2, ge=1)
    ransac_px: float = Field(4.0, gt=0)
    estimate_k3: bool = True  # third radial coefficient when >= 3 x min_markers markers are seen
    corner_refinement: Literal["subpix", "edges"] = "subpix"  # edges: corners from fitted marker edges
    good_rms_px: float = Field(0.5, gt=0)
    fair_rms_px: float = Field(1.5, gt=0)

    def to_config(self) -> Any:
        """The stage's frozen CalibrationConfig."""
        from pipeline.calibration.config import CalibrationConfig

        return CalibrationConfig(**self.model_dump())


class TriangulationSettings(_Section):
    """Cross-view association, robust triangulation, 3D tracks (see pipeline.triangulation.config)."""

    min_score: float = Field(0.3, ge=0, le=1)  # 2D keypoints scored lower are ignored
    outlier_ratio: float = Field(3.0, gt=1)  # a view this many times worse than the others is dropped
    outlier_min_px: float = Field(12.0, ge=0)  # ... if also above this error
    outlier_min_frac: float = Field(0.15, ge=0, le=1)  # ... and above this fraction of the person's size
    max_reproj_px: float = Field(40.0, gt=0)  # a joint with a larger mean error is unknown
    refine_iterations: int = Field(1, ge=0, le=20)  # Gauss-Newton steps after the DLT
    max_epipolar_px: float = Field(40.0, gt=0)  # association: same person below this distance
    min_common_joints: int = Field(4, ge=1, le=17)
    memory_factor: float = Field(0.5, gt=0, le=1)  # pull towards last frames' association
    memory_s: float = Field(5.0, ge=0)  # (camera, track) -> user links forgotten after this
    max_missing_s: float = Field(2.0, ge=0)  # a user unseen this long loses the id
    max_match_distance_m: float = Field(0.7, gt=0)
    smoothing: Literal["none", "one_euro"] = "one_euro"
    one_euro_min_cutoff_hz: float = Field(4.0, gt=0)  # tuned on the simulator: -33 % jitter, +0.2 mm MPJPE
    one_euro_beta: float = Field(30.0, ge=0)  # per m/s: little lag while stepping
    one_euro_d_cutoff_hz: float = Field(1.0, gt=0)
    bone_prior_s: float = Field(2.0, ge=0)  # bone lengths learned over a user's first seconds
    bone_tolerance: float = Field(0.35, gt=0)  # then a limb this far off (fraction) is an outlier
    min_valid_joints: int = Field(5, ge=1, le=17)

    def to_config(self) -> Any:
        """The stage's frozen ReconstructionConfig."""
        from pipeline.triangulation.config import ReconstructionConfig

        return ReconstructionConfig.from_flat(self.model_dump())


class NavigatorSettings(_Section):
    """Choice of the primary navigator (see pipeline.triangulation.navigator)."""

    mode: Literal["auto", "manual"] = "auto"
    dwell_s: float = Field(0.5, ge=0)  # auto: tracked this long before being chosen
    hold_s: float = Field(1.5, ge=0)  # the choice survives an occlusion this long
    max_radius_m: float = Field(1.5, gt=0)  # auto: only people this near the centre
    switch_margin_m: float = Field(0.5, ge=0)  # auto: a challenger must be this much nearer
    manual_grace_s: float = Field(3.0, ge=0)  # manual: a lost choice falls back to auto after this
    reacquire_radius_m: float = Field(0.6, ge=0)  # manual: a new id this near where it vanished = same person

    def to_config(self) -> Any:
        """The selector's frozen NavigatorConfig."""
        from pipeline.triangulation.config import NavigatorConfig

        return NavigatorConfig(**self.model_dump())


class PlannerSettings(_Section):
    """The camera-coverage planner (``cavewalk plan``, ``POST /api/v1/plan``; see pipeline.planner.config).

    The 2D noise it draws from is the simulator's (``sim``) and the triangulation the pipeline's
    (``triangulation``)."""

    grid_step_m: float = Field(0.15, ge=0.02, le=2)  # floor cell side of the maps
    samples: int = Field(4, ge=1, le=256)  # Monte Carlo draws per cell, height and facing
    heights_m: list[float] = Field(default_factory=lambda: [1.6, 1.85])  # standing people tried
    facings_deg: list[float] = Field(default_factory=lambda: [0.0, 90.0, 180.0, 270.0])
    seed: int = 0
    region_band_m: float = Field(0.5, ge=0.05, le=2)  # edge / corner regions: this close to the walls
    wall_clearance_m: float = Field(0.2, ge=0, le=1)  # nobody stands closer to a wall
    above_walls_m: float = Field(0.5, ge=0, le=3)  # a camera may hang this far above the walls' top
    mount_heights_m: list[float] = Field(default_factory=lambda: [2.0, 2.3, 2.45])  # mount search
    pans_deg: list[float] = Field(default_factory=lambda: [-25.0, 0.0, 25.0])
    aim_heights_m: list[float] = Field(default_factory=lambda: [0.4, 1.0])
    top_k: int = Field(3, ge=1, le=10)  # best layouts mapped and shown

    def to_config(self, sim: SimSettings, triangulation: TriangulationSettings, **overrides: Any) -> Any:
        """The planner's frozen PlannerConfig, with the simulator's faults and the triangulation's params."""
        from pipeline.planner.config import PlannerConfig

        fields: dict[str, Any] = {
            "grid_step_m": self.grid_step_m, "samples": self.samples, "heights_m": tuple(self.heights_m),
            "facings_deg": tuple(self.facings_deg), "seed": self.seed, "region_band_m": self.region_band_m,
            "wall_clearance_m": self.wall_clearance_m, "above_walls_m": self.above_walls_m,
            "faults": sim.to_config().faults, "triangulation": triangulation.to_config().triangulation,
        }
        fields.update({k: v for k, v in overrides.items() if v is not None})
        return PlannerConfig(**fields)

    def search_config(self, count: int, preset: str, **overrides: Any) -> Any:
        """The mount search's frozen SearchConfig for ``count`` cameras of the ``preset`` model."""
        from pipeline.planner.config import SearchConfig

        fields: dict[str, Any] = {
            "count": count, "preset": preset, "heights_m": tuple(self.mount_heights_m),
            "pans_deg": tuple(self.pans_deg), "aim_heights_m": tuple(self.aim_heights_m), "top_k": self.top_k,
        }
        fields.update({k: v for k, v in overrides.items() if v is not None})
        return SearchConfig(**fields)


class Settings(BaseSettings):
    """Everything configurable in cavewalk."""

    model_config = SettingsConfigDict(
        env_prefix="CAVEWALK_",
        env_nested_delimiter="__",
        extra="forbid",
        frozen=True,
    )

    cave: CaveSettings = CaveSettings()
    cameras: list[CameraSettings] = Field(default_factory=_default_cameras)
    workstations: list[str] = Field(default_factory=list)
    server: ServerSettings = ServerSettings()
    paths: PathSettings = PathSettings()
    pose: PoseSettings = PoseSettings()
    tracking: TrackingSettings = TrackingSettings()
    recognition: RecognitionSettings = RecognitionSettings()
    runtime: RuntimeSettings = RuntimeSettings()
    sim: SimSettings = SimSettings()
    study: StudySettings = StudySettings()
    calibration: CalibrationSettings = CalibrationSettings()
    triangulation: TriangulationSettings = TriangulationSettings()
    navigator: NavigatorSettings = NavigatorSettings()
    planner: PlannerSettings = PlannerSettings()

    @field_validator("cameras")
    @classmethod
    def _unique_cameras(cls, v: list[CameraSettings]) -> list[CameraSettings]:
        names = [c.name for c in v]
        if len(set(names)) != len(names):
            raise ValueError(f"camera names must be unique, got {names}")
        return v

    @field_validator("workstations")
    @classmethod
    def _host_port(cls, v: list[str]) -> list[str]:
        for item in v:
            parse_endpoint(item)
        return v

    @classmethod
    def settings_customise_sources(
        cls,
        settings_cls: type[BaseSettings],
        init_settings: PydanticBaseSettingsSource,
        env_settings: PydanticBaseSettingsSource,
        dotenv_settings: PydanticBaseSettingsSource,
        file_secret_settings: PydanticBaseSettingsSource,
    ) -> tuple[PydanticBaseSettingsSource, ...]:
        toml_path = _TOML_FILE.get() or _ConfigPath().config or DEFAULT_CONFIG_FILE
        sources: list[PydanticBaseSettingsSource] = [init_settings, env_settings]
        if toml_path.is_file():
            sources.append(TomlConfigSettingsSource(settings_cls, toml_file=toml_path))
        return tuple(sources)

    @property
    def pose_model_path(self) -> Path:
        """The pose model file: ``pose.model``, else the prepared model of ``pose.precision``."""
        if self.pose.model is not None:
            return self.pose.model
        return pose_model_file(self.paths.models_dir, self.pose.precision)


class _ConfigPath(BaseSettings):
    """Reads only CAVEWALK_CONFIG (the TOML file's path)."""

    model_config = SettingsConfigDict(env_prefix="CAVEWALK_", extra="ignore")
    config: Path | None = None


def parse_endpoint(value: str) -> tuple[str, int]:
    """``"host:port"`` -> (host, port); raises ValueError with the reason."""
    host, sep, port = value.rpartition(":")
    if not sep or not host:
        raise ValueError(f"workstation {value!r} must be HOST:PORT")
    try:
        port_i = int(port)
    except ValueError:
        raise ValueError(f"workstation {value!r}: port {port!r} is not a number") from None
    if not 1 <= port_i <= 65535:
        raise ValueError(f"workstation {value!r}: port must be 1-65535")
    return host.strip("[]"), port_i


def format_validation_error(exc: ValidationError, source: str) -> str:
    """One readable line per bad key, naming the key path."""
    lines = [f"invalid settings ({source}):"]
    for err in exc.errors():
        key = ".".join(str(p) for p in err["loc"]) or "(root)"
        lines.append(f"  {key}: {err['msg']}")
    return "\n".join(lines)


def load_settings(config_path: Path | None = None, **overrides: Any) -> Settings:
    """Build the settings from an explicit TOML file (or the default sources).

    Raises :class:`ConfigError` with a message naming every bad key.
    """
    source = str(config_path) if config_path else "environment / cavewalk.toml"
    if config_path is not None and not Path(config_path).is_file():
        raise ConfigError(f"config file not found: {config_path}")
    try:
        if config_path is None:
            return Settings(**overrides)

        token = _TOML_FILE.set(Path(config_path))
        try:
            return Settings(**overrides)
        finally:
            _TOML_FILE.reset(token)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source)) from exc
    except ValueError as exc:  # TOML syntax errors
        raise ConfigError(f"cannot read settings from {source}: {exc}") from exc


_override: Settings | None = None


@lru_cache(maxsize=1)
def _cached() -> Settings:
    return load_settings()


def get_settings() -> Settings:
    """The process-wide settings (built on first use, not at import)."""
    return _override if _override is not None else _cached()


def set_settings(settings: Settings | None) -> None:
    """Install settings for this process (the CLI after parsing --config; tests)."""
    global _override
    _override = settings
    _cached.cache_clear()
