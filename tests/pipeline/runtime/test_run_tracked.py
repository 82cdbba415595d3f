"""Who counts as tracked for the operator's choices: a person missed for a frame or two still is."""

from __future__ import annotations

import multiprocessing
import queue

import numpy as np

from pipeline.navigation.config import TRACKED_WITHIN_S
from pipeline.runtime.run import Run
from pipeline.runtime.supervisor import Supervisor
from pipeline.triangulation.types import Person3D
from tests.pipeline.triangulation.scene import skeleton_at


def people(*ids: int) -> list[Person3D]:
    """People standing at x = their id (the floor position follows from the skeleton's feet)."""
    return [Person3D(uid, skeleton_at(float(uid), 0.0), np.ones(17, bool), 1.0) for uid in ids]


def make_run() -> Run:
    events: queue.Queue[object] = queue.Queue()
    return Run(source="sim", cameras={}, events_q=events,
               supervisor=Supervisor(multiprocessing.get_context("spawn"), events))


def test_a_person_missed_for_a_moment_is_still_tracked_and_one_gone_longer_is_not() -> None:
    run = make_run()
    run.note_people(people(1, 2, 3), now_s=100.0)
    run.note_people(people(2, 3), now_s=100.0 + 0.5 * TRACKED_WITHIN_S)  # 1 missed in this frame
    assert run.tracked(100.0 + 0.5 * TRACKED_WITHIN_S) == [1, 2, 3]
    run.note_people(people(3), now_s=101.0 + TRACKED_WITHIN_S)
    assert run.tracked(101.0 + TRACKED_WITHIN_S) == [3], "gone longer than the grace: not tracked"
    assert make_run().tracked(0.0) == [], "nobody before the first frame"


def test_people_gone_for_an_hour_are_forgotten() -> None:
    run = make_run()
    run.note_people(people(*range(100)), now_s=0.0)
    run.note_people(people(7), now_s=4000.0)
    assert set(run.seen_s) == set(run.xy_m) == {7}
