"""The group rule: a strict majority of the members moves the room; ties and disagreement stay still."""

from __future__ import annotations

import pytest

from pipeline.navigation.group import Vote, circular_mean_deg, group_command
from pipeline.recognition.types import ActionEstimate


def vote(uid: int, label: str, conf: float = 0.9, yaw: float = 0.0, speed: float = 1.0,
         xy: tuple[float, float] = (0.0, 0.0)) -> Vote:
    probs = {a: 0.0 for a in ("still", "forward", "left", "right")} | {label: conf}
    return Vote(uid, ActionEstimate(label, probs, yaw, speed if label != "still" else 0.0), (*xy, 0.0))


@pytest.mark.parametrize(("labels", "expected"), [
    (["forward"], "forward"),
    (["forward", "forward", "still"], "forward"),  # 2 of 3
    (["forward", "still"], "still"),  # a tie: nobody is moved against their will
    (["forward", "left"], "still"),  # a tie between two moves
    (["forward", "left", "still"], "still"),  # no majority
    (["left", "left", "right", "still"], "still"),  # 2 of 4 is not a strict majority
    (["right", "right", "right", "still"], "right"),
    (["still", "still", "forward"], "still"),
])
def test_strict_majority_or_still(labels: list[str], expected: str) -> None:
    got = group_command([vote(i, a) for i, a in enumerate(labels)])
    assert got is not None
    assert got.action.label == expected, f"{labels} -> {got.action.label}, expected {expected}"
    assert got.members == tuple(range(len(labels)))
    assert sum(got.votes.values()) == len(labels)


def test_nobody_votes_gives_no_command() -> None:
    assert group_command([]) is None


def test_figures_come_from_the_voters_who_agree() -> None:
    got = group_command([vote(0, "forward", 0.8, yaw=10.0, speed=1.0, xy=(1.0, 0.0)),
                         vote(1, "forward", 0.6, yaw=-10.0, speed=2.0, xy=(-1.0, 0.0)),
                         vote(2, "still", 1.0, yaw=90.0, xy=(0.0, 3.0))])
    assert got is not None and got.action.label == "forward"
    assert got.confidence == pytest.approx(2 / 3 * 0.7), "share of agreeing members x their mean confidence"
    assert got.action.yaw_deg == pytest.approx(0.0, abs=1e-9), "circular mean of the agreeing members' yaws"
    assert got.action.speed_mps == pytest.approx(1.5), "median speed of the agreeing members"
    assert got.position_m == pytest.approx((0.0, 1.0, 0.0)), "centroid of all members"
    still = group_command([vote(0, "forward"), vote(1, "left")])
    assert still is not None and still.action.speed_mps == 0.0 and still.confidence == 0.0


@pytest.mark.parametrize(("angles", "expected"), [([170.0, -170.0], 180.0), ([10.0, 30.0], 20.0), ([], 0.0),
                                                   ([0.0, 180.0], 0.0)])
def test_circular_mean(angles: list[float], expected: float) -> None:
    assert circular_mean_deg(angles) == pytest.approx(expected, abs=1e-6)
