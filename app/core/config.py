"""The one settings object of cavewalk (pydantic-settings).

Sources, highest priority first: keyword arguments, ``CAVEWALK_*`` environment
variables (nested with ``__``, e.g. ``CAVEWALK_SERVER__PORT=9000``), the TOML file
(``cavewalk.toml`` in the working directory, or the path given by ``--config`` /
``CAVEWALK_CONFIG``), the ``[pose]`` keys ``cavewalk tune`` chose for this machine (its file
``tuned.toml`` in the user's config directory, or ``CAVEWALK_TUNE_FILE``; ignored when it was
tuned on another machine), then the defaults below. Unknown keys are errors, so a typo
in the file is reported by name instead of silently ignored.

Each pipeline stage owns one frozen config dataclass (``pipeline.<stage>``), and the
settings embed it as its section: a setting is declared once, in the stage, with its
default and its check (``__post_init__``); pydantic validates the sections once, here, and
the stage receives its section as it is. Keys that moved keep working for a while: they are
mapped to their new place with a warning naming the new key (:data:`MOVED_KEYS`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import os
import tomllib
import types
import typing
import warnings
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from pydantic_settings import (
    BaseSettings,
    PydanticBaseSettingsSource,
    SettingsConfigDict,
    TomlConfigSettingsSource,
)

from app.services.event_log_config import EventWriterConfig
from app.study.config import StudyConfig
from pipeline.calibration.config import CalibrationConfig
from pipeline.cave import CaveGeometry, Wall, box_cave
from pipeline.emitter.config import EmitterConfig, parse_endpoint
from pipeline.errors import ConfigError
from pipeline.head.config import HeadConfig
from pipeline.identity.config import IdentityConfig
from pipeline.machine import machine_fingerprint
from pipeline.navigation.config import NavigationConfig
from pipeline.planner.config import PlannerConfig
from pipeline.pose.config import FINGERPRINT_KEYS, TUNED_KEYS, PoseConfig, TuneConfig
from pipeline.recognition.recognizer import RecognizerConfig
from pipeline.runtime.config import RuntimeConfig
from pipeline.sim.config import SimConfig
from pipeline.takes.config import TakesConfig
from pipeline.tracking.config import OCSortConfig
from pipeline.triangulation.config import (
    AssociationParams,
    NavigatorConfig,
    Tracks3DParams,
    TriangulationParams,
)

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
#: What ``cavewalk tune`` chose for this machine, unless CAVEWALK_TUNE_FILE names another file.
TUNED_FILE = _user_dir("XDG_CONFIG_HOME", _HOME / ".config") / "tuned.toml"
log = logging.getLogger(__name__)


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
    # Host names the server answers to besides loopback and the bound address ("*" = any; see
    # app/api/origin.py): e.g. the DNS name of the server machine, or a reverse proxy's name
    allowed_hosts: list[str] = Field(default_factory=list)
    max_request_bytes: int = Field(1_000_000, gt=0)
    max_model_bytes: int = Field(16_000_000, gt=0)  # POST /api/v1/models: an action model, base64
    live_rate_hz: float = Field(10.0, gt=0, le=60)  # WebSocket status messages per second
    viser: bool = True  # serve the 3D view
    # the address a participant's tablet opens (the participant link and its QR code); None = this
    # server's own address on the network (or loopback when it listens on loopback only)
    public_url: str | None = Field(None, pattern=r"^https?://[^\s/?#]+$")


class PathSettings(_Section):
    db: Path = USER_DATA_DIR / "cavewalk.db"  # the user's data directory, unless told otherwise
    models_dir: Path = USER_CACHE_DIR / "models"
    cache_dir: Path = USER_CACHE_DIR
    calibration: Path | None = None


class BackupSettings(_Section):
    """Backups of the database while the server runs (``cavewalk db backup`` makes one by hand): at
    start when the data changed since the newest backup (always before a migration), when a study
    session ends, every ``interval_min`` while the data changes, and at stop; the newest ``keep``
    are kept."""

    enabled: bool = True
    folder: Path | None = None  # default: backups/ beside the database
    keep: int = Field(20, ge=1)
    interval_min: float = Field(15.0, ge=0)  # 0: no timed backups (the others still)


class StorageSettings(_Section):
    """Free disk space where the server writes (the database, its backups, the takes): below
    ``warn_free_gb`` the dashboard warns; below ``min_free_gb`` a take being recorded stops and new
    takes and backups are refused (see ``app/services/storage.py``); checked every ``check_s``."""

    warn_free_gb: float = Field(10.0, ge=0)
    min_free_gb: float = Field(2.0, ge=0)
    check_s: float = Field(5.0, gt=0)

    @model_validator(mode="after")
    def _ordered(self) -> StorageSettings:
        if self.warn_free_gb < self.min_free_gb:
            raise ValueError(
                f"warn_free_gb ({self.warn_free_gb}) must be at least min_free_gb ({self.min_free_gb})"
            )
        return self


#: Keys that moved when each stage came to own its config: old dotted key -> new dotted key.
#: A settings file or ``CAVEWALK_*`` variable with an old key still works (with a warning
#: naming the new one); giving both is an error.
MOVED_KEYS: dict[str, str] = {
    "server.event_flush_s": "event_log.flush_interval_s",
    "runtime.group_tolerance_s": "runtime.grouper.tolerance_s",
    "runtime.group_max_wait_s": "runtime.grouper.max_wait_s",
    "runtime.camera_gone_s": "runtime.grouper.gone_after_s",
    "runtime.emit_rate_hz": "emitter.rate_hz",
    "runtime.heartbeat_s": "emitter.heartbeat_s",
    "runtime.osc": "emitter.osc",
    "recognition.model": "recognition.model_path",
    "recognition.forward_step_m": "recognition.speed.forward_step_m",
    "recognition.side_step_m": "recognition.speed.side_step_m",
    **{f"sim.{k}": f"sim.faults.{k}" for k in
       ("pixel_noise_px", "person_miss_rate", "false_detection_rate", "timestamp_jitter_s")},
    **{f"triangulation.{k}": f"association.{k}" for k in
       ("max_epipolar_px", "min_common_joints", "memory_factor", "memory_s")},
    **{f"triangulation.{k}": f"tracks3d.{k}" for k in
       ("max_missing_s", "max_match_distance_m", "smoothing", "one_euro_min_cutoff_hz", "one_euro_beta",
        "one_euro_d_cutoff_hz", "bone_prior_s", "bone_tolerance", "min_valid_joints")},
    "study.min_gap_days": "study.design.min_gap_days",
    "study.alpha": "study.analysis.alpha",
    "study.correction": "study.analysis.correction",
    "planner.mount_heights_m": "planner.search.heights_m",
    "planner.pans_deg": "planner.search.pans_deg",
    "planner.aim_heights_m": "planner.search.aim_heights_m",
    "planner.top_k": "planner.search.top_k",
}
# new key -> the old key the user wrote, for the error messages of the current validation
_MOVED_NOW: ContextVar[dict[str, str] | None] = ContextVar("cavewalk_moved_keys", default=None)


class Settings(BaseSettings):
    """Everything configurable in cavewalk: the app's own sections, then each stage's config."""

    model_config = SettingsConfigDict(
        env_prefix="CAVEWALK_",
        env_nested_delimiter="__",
        extra="forbid",
        frozen=True,
    )

    cave: CaveSettings = CaveSettings()
    cameras: list[CameraSettings] = Field(default_factory=_default_cameras)
    workstations: list[str] = Field(default_factory=list)  # HOST:PORT of the UDP receivers
    server: ServerSettings = ServerSettings()
    paths: PathSettings = PathSettings()
    backup: BackupSettings = BackupSettings()
    storage: StorageSettings = StorageSettings()
    event_log: EventWriterConfig = EventWriterConfig()
    study: StudyConfig = StudyConfig()
    pose: PoseConfig = PoseConfig()
    tune: TuneConfig = TuneConfig()
    tracking: OCSortConfig = OCSortConfig()
    triangulation: TriangulationParams = TriangulationParams()
    association: AssociationParams = AssociationParams()
    tracks3d: Tracks3DParams = Tracks3DParams()
    identity: IdentityConfig = IdentityConfig()
    navigator: NavigatorConfig = NavigatorConfig()
    navigation: NavigationConfig = NavigationConfig()
    recognition: RecognizerConfig = RecognizerConfig()
    head: HeadConfig = HeadConfig()
    runtime: RuntimeConfig = RuntimeConfig()
    emitter: EmitterConfig = EmitterConfig()
    sim: SimConfig = SimConfig()
    calibration: CalibrationConfig = CalibrationConfig()
    planner: PlannerConfig = PlannerConfig()
    takes: TakesConfig = TakesConfig()

    @model_validator(mode="before")
    @classmethod
    def _moved_keys(cls, data: Any) -> Any:
        """Old keys (:data:`MOVED_KEYS`) to their new place, with a warning that names it."""
        if not isinstance(data, dict):
            return data
        moved: dict[str, str] = {}
        data = _copy_tree(data)
        _decode_json_strings(data, cls)
        for old, new in MOVED_KEYS.items():
            found, value = _pop_path(data, old)
            if not found:
                continue
            if _has_path(data, new):
                raise ValueError(f"{old} and {new} are the same setting (it moved to {new}): give only {new}")
            _set_path(data, new, value)
            moved[new] = old
            warnings.warn(f"settings key {old} is deprecated: it is now {new}", FutureWarning, stacklevel=2)
        if moved:
            known = _MOVED_NOW.get()
            if known is not None:
                known.update(moved)
        planner = data.get("planner")
        for key, where in (("faults", "sim.faults"), ("triangulation", "triangulation")):
            if isinstance(planner, dict) and key in planner:
                raise ValueError(f"planner.{key} is not a setting of its own: the planner uses [{where}]")
        return data

    @model_validator(mode="after")
    def _planner_noise(self) -> Settings:
        """The planner draws from the simulator's noise and triangulates as the pipeline does."""
        planner = dataclasses.replace(self.planner, faults=self.sim.faults, triangulation=self.triangulation)
        object.__setattr__(self, "planner", planner)  # frozen: set once, while validating
        return self

    def dump(self) -> dict[str, Any]:
        """The settings as plain JSON values, each key once (``cavewalk config show``)."""
        data = self.model_dump(mode="json", exclude_none=True)
        for key in ("faults", "triangulation"):  # the simulator's and the pipeline's own, shown there
            data["planner"].pop(key, None)
        return data

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
        toml_path = _toml_path()
        sources: list[PydanticBaseSettingsSource] = [init_settings, env_settings]
        if toml_path.is_file():
            sources.append(TomlConfigSettingsSource(settings_cls, toml_file=toml_path))
        sources.append(TunedSettingsSource(settings_cls))
        return tuple(sources)

    @property
    def pose_model_path(self) -> Path:
        """The pose model file: ``pose.model``, else the prepared model of ``pose.precision``."""
        return self.pose.model_file(self.paths.models_dir)

    @property
    def endpoints(self) -> list[tuple[str, int]]:
        """The workstations as (host, port)."""
        return [parse_endpoint(w) for w in self.workstations]


