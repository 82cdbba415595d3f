"""The navigation stage's contract: bad requests change nothing; lost people start afresh."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.navigation.config import NavigationConfig
from pipeline.navigation.navigators import Navigators
from pipeline.recognition.types import ActionEstimate
from pipeline.triangulation.types import Person3D


class Counting:
    """A recogniser state that says forward on every update and counts them."""

    def __init__(self) -> None:
        self.updates = 0

    def update(self, joints_m: object, timestamp_s: float) -> ActionEstimate:
        self.updates += 1
        return ActionEstimate("forward", {"still": 0.1, "forward": 0.9, "left": 0.0, "right": 0.0}, 0.0, 1.0)

    def reset(self) -> None:
        self.updates = 0


def person(uid: int, x: float) -> Person3D:
    joints = np.zeros((17, 3))
    joints[:, 0] = x
    return Person3D(uid, joints, np.ones(17, dtype=bool), 1.0)


@pytest.mark.parametrize(("mode", "ids", "match"), [
    ("bogus", (), "navigation mode must be one of single, each, group"),
    ("each", (1, 1), "distinct"),
    ("group", (-2,), "integers >= 0"),
    ("single", (1,), "not single"),
])
def test_a_bad_request_raises_and_changes_nothing(mode: str, ids: tuple[int, ...], match: str) -> None:
    nav = Navigators(NavigationConfig("each", (1, 2)), Counting)
    nav.update([person(1, 0.0), person(2, 1.0)], 0.0)
    with pytest.raises(InputError, match=match):
        nav.set_mode(mode, ids)
    assert (nav.mode, nav.chosen) == ("each", (1, 2)), "the mode and the chosen people stay"
    frame = nav.update([person(1, 0.0), person(2, 1.0)], 0.1)
    assert frame.changes == (), "the states were kept: no command changed"


def test_each_person_has_their_own_state_and_a_returning_person_starts_afresh() -> None:
    made: list[Counting] = []

    def make() -> Counting:
        made.append(Counting())
        return made[-1]

    nav = Navigators(NavigationConfig("each", (), max_navigators=2), make)
    people = [person(1, 0.0), person(2, 0.5), person(3, 1.4)]
    first = nav.update(people, 0.0)
    assert first.user_ids == (1, 2), "at most max_navigators, nearest the centre first"
    started = [(c.user_id, c.previous, c.current) for c in first.changes]
    assert started == [(1, None, "forward"), (2, None, "forward")]
    nav.update(people, 0.1)
    assert [m.updates for m in made] == [2, 2]
    gone = nav.update([person(1, 0.0)], 0.2)
    assert [(c.user_id, c.current) for c in gone.changes] == [(2, None)], "user 2's command ended"
    nav.update(people, 0.3)
    assert len(made) == 3 and made[-1].updates == 1, "user 2 came back with a fresh state"
    group = Navigators(NavigationConfig("group", (1, 3)), make)
    g = group.update(people, 0.0)
    assert g.group is not None and g.group.members == (1, 3) and g.group.action.label == "forward"
