"""The live pipeline on the simulator source: real worker processes, UDP on 127.0.0.1."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from pipeline.errors import InputError, SourceError
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.pipeline import Pipeline
from pipeline.runtime.status import PersonStatus

from .live import CreatedRings, Listener, children_alive, wait_for

pytestmark = pytest.mark.slow


def navigating(pipeline: Pipeline) -> list[int]:
    return [p.user_id for p in pipeline.status().people if p.navigating]


def both_found(pipeline: Pipeline) -> bool:
    """The simulator's walker (the navigator, nearest the centre) and its bystander are tracked."""
    st = pipeline.status()
    return len(st.people) == 2 and st.navigator is not None


def test_simulator_runs_reports_and_stops_clean(
    sim_pipeline: Pipeline, listener: Listener, created_rings: CreatedRings
) -> None:
    sim_pipeline.set_workstations([("127.0.0.1", listener.port)])
    sim_pipeline.start("simulator")
    wait_for(lambda: sim_pipeline.status().processed >= 45, 60, "45 processed frames")
    wait_for(lambda: bool(sim_pipeline.status().people), 30, "3D people from the simulated views")
    st = sim_pipeline.status()
    assert st.state == "running" and st.source == "simulator"
    assert [c.name for c in st.cameras] == ["cam01", "cam02", "cam03", "cam04"]
    assert all(c.ok for c in st.cameras), st.cameras
    assert set(st.latency_ms) == {"capture", "detect", "fuse", "emit", "end_to_end"}
    assert st.latency_ms["end_to_end"]["p50"] > 0
    assert st.fps > 0
    assert st.people3d and len(st.people3d[0].joints_m) == 17
    pids = sim_pipeline.worker_pids()
    assert len(pids) == 2, "simulator + fusion workers"

    jpeg = sim_pipeline.snapshot_jpeg("cam01")
    assert jpeg is not None and jpeg[:2] == b"\xff\xd8", "a JPEG of the virtual camera"
    assert sim_pipeline.snapshot_jpeg("cam99") is None

    wait_for(lambda: bool(listener.of_type("heartbeat")), 5, "a heartbeat")
    assert listener.of_type("heartbeat")[-1]["state"] == "running"
    if DEFAULT_MODEL_PATH.is_file():  # with the trained action model, the navigator's commands flow
        wait_for(lambda: len(listener.of_type("locomotion")) >= 10, 20, "locomotion datagrams")

    sim_pipeline.stop()
    assert children_alive(pids) == [], "no worker outlives stop()"
    assert created_rings.names and not created_rings.existing(), "its mailboxes are unlinked at stop"
    assert sim_pipeline.status().state == "stopped"
    kinds = [(e.kind, e.data.get("state")) for e in sim_pipeline.drain_events()]
    assert ("state", "starting") in kinds and ("state", "running") in kinds and ("state", "stopped") in kinds
    stats = listener.close()
    summary = stats.summary()
    assert summary["invalid"] == 0 and summary["dropped"] == 0 and summary["out_of_order"] == 0, summary
    seqs = [m["seq"] for m in listener.messages if m is not None]
    assert seqs == list(range(len(seqs))), "in order, one seq per datagram"


def test_navigator_choice(sim_pipeline: Pipeline) -> None:
    with pytest.raises(InputError, match="not running"):
        sim_pipeline.set_navigator(1)
    sim_pipeline.start("simulator")
    wait_for(lambda: len(sim_pipeline.status().people) >= 1, 60, "tracked people")
    with pytest.raises(InputError, match="user 999 is not tracked"):
        sim_pipeline.set_navigator(999)
    assert sim_pipeline.status().navigator_mode == "auto", "a rejected choice changes nothing"
    uid = sim_pipeline.status().people[0].user_id
    sim_pipeline.set_navigator(uid)
    wait_for(lambda: sim_pipeline.status().navigator_mode == "manual", 10, "manual mode")
    assert sim_pipeline.status().navigator == uid
    sim_pipeline.set_navigator(None)
    wait_for(lambda: sim_pipeline.status().navigator_mode == "auto", 10, "auto mode")
    nav_events = [e for e in sim_pipeline.drain_events() if e.kind == "navigator"]
    assert any(e.data["mode"] == "manual" and e.data["current"] == uid for e in nav_events)


def test_a_new_run_numbers_people_past_the_last_run_so_a_kept_choice_moves_nobody(
    sim_pipeline: Pipeline,
) -> None:
    """The navigation mode holds for the next runs, with its chosen people's ids; a new run's people
    get new ids, so that kept choice is nobody until the operator chooses again (numbered from 1
    again, the id would go to whoever the new run found first)."""
    sim_pipeline.start("simulator")
    wait_for(lambda: both_found(sim_pipeline), 60, "the walker and the bystander")
    first = sim_pipeline.status()
    assert first.navigator is not None
    sim_pipeline.set_navigation("each", [first.navigator])
    wait_for(lambda: navigating(sim_pipeline) == [first.navigator], 30, "the chosen walker navigates")
    last_id = max(p.user_id for p in sim_pipeline.status().people)
    sim_pipeline.stop()
    sim_pipeline.start("simulator")
    wait_for(lambda: both_found(sim_pipeline) and sim_pipeline.status().processed > 60, 60,
             "two seconds of the new run")
    st = sim_pipeline.status()
    assert st.navigation.mode == "each" and list(st.navigation.chosen) == [first.navigator], st.navigation
    assert min(p.user_id for p in st.people) > last_id, st.people
    assert not any(p.navigating for p in st.people), "the kept choice is nobody in the new run"
    assert st.navigator is not None
    sim_pipeline.set_navigation("each", [st.navigator])  # chosen again
    wait_for(lambda: navigating(sim_pipeline) == [st.navigator], 30, "the walker navigates")