class _ConfigPath(BaseSettings):
    """Reads only CAVEWALK_CONFIG (the TOML file's path) and CAVEWALK_TUNE_FILE (the tuned file's)."""

    model_config = SettingsConfigDict(env_prefix="CAVEWALK_", extra="ignore")
    config: Path | None = None
    tune_file: Path | None = None


def tuned_file() -> Path:
    """Where ``cavewalk tune`` writes its choice and the settings read it: CAVEWALK_TUNE_FILE, else
    :data:`TUNED_FILE`."""
    return _ConfigPath().tune_file or TUNED_FILE


def read_tuned(path: Path) -> tuple[dict[str, Any], str | None]:
    """(the ``[pose]`` keys of the tuned file ``path``, None) when it applies to this machine, else
    ({}, why not). Only :data:`pipeline.pose.tune.TUNED_KEYS` are taken."""
    if not path.is_file():
        return {}, f"{path} does not exist"
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, ValueError) as exc:
        return {}, f"{path} cannot be read ({exc}); run  cavewalk tune  again"
    tune = data.get("tune")
    tune = tune if isinstance(tune, dict) else {}
    recorded = tune.get("fingerprint")
    recorded = recorded if isinstance(recorded, dict) else {}
    here = machine_fingerprint()
    differ = [k for k in FINGERPRINT_KEYS if recorded.get(k) != here.get(k)]
    if differ:
        return {}, (f"{path} was tuned on another machine or onnxruntime ("
                    + ", ".join(f"{k} {recorded.get(k)!r} there, {here.get(k)!r} here" for k in differ)
                    + "); run  cavewalk tune  here")
    pose = data.get("pose")
    pose = pose if isinstance(pose, dict) else {}
    return {k: v for k, v in pose.items() if k in TUNED_KEYS}, None


