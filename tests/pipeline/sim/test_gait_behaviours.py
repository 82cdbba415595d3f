"""Every behaviour of the gait model on its own: physics (planted feet stay put, soles on the
floor, nothing below it) and labels that match the contacts; and the in-place preset that has
what the independent stepping set has (marching, side steps out-and-back and step-touch,
gestures and turns while standing, bodies 1.48-1.98 m, 1.2 cm noise, 2 % dropped joints)."""

from __future__ import annotations

import json
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from pipeline.sim.gait import (
    BEHAVIOURS,
    IN_PLACE_MIX,
    IN_PLACE_SIDE_KINDS,
    BodyConfig,
    GaitConfig,
    GaitTake,
    simulate_routine,
)
from pipeline.skeleton import J, load_npz

ROOT = Path(__file__).resolve().parents[3]
FPS = 30.0
STEPPING = {"march": {"forward"}, "side": {"left", "right"}, "walk": {"forward"}, "run": {"forward"}}
# Still behaviours whose feet may leave the floor (TEAM.md LABELS: still, with the tag).
FEET_MAY_LIFT = {"turn": {"turn"}, "kneel": {"kneel"}, "jump": {"jump"}}


@cache
def only(behaviour: str, seed: int = 0) -> GaitTake:
    return simulate_routine(GaitConfig(duration_s=10.0, fps=FPS, mix=((behaviour, 1.0),)), seed)


