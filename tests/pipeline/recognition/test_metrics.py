"""The evaluation measures on small hand-made label sequences with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.recognition.metrics import (
    AFTER_BOUT,
    BEFORE_BOUT,
    NO_BOUT,
    ScoredSequence,
    angle_error_deg,
    confusion,
    evaluate,
    false_movement_kinds,
    fill_ignore,
    latencies,
    macro_f1,
    rhythm_pauses_s,
    text_confusion,
    text_histogram,
    text_report,
    transition_mask,
)

S, F, L, R = 0, 1, 2, 3


def test_latencies_of_starts_and_stops() -> None:
    truth = np.array([S] * 10 + [F] * 10 + [S] * 10 + [L] * 5)
    pred = np.array([S] * 13 + [F] * 8 + [S] * 9 + [S] * 5)  # start 3 frames late, stop 1 late, L never
    lat = latencies(truth, pred, fps=10.0)
    np.testing.assert_allclose(lat.start_s[:1], [0.3])
    assert np.isnan(lat.start_s[1]), "the last onset is never detected"
    np.testing.assert_allclose(lat.stop_s, [0.1])


def test_a_change_between_moving_classes_is_no_start() -> None:
    truth = np.array([S] * 5 + [F] * 5 + [L] * 5 + [S] * 5)
    pred = truth.copy()
    lat = latencies(truth, pred, fps=10.0)
    assert lat.start_s.tolist() == [0.0] and lat.stop_s.tolist() == [0.0]


def test_transition_mask_leaves_out_the_time_after_each_change() -> None:
    truth = np.array([S] * 5 + [F] * 5)
    keep = transition_mask(truth, fps=10.0, exclude_s=0.3)
    assert keep.tolist() == [True] * 5 + [False] * 3 + [True] * 2


def test_confusion_and_macro_f1() -> None:
    truth = np.array([S, S, S, F, F, L, R])
    pred = np.array([S, S, F, F, F, L, S])
    conf = confusion(truth, pred)
    assert conf[S, S] == 2 and conf[S, F] == 1 and conf[R, S] == 1 and conf.sum() == 7
    # F1: still 2*2/(4+1+1)=0.667, forward 2*2/(4+1)=0.8, left 1.0, right 0
    assert macro_f1(conf) == pytest.approx((2 / 3 + 0.8 + 1.0 + 0.0) / 4)
    assert macro_f1(confusion(truth, truth)) == 1.0
    assert "recall" in text_confusion(conf) and "still" in text_confusion(conf)


def test_angle_error_wraps() -> None:
    np.testing.assert_allclose(
        angle_error_deg([179.0, -90.0, 10.0], [-179.0, 90.0, 350.0]), [2.0, 180.0, 20.0]
    )


def test_text_histogram_counts_and_misses() -> None:
    text = text_histogram(np.array([0.05, 0.15, 0.16, np.nan]), [0.0, 0.1, 0.2])
    lines = text.splitlines()
    assert lines[0].endswith(" 1") and lines[1].endswith(" 2") and lines[2].endswith(" 0")
    assert "never detected within the segment: 1" in text


# ------------------------------------------------------------------ the evaluation report


def _seq(truth: list[int], pred: list[int], tags: list[str] | None = None, contacts=None, name: str = "s"):  # type: ignore[no-untyped-def]
    n = len(truth)
    return ScoredSequence(
        name,
        "src",
        np.array(truth),
        np.array(pred),
        np.array(tags or [""] * n),
        10.0,
        None if contacts is None else np.asarray(contacts, bool),
    )


def test_evaluate_counts_frames_latencies_and_false_movement_per_tag() -> None:
    truth = [S] * 10 + [F] * 10 + [S] * 10
    pred = [S] * 5 + [L] * 2 + [S] * 5 + [F] * 10 + [S] * 8  # 2 false frames, start +2, stop +2
    tags = ["wave"] * 10 + [""] * 10 + ["kneel"] * 10
    ev = evaluate([_seq(truth, pred, tags)], exclude_s=0.0)
    assert ev.frames == 30 and ev.confusion[S, L] == 2 and ev.confusion[F, S] == 2 and ev.confusion[S, F] == 2
    assert ev.accuracy == pytest.approx(24 / 30)
    assert ev.start.values_s == pytest.approx((0.2,)) and ev.stop.values_s == pytest.approx((0.2,))
    tag = {g.name: g for g in ev.per_tag}
    assert tag["wave"].false_movement == pytest.approx(0.2) and tag["kneel"].false_movement == pytest.approx(
        0.2
    )
    assert tag["(untagged)"].movement_detected == pytest.approx(0.8)
    pc = ev.per_class()
    assert pc["forward"]["precision"] == pytest.approx(8 / 10) and pc["forward"]["recall"] == pytest.approx(
        0.8
    )
    assert pc["left"]["precision"] == 0.0 and pc["left"]["recall"] is None
    assert ev.flicker == pytest.approx(4 / 2)


def test_ignore_frames_are_left_out_and_do_not_split_a_bout() -> None:
    truth = [S] * 5 + [F] * 4 + [-1] * 2 + [F] * 4 + [S] * 5
    pred = [S] * 5 + [F] * 10 + [S] * 5
    assert fill_ignore(np.array(truth)).tolist() == [S] * 5 + [F] * 10 + [S] * 5
    ev = evaluate([_seq(truth, pred)], exclude_s=0.0)
    assert ev.frames == 18 and ev.accuracy == 1.0
    assert ev.start.n == 1 and ev.stop.n == 1, "one bout, not two"


def test_missed_transitions_count_as_infinitely_late() -> None:
    truth = [S] * 5 + [F] * 5 + [S] * 5 + [R] * 5 + [S] * 5 + [L] * 5
    pred = [S] * 6 + [F] * 4 + [S] * 15 + [L] * 5  # the right bout is never seen
    ev = evaluate([_seq(truth, pred)], exclude_s=0.0)
    assert ev.start.n == 3 and ev.start.missed == 1
    assert ev.start.median_s == pytest.approx(0.1) and ev.start.p95_s is None
    assert ev.to_dict()["start_latency"]["p95_s"] is None  # type: ignore[index]


def test_stop_beyond_rhythm_subtracts_the_bouts_own_pause() -> None:
    # contacts: both down except single swings; inside the bout two both-down pauses of 3 frames (0.3 s)
    both, l_up, r_up = (1, 1), (0, 1), (1, 0)
    contacts = [both] * 5 + [l_up] * 3 + [both] * 3 + [r_up] * 3 + [both] * 3 + [l_up] * 3 + [both] * 10
    truth = [S] * 5 + [F] * 15 + [S] * 10
    pred = [S] * 6 + [F] * 18 + [S] * 6  # stop seen 4 frames (0.4 s) after the last landing
    assert rhythm_pauses_s(np.array(truth) != S, np.array(contacts, bool), 10.0) == pytest.approx([0.3])
    ev = evaluate([_seq(truth, pred, contacts=contacts)], exclude_s=0.0)
    assert ev.stop.values_s == pytest.approx((0.4,))
    assert ev.stop_beyond_rhythm.values_s == pytest.approx((0.1,))


def test_scored_sequence_checks_its_shapes() -> None:
    with pytest.raises(ValueError, match="must be"):
        ScoredSequence("x", "s", np.zeros(5, np.int64), np.zeros(4, np.int64), np.array([""] * 5), 10.0)


def test_false_movement_is_split_by_the_predicted_bout_it_lies_in() -> None:
    truth = [S] * 4 + [F] * 4 + [S] * 6 + [S] * 6
    # begun 2 frames early, held 3 frames past the end; then a bout nobody stepped for (2 frames)
    pred = [S] * 2 + [F] * 9 + [S] * 4 + [F] * 2 + [S] * 3
    kinds = false_movement_kinds(np.array(truth), np.array(pred))
    assert (
        kinds.tolist()
        == [0, 0, BEFORE_BOUT, BEFORE_BOUT] + [0] * 4 + [AFTER_BOUT] * 3 + [0] * 4 + [NO_BOUT] * 2 + [0] * 3
    )
    ev = evaluate([_seq(truth, pred, tags=["wave"] * 8 + ["kneel"] * 12)], exclude_s=0.0)
    o = ev.overall
    assert (o.still_frames, o.false_moving, o.false_after, o.false_without) == (16, 7, 3, 2)
    assert o.false_after_bout == pytest.approx(3 / 16) and o.false_starts == pytest.approx(2 / 16)
    assert o.false_before_bout == pytest.approx(2 / 16)
    tag = {g.name: g for g in ev.per_tag}
    assert (tag["kneel"].false_after, tag["kneel"].false_without) == (3, 2) and tag["wave"].false_after == 0
    d = ev.to_dict()
    assert d["false_starts"] == pytest.approx(2 / 16) and d["false_movement_after_bout"] == pytest.approx(
        3 / 16
    )
    assert d["per_source"][0]["false_starts"] == pytest.approx(2 / 16)  # type: ignore[index]


def test_a_command_bridging_two_bouts_is_held_on_after_the_first() -> None:
    truth = np.array([F] * 3 + [S] * 3 + [L] * 3 + [S] * 2)
    pred = np.array([F] * 9 + [S] * 2)
    assert false_movement_kinds(truth, pred).tolist() == [0] * 3 + [AFTER_BOUT] * 3 + [0] * 5
    with pytest.raises(ValueError, match="alike"):
        false_movement_kinds(truth, pred[:-1])


def test_the_text_report_names_the_split() -> None:
    truth = [S] * 4 + [F] * 4 + [S] * 12
    pred = [S] * 4 + [F] * 6 + [S] * 6 + [R] * 2 + [S] * 2
    text = text_report(evaluate([_seq(truth, pred)], exclude_s=0.0))
    # 16 still frames: 2 held on after the bout, 2 in a bout of their own
    assert (
        "held on after a bout 12.50 %, begun before a bout 0.00 %, "
        "false starts (a command with no bout) 12.50 %" in text
    )
    assert "false st." in text


def test_false_movement_with_both_feet_planted_is_counted_from_the_files_contacts() -> None:
    """The issue's rule "no movement while both feet stay planted", as a figure: of the truly still
    frames whose contacts have both feet down, the share called moving; a foot up (a kick's stance,
    a step into a lunge) does not count; a file without contacts gives no figure, not a zero."""
    truth = [S] * 10 + [F] * 4 + [S] * 6
    pred = [S] * 2 + [F] * 2 + [S] * 6 + [F] * 6 + [S] * 4  # 2 frames early, 2 held on after the bout
    up, down = (True, False), (True, True)
    contacts = [down] * 2 + [up] * 2 + [down] * 6 + [up] * 4 + [down] * 6  # the first pair: a foot up
    ev = evaluate([_seq(truth, pred, tags=["kick"] * 10 + ["walk"] * 10, contacts=contacts)], exclude_s=0.0)
    o = ev.overall
    # still frames with both feet planted: 2 + 6 + 6 = 14; called moving there: the 2 after the bout
    assert (o.planted_still, o.planted_false) == (14, 2) and o.false_movement_planted == pytest.approx(2 / 14)
    assert o.false_movement == pytest.approx(4 / 16)  # the 2 frames with a foot up count there only
    tag = {g.name: g for g in ev.per_tag}
    assert tag["kick"].false_movement_planted == 0.0
    assert tag["walk"].false_movement_planted == pytest.approx(2 / 6)
    d = ev.to_dict()
    assert d["false_movement_both_feet_planted"] == pytest.approx(2 / 14)
    assert d["still_frames_both_feet_planted"] == 14
    text = text_report(ev)
    assert "with both feet planted (the files' contacts): 14.29 % of 14" in text and "planted" in text
    none = evaluate([_seq(truth, pred)], exclude_s=0.0)
    assert none.overall.false_movement_planted is None
    assert none.to_dict()["still_frames_both_feet_planted"] is None
    assert "with both feet planted (the files' contacts): — (no contacts in the files)" in text_report(none)