class TunedSettingsSource(PydanticBaseSettingsSource):
    """The ``[pose]`` keys ``cavewalk tune`` chose for this machine (:func:`read_tuned`), below every
    other source: a key in cavewalk.toml or a CAVEWALK_* variable wins."""

    _warned: typing.ClassVar[set[str]] = set()

    def get_field_value(self, field: Any, field_name: str) -> tuple[Any, str, bool]:  # pragma: no cover
        return None, field_name, False

    def __call__(self) -> dict[str, Any]:
        path = tuned_file()
        pose, why = read_tuned(path)
        if why is not None and path.is_file() and why not in self._warned:
            self._warned.add(why)
            log.warning("tuned settings not used: %s", why)
        return {"pose": pose} if pose else {}


def _toml_path() -> Path:
    """The settings TOML file: the one given to load_settings, else CAVEWALK_CONFIG, else ./cavewalk.toml."""
    return _TOML_FILE.get() or _ConfigPath().config or DEFAULT_CONFIG_FILE


def _decode_json_strings(data: dict[str, Any], node: Any) -> None:
    """Inside the stages' sections, a ``CAVEWALK_*`` variable's JSON text for a list, tuple or table
    becomes that value (pydantic-settings decodes it for pydantic models only, not dataclasses)."""
    if isinstance(node, type) and issubclass(node, BaseModel):
        hints: dict[str, Any] = {k: f.annotation for k, f in node.model_fields.items()}
    elif dataclasses.is_dataclass(node):
        hints = typing.get_type_hints(node)
    else:
        return
    for key, value in data.items():
        target = hints.get(key)
        args = [a for a in typing.get_args(target) if a is not type(None)]
        optional = typing.get_origin(target) in (typing.Union, types.UnionType) and len(args) == 1
        inner = args[0] if optional else target
        if isinstance(value, dict):
            _decode_json_strings(value, inner)
        elif isinstance(value, str) and dataclasses.is_dataclass(node) and (
            typing.get_origin(inner) in (list, tuple, dict, set, frozenset) or dataclasses.is_dataclass(inner)
        ):
            with contextlib.suppress(ValueError):  # else left to the validation, which names the key
                data[key] = json.loads(value)