def _bouts(labels: np.ndarray) -> list[tuple[int, int]]:
    move = np.isin(labels, ["forward", "left", "right"]).astype(int)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], move, [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


@pytest.mark.parametrize("behaviour", BEHAVIOURS)
def test_planted_feet_stay_put_and_soles_meet_the_floor(behaviour: str) -> None:
    take = only(behaviour)
    prog, sol = take.programme, take.solved
    support = prog.contact & ~prog.slide
    for s in (0, 1):
        sole = np.stack([sol.heel[:, s], sol.ball[:, s]], 1)
        lowest = sole[..., 2].min(axis=1)
        assert np.abs(lowest[prog.contact[:, s]]).max() < 1e-6, (
            f"{behaviour}: a foot in contact is off the floor"
        )
        if (~prog.contact[:, s]).any():
            assert lowest[~prog.contact[:, s]].min() > -1e-6, (
                f"{behaviour}: a lifted foot went below the floor"
            )
        down = sole[..., 2] < 1e-6
        held = support[1:, s] & support[:-1, s]
        planted = down[1:] & down[:-1] & held[:, None]
        moved = np.linalg.norm(sole[1:, :, :2] - sole[:-1, :, :2], axis=-1)
        if planted.any():
            assert moved[planted].max() < 1e-6, f"{behaviour}: a planted sole point slid along the floor"
    assert np.nanmin(take.sequence.joints_m[..., 2]) > 0.0, f"{behaviour}: a joint below the floor"


@pytest.mark.parametrize("behaviour", BEHAVIOURS)
def test_labels_match_the_contacts(behaviour: str) -> None:
    take = only(behaviour)
    prog = take.programme
    labels, tags = np.array(prog.labels), np.array(prog.tags)
    moving = (~prog.contact | prog.slide).any(axis=1)
    moves = set(labels) - {"still"}
    if behaviour in STEPPING:
        assert moves and moves <= STEPPING[behaviour], f"{behaviour}: labels {set(labels)}"
    else:
        assert not moves, f"{behaviour} is a still behaviour but has {moves}"
        assert behaviour.split("-")[0] in " ".join(set(tags)) or behaviour in ("stand",), set(tags)
    for a, b in _bouts(labels):
        assert moving[a] and (a == 0 or not moving[a - 1]), (
            f"{behaviour}: bout at {a} starts without a lift-off"
        )
        if b < len(labels):
            assert not moving[b - 1] and moving[b - 2], f"{behaviour}: bout {a}-{b} ends off a touch-down"
    # A foot off the floor (or sliding) outside a bout: only the still behaviours that step, or the
    # untagged squaring-up step between behaviours.
    outside = moving & (labels == "still")
    allowed = set().union(*FEET_MAY_LIFT.values()) | {""}
    assert set(tags[outside]) <= allowed, (
        f"{behaviour}: feet move in still frames tagged {set(tags[outside])}"
    )
    if behaviour not in STEPPING and behaviour not in FEET_MAY_LIFT and behaviour != "stand":
        own = np.isin(tags, [t for t in set(tags) if t])
        assert not (moving & own).any(), f"{behaviour}: a foot left the floor during the behaviour itself"


def test_the_in_place_preset_has_what_the_independent_set_has() -> None:
    cfg = GaitConfig(
        duration_s=60.0,
        mix=IN_PLACE_MIX,
        side_kinds=IN_PLACE_SIDE_KINDS,
        body=BodyConfig(1.48, 1.98),
        noise_m=0.012,
        dropout=0.02,
    )
    takes = [simulate_routine(cfg, seed) for seed in (21, 22)]
    labels = set().union(*(set(t.sequence.labels or ()) for t in takes))
    tags = set().union(*(set(t.sequence.tags or ()) for t in takes))
    assert {"forward", "still"} <= labels and {"left", "right"} & labels
    assert "march" in tags and tags & set(IN_PLACE_SIDE_KINDS)
    assert not tags & {"walk", "run", "step-together", "shuffle", "kneel", "squat", "crouch", "jump"}
    assert tags & {"wave", "point", "stretch"} and "turn" in tags
    for t in takes:
        assert 1.48 <= t.body.height_m <= 1.98
        assert 0.01 < np.isnan(t.sequence.joints_m[..., 0]).mean() < 0.03
        drift = np.linalg.norm(t.solved.pelvis[:, :2] - t.solved.pelvis[0, :2], axis=1).max()
        assert drift < 0.8, f"stepping in place travelled {drift:.2f} m"
    # The pauses inside a bout keep its label: some bout holds both feet down for >= 0.2 s.
    longest = 0
    for t in takes:
        prog = t.programme
        labels_t = np.array(prog.labels)
        down = prog.contact.all(axis=1) & ~prog.slide.any(axis=1)
        for a, b in _bouts(labels_t):
            run = 0
            for k in range(a, b):
                run = run + 1 if down[k] else 0
                longest = max(longest, run)
    assert longest / FPS >= 0.2


def test_side_kinds_are_checked() -> None:
    with pytest.raises(ValueError, match="side_kinds"):
        GaitConfig(side_kinds=("moonwalk",))
    with pytest.raises(ValueError, match="side_kinds"):
        GaitConfig(side_kinds=())
    assert GaitConfig(side_kinds=("step-touch",)).side_kinds == ("step-touch",)
    take = simulate_routine(GaitConfig(duration_s=20.0, mix=(("side", 1.0),), side_kinds=("step-touch",)), 3)
    assert {t for t in take.sequence.tags or () if t} == {"step-touch"}
    ankle_spread = np.ptp(take.sequence.joints_m[:, [J["l_ankle"], J["r_ankle"]], :2], axis=0).max()
    assert ankle_spread > 0.05  # the feet really went out


def test_make_gait_set_in_place_preset(tmp_path: Path) -> None:
    out = tmp_path / "inplace"
    script = str(ROOT / "scripts" / "make_gait_set.py")
    args = ["--out", str(out), "--preset", "in-place", "--count", "1", "--duration-s", "30"]
    args += ["--noise-m", "0.012", "--dropout", "0.02"]
    proc = subprocess.run(
        [sys.executable, script, *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads((out / "index.json").read_text())["config"]["preset"] == "in-place"
    seq = load_npz(out / "gait_0_000.npz")
    allowed = {
        "",
        "march",
        "wave",
        "point",
        "stretch",
        "look-around",
        "turn",
        "weight-shift",
        *IN_PLACE_SIDE_KINDS,
    }
    assert set(seq.tags or ()) <= allowed and len(seq) == 900
