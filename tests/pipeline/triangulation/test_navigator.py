"""The primary navigator: auto (nearest the centre after a dwell), manual, occlusions, events."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.triangulation.config import NavigatorConfig
from pipeline.triangulation.navigator import NavigatorChange, NavigatorSelector
from pipeline.triangulation.types import Person3D
from tests.pipeline.triangulation.scene import skeleton_at

DT = 0.1


def person(uid: int, x: float, y: float) -> Person3D:
    return Person3D(uid, skeleton_at(x, y), np.ones(17, bool), 1.0)


def run(sel: NavigatorSelector, frames, t0: float = 0.0) -> tuple[float, list[NavigatorChange]]:
    """Feed frames (lists of people) DT apart; returns the next time and the change events."""
    events = []
    t = t0
    for people in frames:
        ev = sel.update(people, t)
        if ev is not None:
            events.append(ev)
        t += DT
    return t, events


def test_auto_picks_the_person_nearest_the_centre_after_the_dwell() -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.5))
    t, events = run(sel, [[person(1, 1.0, 0.0), person(2, 0.2, 0.1)]] * 4)
    assert sel.current is None and events == [], "nobody is chosen before the dwell time"
    t, events = run(sel, [[person(1, 1.0, 0.0), person(2, 0.2, 0.1)]] * 3, t)
    assert sel.current == 2
    assert len(events) == 1 and (events[0].previous, events[0].current, events[0].mode) == (None, 2, "auto")


def test_auto_ignores_people_outside_the_radius() -> None:
    sel = NavigatorSelector(NavigatorConfig(max_radius_m=1.0))
    run(sel, [[person(1, 1.4, 1.0)]] * 10)
    assert sel.current is None


def test_auto_choice_survives_a_short_occlusion_and_passes_on_after_a_long_one() -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.3, hold_s=1.5))
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(2, 0.8, 0.0)]] * 5)
    assert sel.current == 1
    t, events = run(sel, [[person(2, 0.8, 0.0)]] * 10, t)  # 1 hidden for 1.0 s
    assert sel.current == 1 and events == [], "a 1 s occlusion keeps the navigator"
    t, events = run(sel, [[person(1, 0.0, 0.0), person(2, 0.8, 0.0)]] * 2, t)
    assert sel.current == 1
    t, events = run(sel, [[person(2, 0.8, 0.0)]] * 20, t)  # hidden for 2 s
    assert sel.current == 2, "after hold_s the next person nearest the centre takes over"
    assert [(e.previous, e.current) for e in events] == [(1, 2)]


def test_auto_switches_only_to_someone_clearly_nearer_for_the_dwell() -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.5, switch_margin_m=0.5))
    t, _ = run(sel, [[person(1, 0.3, 0.0)]] * 6)
    assert sel.current == 1
    t, events = run(sel, [[person(1, 0.3, 0.0), person(2, 0.0, 0.0)]] * 10, t)  # only 0.3 m nearer
    assert sel.current == 1 and events == []
    t, events = run(sel, [[person(1, 1.2, 0.0), person(2, 0.0, 0.0)]] * 3, t)  # walks away
    assert sel.current == 1, "not before the challenger has been nearer for the dwell"
    t, events = run(sel, [[person(1, 1.2, 0.0), person(2, 0.0, 0.0)]] * 4, t)
    assert sel.current == 2 and [(e.previous, e.current) for e in events] == [(1, 2)]


def test_manual_choice_holds_through_occlusion_and_returns() -> None:
    sel = NavigatorSelector()
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(2, 1.0, 0.0)]] * 6)
    assert sel.current == 1
    ev = sel.set_manual(2)
    assert ev is not None and (ev.previous, ev.current, ev.mode) == (1, 2, "manual")
    t, events = run(sel, [[person(1, 0.0, 0.0)]] * 10, t)  # 2 hidden 1 s: still the navigator
    assert sel.current == 2 and events == []
    t, events = run(sel, [[person(1, 0.0, 0.0)]] * 10, t)  # 2 s: lost, manual mode stays
    assert sel.current is None and sel.mode == "manual"
    assert [(e.previous, e.current) for e in events] == [(2, None)]
    t, events = run(sel, [[person(1, 0.0, 0.0), person(2, 1.0, 0.0)]], t)
    assert sel.current == 2, "the chosen user navigates again when seen"
    ev = sel.set_auto()
    assert ev is not None and ev.mode == "auto" and sel.current == 2


@pytest.mark.parametrize(("user_id", "match"), [(7, "user 7 is not tracked"), ("2", "must be an integer"),
                                                (True, "must be an integer")])
def test_manual_choice_of_an_unknown_user_is_rejected_and_changes_nothing(user_id, match) -> None:
    sel = NavigatorSelector()
    run(sel, [[person(1, 0.0, 0.0), person(2, 1.0, 0.0)]] * 6)
    with pytest.raises(InputError, match=match):
        sel.set_manual(user_id)
    assert sel.current == 1 and sel.mode == "auto"


def test_manual_mode_from_the_config_waits_for_a_choice() -> None:
    sel = NavigatorSelector(NavigatorConfig(mode="manual"))
    run(sel, [[person(1, 0.0, 0.0)]] * 10)
    assert sel.current is None
    assert sel.tracked == (1,)


def test_people_without_a_position_are_ignored_and_bad_time_rejected() -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.0))
    blind = Person3D(3, np.full((17, 3), np.nan), np.zeros(17, bool), float("nan"))
    sel.update([blind], 0.0)
    assert sel.current is None and sel.tracked == ()
    with pytest.raises(InputError, match="finite"):
        sel.update([], float("inf"))


def test_bad_navigator_config_is_rejected() -> None:
    with pytest.raises(ValueError, match="mode"):
        NavigatorConfig(mode="random")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="hold_s"):
        NavigatorConfig(hold_s=-1.0)


def test_changes_are_logged_and_the_selector_comes_from_the_settings(caplog) -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.0))
    assert sel.config.dwell_s == 0.0 and sel.mode == "auto"
    with caplog.at_level("INFO", logger="pipeline.triangulation.navigator"):
        sel.update([person(4, 0.0, 0.0)], 0.0)
    assert sel.current == 4
    assert any("navigator None -> 4" in r.getMessage() for r in caplog.records), caplog.text


def test_a_lost_manual_navigator_falls_back_to_automatic_after_the_grace_period() -> None:
    """Issue 19.1: a manual choice lost for good must not leave the session with nobody steering."""
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.3, hold_s=1.0, manual_grace_s=2.0))
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(2, 0.6, 0.0)]] * 5)
    sel.set_manual(1)
    t, events = run(sel, [[person(2, 0.6, 0.0)]] * 25, t)  # 1 walks away: 2.5 s, within hold + grace
    assert sel.current is None and sel.mode == "manual", "waited for within hold_s + manual_grace_s"
    assert [(e.previous, e.current, e.reason) for e in events] == [(1, None, "operator's choice lost")]
    t, events = run(sel, [[person(2, 0.6, 0.0)]] * 6, t)  # past 3.0 s missing
    assert sel.mode == "auto" and sel.current == 2, "after the grace period the automatic choice takes over"
    assert events[-1].mode == "auto" and events[-1].current == 2
    assert "operator's choice lost for 3.0 s: automatic choice" in events[-1].reason, events[-1].reason


def test_a_lost_manual_navigator_with_nobody_left_still_returns_to_automatic() -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.0, hold_s=0.5, manual_grace_s=1.0))
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(2, 0.6, 0.0)]] * 2)
    sel.set_manual(2)
    t, events = run(sel, [[]] * 20, t)
    assert sel.mode == "auto" and sel.current is None
    assert [(e.current, e.mode) for e in events] == [(None, "manual"), (None, "auto")]
    t, events = run(sel, [[person(5, 0.1, 0.0)]], t)
    assert sel.current == 5, "whoever comes back is chosen automatically"


def test_a_lost_manual_navigator_is_reacquired_under_a_new_id_where_they_vanished() -> None:
    """The tracker gives a person a new id after a break: the operator's choice follows them."""
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.3, hold_s=1.5, reacquire_radius_m=0.6))
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(2, 1.0, 0.5)]] * 5)
    sel.set_manual(2)
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(2, 1.0, 0.5)]] * 3, t)
    t, events = run(sel, [[person(1, 0.0, 0.0)]] * 4, t)  # 2 drops out of tracking for 0.4 s ...
    t, events = run(sel, [[person(1, 0.0, 0.0), person(7, 1.2, 0.4)]] * 3, t)  # ... and is back as 7
    assert sel.mode == "manual" and sel.current == 7
    assert [(e.previous, e.current) for e in events] == [(2, 7)]
    assert "re-acquired" in events[0].reason and "user 2" in events[0].reason