def _copy_tree(data: dict[str, Any]) -> dict[str, Any]:
    return {k: _copy_tree(v) if isinstance(v, dict) else v for k, v in data.items()}


def _pop_path(data: dict[str, Any], dotted: str) -> tuple[bool, Any]:
    *parents, leaf = dotted.split(".")
    node: Any = data
    for key in parents:
        node = node.get(key) if isinstance(node, dict) else None
    if not isinstance(node, dict) or leaf not in node:
        return False, None
    return True, node.pop(leaf)


def _has_path(data: dict[str, Any], dotted: str) -> bool:
    node: Any = data
    for key in dotted.split("."):
        if not isinstance(node, dict) or key not in node:
            return False
        node = node[key]
    return True


def _set_path(data: dict[str, Any], dotted: str, value: Any) -> None:
    *parents, leaf = dotted.split(".")
    node = data
    for key in parents:
        child = node.get(key)
        if not isinstance(child, dict):  # a section given as an object is left to the validation
            child = node[key] = {} if child is None else child
            if not isinstance(child, dict):
                return
        node = child
    node[leaf] = value


def _error_key(err: Any, moved: dict[str, str]) -> str:
    """The dotted key of one validation error, as the user wrote it.

    A stage's own check (``__post_init__``) fails for its whole section; its message starts
    with the field's name, which completes the key. A key that moved is shown as written.
    """
    loc = [str(p) for p in err["loc"]]
    msg = str(err["msg"]).removeprefix("Value error, ")
    first = msg.split(" ", 1)[0].rstrip(":,")
    if err["type"] == "value_error" and first in _section_fields(loc):
        loc.append(first)
    key = ".".join(loc) or "(root)"
    for new, old in moved.items():
        if key == new or key.startswith(new + "."):
            return f"{old} (now {key})"
    return key