def test_killing_a_worker_mid_run_recovers(sim_pipeline: Pipeline) -> None:
    sim_pipeline.start("simulator")
    wait_for(lambda: sim_pipeline.status().processed >= 10, 60, "first results")
    victim = sim_pipeline.workers()["fuse"]
    os.kill(victim, signal.SIGKILL)
    wait_for(lambda: victim not in sim_pipeline.worker_pids(), 20, "the chain to be rebuilt")
    count = sim_pipeline.status().processed
    wait_for(lambda: sim_pipeline.status().processed >= count + 15, 60, "results after the restart")
    assert sim_pipeline.status().state == "running", "the pipeline stays up"
    events = sim_pipeline.drain_events()
    assert any(e.kind == "worker" and "died" in e.message for e in events), [e.message for e in events]
    assert any("restarted" in e.message for e in events)


def choose_the_bystander(pipeline: Pipeline) -> PersonStatus:
    """Start the simulator and choose by hand the person the automatic choice did not take."""
    pipeline.start("simulator")
    wait_for(lambda: both_found(pipeline), 60, "the walker and the bystander")
    st = pipeline.status()
    bystander = next(p for p in st.people if p.user_id != st.navigator)
    pipeline.set_navigator(bystander.user_id)
    wait_for(lambda: pipeline.status().navigator == bystander.user_id, 10, "the bystander chosen")
    return bystander


def navigator_by_hand_where(pipeline: Pipeline, chosen: PersonStatus, past_id: int) -> None:
    """The navigator is somebody numbered past ``past_id``, chosen by hand: of the people tracked,
    the one nearest to where ``chosen`` stood (the simulated bystander may have walked on since)."""
    wait_for(lambda: both_found(pipeline) and (pipeline.status().navigator or 0) > past_id, 30,
             "a navigator among the people numbered anew")
    st = pipeline.status()
    assert st.navigator_mode == "manual", st
    assert chosen.position_m is not None

    def away(p: PersonStatus) -> float:
        assert p.position_m is not None
        return float(np.hypot(*np.subtract(p.position_m[:2], chosen.position_m[:2])))

    nearest = min(st.people, key=away)
    assert nearest.user_id == st.navigator, (st.people, chosen)


def test_a_navigator_chosen_by_hand_is_the_navigator_of_a_fusion_worker_started_again(
    sim_pipeline: Pipeline,
) -> None:
    """The operator chose the bystander (not the one the automatic choice takes); after a crash
    of the fusion worker the person tracked anew where the bystander stood is the navigator."""
    bystander = choose_the_bystander(sim_pipeline)
    victim = sim_pipeline.workers()["fuse"]
    os.kill(victim, signal.SIGKILL)
    wait_for(lambda: sim_pipeline.workers().get("fuse") not in (None, victim), 60, "a new fusion worker")
    navigator_by_hand_where(sim_pipeline, bystander, past_id=bystander.user_id)


def test_a_navigator_chosen_by_hand_goes_on_being_the_navigator_after_a_restart(
    sim_pipeline: Pipeline,
) -> None:
    """A start while the pipeline runs (the dashboard's Start, or Restart now for a new calibration)
    is a new run, whose people get new ids; the bystander the operator chose by hand is the
    navigator again, found where they stood (the automatic choice takes the walker)."""
    bystander = choose_the_bystander(sim_pipeline)
    last_id = max(p.user_id for p in sim_pipeline.status().people)
    sim_pipeline.start("simulator")
    navigator_by_hand_where(sim_pipeline, bystander, past_id=last_id)
    events = [e.message for e in sim_pipeline.drain_events() if e.kind == "navigator"]
    said = f"the navigator chosen by hand (user {bystander.user_id}) is looked for"
    assert any(said in m for m in events), events
    sim_pipeline.stop()  # an explicit stop ends the choice: the next start chooses automatically
    sim_pipeline.start("simulator")
    wait_for(lambda: both_found(sim_pipeline) and sim_pipeline.status().navigator is not None, 30,
             "a navigator")
    assert sim_pipeline.status().navigator_mode == "auto"


def test_bad_start_changes_nothing(sim_pipeline: Pipeline) -> None:
    with pytest.raises(InputError, match="source must be one of"):
        sim_pipeline.start("webcam")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="needs at least one video"):
        sim_pipeline.start("videos", {})
    assert sim_pipeline.status().state == "stopped"
    no_sim = Pipeline(RuntimeConfig(), None)
    try:
        with pytest.raises(SourceError, match="simulator is not available"):
            no_sim.start("simulator")
        assert no_sim.status().state == "stopped"
    finally:
        no_sim.close()
