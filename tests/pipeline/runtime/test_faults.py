"""Faults of the live pipeline's workers (issue 15 D6): real worker processes, UDP on 127.0.0.1.

A frozen fusion worker makes the heartbeat say ``stalled``; a killed simulator or fusion
worker is started again alone (the other keeps its pid and its state); a killed fork
server stops nothing. How quickly the stream comes back is measured, not asserted, by
``scripts/runtime_faults.py``.
"""

from __future__ import annotations

import os
import signal
from multiprocessing import forkserver

import pytest

from pipeline.runtime.mailbox import Mailbox
from pipeline.runtime.pipeline import Pipeline
from pipeline.runtime.shm import MAILBOX_PREFIX

from .live import CreatedRings, Listener, children_alive, wait_for

pytestmark = pytest.mark.slow


def _running(pipeline: Pipeline, frames: int = 10) -> int:
    wait_for(
        lambda: pipeline.status().state == "running" and pipeline.status().processed >= frames,
        90,
        "a running pipeline",
    )
    return pipeline.status().processed


def test_a_frozen_fusion_worker_makes_the_heartbeat_say_stalled(
    sim_pipeline: Pipeline, listener: Listener
) -> None:
    sim_pipeline.set_workstations([("127.0.0.1", listener.port)])
    sim_pipeline.start("simulator")
    _running(sim_pipeline)
    fuse = sim_pipeline.workers()["fuse"]
    os.kill(fuse, signal.SIGSTOP)  # alive but producing nothing: nothing for the supervisor to restart
    try:
        wait_for(lambda: sim_pipeline.status().state == "stalled", 20, "the status to say stalled")
        wait_for(
            lambda: any(m["state"] == "stalled" for m in listener.of_type("heartbeat")),
            20,
            "a heartbeat that says stalled",
        )
    finally:
        os.kill(fuse, signal.SIGCONT)
    wait_for(lambda: sim_pipeline.status().state == "running", 30, "running again with the next frame")
    wait_for(lambda: listener.of_type("heartbeat")[-1]["state"] == "running", 20, "a running heartbeat")
    assert sim_pipeline.workers()["fuse"] == fuse, "a stall alone restarts nothing"
    states = [e.data.get("state") for e in sim_pipeline.drain_events() if e.kind == "state"]
    assert "stalled" in states and states[-1] == "running", states


@pytest.mark.parametrize(("victim", "survivor"), [("simulator", "fuse"), ("fuse", "simulator")])
def test_a_killed_worker_is_restarted_alone(sim_pipeline: Pipeline, victim: str, survivor: str) -> None:
    sim_pipeline.start("simulator")
    _running(sim_pipeline)
    before = sim_pipeline.workers()
    os.kill(before[victim], signal.SIGKILL)
    wait_for(
        lambda: sim_pipeline.workers().get(victim) not in (None, before[victim]), 30, f"a new {victim} worker"
    )
    count = sim_pipeline.status().processed
    wait_for(lambda: sim_pipeline.status().processed >= count + 15, 60, "results after the restart")
    after = sim_pipeline.workers()
    assert after[survivor] == before[survivor], f"the {survivor} worker goes on: only the dead one restarts"
    assert sim_pipeline.status().state == "running"
    messages = [e.message for e in sim_pipeline.drain_events()]
    assert any(f"{victim} died" in m and "alone" in m for m in messages), messages
    assert any(f"{victim} restarted" in m for m in messages), messages


def test_a_killed_fork_server_stops_nothing(sim_pipeline: Pipeline) -> None:
    sim_pipeline.start("simulator")
    _running(sim_pipeline)
    before = sim_pipeline.workers()
    server_pid = forkserver._forkserver._forkserver_pid  # type: ignore[attr-defined]
    assert server_pid is not None and server_pid not in before.values()
    os.kill(server_pid, signal.SIGKILL)
    count = sim_pipeline.status().processed
    wait_for(lambda: sim_pipeline.status().processed >= count + 30, 60, "results after the kill")
    assert sim_pipeline.workers() == before, "the workers outlive their fork server"
    assert sim_pipeline.status().state == "running"
    assert not any("died" in e.message for e in sim_pipeline.drain_events())

    os.kill(before["fuse"], signal.SIGKILL)  # a later restart goes through a new fork server
    wait_for(
        lambda: sim_pipeline.workers().get("fuse") not in (None, before["fuse"]), 30, "a new fuse worker"
    )
    count = sim_pipeline.status().processed
    wait_for(lambda: sim_pipeline.status().processed >= count + 15, 60, "results from the new fuse worker")
    assert forkserver._forkserver._forkserver_pid not in (None, server_pid)  # type: ignore[attr-defined]
    pids = sim_pipeline.worker_pids()
    sim_pipeline.stop()
    assert children_alive(pids) == [], "stop() ends the workers of the dead fork server too"


def test_the_mailboxes_between_the_stages_are_unlinked_at_stop(
    sim_pipeline: Pipeline, created_rings: CreatedRings
) -> None:
    sim_pipeline.start("simulator")
    _running(sim_pipeline)
    boxes = set(created_rings.of(MAILBOX_PREFIX))
    assert len(boxes) == 2 and boxes <= created_rings.existing(), "simulator -> fuse, fuse -> collector"
    sim_pipeline.stop()
    assert not created_rings.existing()


def test_a_mailbox_hands_on_the_newest_or_every_message_and_survives_its_writer() -> None:
    box = Mailbox.create("test")
    try:
        assert box.get(timeout=0.01) is None and box.get_all(timeout=0.01) == []
        writer = Mailbox.attach(box.spec)
        for i in range(3):
            writer.put({"i": i})
        assert box.get_all(timeout=1.0) == [{"i": 0}, {"i": 1}, {"i": 2}], "every one, in order"
        for i in range(3, 10):
            writer.put({"i": i})
        assert box.get(timeout=1.0) == ({"i": 9}, 6), "the newest, and how many it skipped"
        writer.close()
        again = Mailbox.attach(box.spec)  # a restarted writer goes on where the dead one stopped
        again.put({"i": 10})
        assert box.get_all(timeout=1.0) == [{"i": 10}]
        again.close()
    finally:
        box.unlink()