def _section_fields(loc: list[str]) -> set[str]:
    """Field names of the dataclass section at ``loc`` (empty when it is not one)."""
    node: Any = Settings
    for part in loc:
        if isinstance(node, type) and issubclass(node, BaseModel):
            info = node.model_fields.get(part)
            node = info.annotation if info is not None else None
        elif dataclasses.is_dataclass(node):
            node = typing.get_type_hints(node).get(part)
        else:
            return set()
    return {f.name for f in dataclasses.fields(node)} if dataclasses.is_dataclass(node) else set()


def format_validation_error(exc: ValidationError, source: str) -> str:
    """One readable line per bad key, naming the key path."""
    moved = _MOVED_NOW.get() or {}
    lines = [f"invalid settings ({source}):"]
    for err in exc.errors():
        key = _error_key(err, moved)
        msg = str(err["msg"]).removeprefix("Value error, ")
        leaf = key.split(" ")[-1].rstrip(")").split(".")[-1]
        if msg.startswith(leaf + ":"):  # the stage's check named the field; the key says it already
            msg = msg[len(leaf) + 1:].lstrip()
        elif msg.startswith(leaf + " "):
            msg = msg[len(leaf) + 1:]
        lines.append(f"  {key}: {msg}")
    return "\n".join(lines)


def load_settings(config_path: Path | None = None, **overrides: Any) -> Settings:
    """Build the settings from an explicit TOML file (or the default sources).

    Raises :class:`ConfigError` with a message naming every bad key.
    """
    global _last_config_path
    _last_config_path = config_path
    source = str(config_path) if config_path else "environment / cavewalk.toml"
    toml = Path(config_path) if config_path is not None else _toml_path()
    if toml.exists() and not toml.is_file():  # a folder named cavewalk.toml was silently ignored
        raise ConfigError(f"config {toml} is a folder, not a TOML settings file")
    if config_path is not None and not toml.is_file():
        raise ConfigError(f"config file not found: {config_path}")
    moved_token = _MOVED_NOW.set({})
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
    finally:
        _MOVED_NOW.reset(moved_token)


_override: Settings | None = None
_last_config_path: Path | None = None


def reload_settings() -> Settings:
    """The settings read again from their sources, with the TOML file last given to
    :func:`load_settings` (after ``cavewalk tune`` wrote its file)."""
    return load_settings(_last_config_path)


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