def test_a_choice_resumed_by_a_new_selector_takes_the_person_tracked_where_the_navigator_was() -> None:
    """A fusion worker started again: its selector is new, everyone gets a new id at once; the
    operator's navigator of the worker before is the one first tracked where they were last seen."""
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.3, hold_s=1.0, manual_grace_s=2.0))
    sel.resume_manual(2, (1.0, 0.5))
    assert sel.mode == "manual" and sel.current is None
    t, events = run(sel, [[]] * 5, 100.0)  # the new worker tracks nobody for 0.5 s
    assert sel.current is None and sel.mode == "manual"
    t, events = run(sel, [[person(5, 0.0, 0.0), person(6, 1.1, 0.45)]] * 3, t)
    assert sel.mode == "manual" and sel.current == 6, "not the person nearest the centre"
    assert [(e.previous, e.current) for e in events] == [(None, 6)]
    assert "re-acquired" in events[0].reason and "user 2" in events[0].reason


def test_a_resumed_choice_with_nobody_where_the_navigator_was_falls_back_to_automatic() -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.3, hold_s=1.0, manual_grace_s=2.0))
    sel.resume_manual(2, (1.0, 0.5))
    t, _ = run(sel, [[person(5, 0.0, 0.0), person(6, -1.0, -1.0)]] * 29, 50.0)
    assert sel.mode == "manual" and sel.current is None, "waited for hold_s + manual_grace_s"
    run(sel, [[person(5, 0.0, 0.0), person(6, -1.0, -1.0)]] * 3, t)
    assert sel.mode == "auto" and sel.current == 5


@pytest.mark.parametrize(
    ("config", "newcomer_xy"),
    [
        (NavigatorConfig(reacquire_radius_m=0.6), (-1.0, -1.0)),  # too far from where 2 vanished
        (NavigatorConfig(reacquire_radius_m=0.0), (1.1, 0.5)),  # re-acquisition off
    ],
)
def test_no_reacquisition_far_away_or_when_off(config: NavigatorConfig, newcomer_xy) -> None:
    sel = NavigatorSelector(config)
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(2, 1.0, 0.5)]] * 6)
    sel.set_manual(2)
    t, _ = run(sel, [[person(1, 0.0, 0.0)]] * 3, t)
    run(sel, [[person(1, 0.0, 0.0), person(8, *newcomer_xy)]] * 3, t)
    assert sel.mode == "manual" and sel.current == 2, "held through the short occlusion, nobody else taken"


def test_an_old_bystander_is_not_taken_for_the_lost_navigator() -> None:
    sel = NavigatorSelector(NavigatorConfig(dwell_s=0.0, hold_s=0.5, manual_grace_s=5.0))
    t, _ = run(sel, [[person(1, 0.0, 0.0), person(3, 0.9, 0.5)]] * 3)
    sel.set_manual(1)
    t, _ = run(sel, [[person(1, 0.8, 0.5), person(3, 0.9, 0.5)]] * 3, t)
    run(sel, [[person(3, 0.9, 0.5)]] * 10, t)  # 1 leaves right next to 3, who was there all along
    assert sel.current is None and sel.mode == "manual"


def test_grace_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="manual_grace_s"):
        NavigatorConfig(manual_grace_s=-1.0)
    with pytest.raises(ValueError, match="reacquire_radius_m"):
        NavigatorConfig(reacquire_radius_m=-0.1)
