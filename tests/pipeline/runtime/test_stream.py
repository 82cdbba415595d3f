"""The UDP stream is sent by the fusion worker (issue 16, item 3): real workers, a real UDP socket.

The main process's collector (and every main-process sink) can be stuck and fresh locomotion
still arrives; ``seq`` goes on, from one sender address, across a killed fusion worker; the
shared book hands ``seq`` and the endpoints between the two emitters of one stream.
"""

from __future__ import annotations

import itertools
import logging
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from pipeline.emitter import udp
from pipeline.emitter.udp import EmitterConfig, UdpEmitter, stream_socket
from pipeline.errors import InputError
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH
from pipeline.results import FrameResult
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.pipeline import Handover, Pipeline
from pipeline.runtime.stream import MAX_ENDPOINTS, StreamBook
from tests.adaptation import FIXED, shows_fixed
from tests.datagrams import DatagramRecorder
from tests.waiting import wait_until

from .live import wait_for

ROOT = Path(__file__).resolve().parents[3]
needs_model = pytest.mark.skipif(not DEFAULT_MODEL_PATH.is_file(), reason="the trained action model")


@pytest.fixture()
def recorder() -> Any:
    rx = DatagramRecorder()
    yield rx
    rx.close()


class StuckSink:
    """A main-process sink that blocks the collector's thread until released."""

    def __init__(self) -> None:
        self.entered = threading.Event()
        self.release = threading.Event()

    def on_result(self, result: FrameResult) -> None:
        self.entered.set()
        self.release.wait(120)


@pytest.mark.slow
@needs_model
def test_fresh_locomotion_arrives_while_the_main_process_collector_is_stuck(
    sim_pipeline: Pipeline, recorder: DatagramRecorder
) -> None:
    sim_pipeline.set_workstations([("127.0.0.1", recorder.port)])
    sim_pipeline.start("simulator")
    wait_until(lambda: recorder.fresh_locomotion() >= 5, "locomotion from the running pipeline")
    stuck = StuckSink()
    sim_pipeline.add_sink(stuck)
    try:
        assert stuck.entered.wait(120), "the collector handed a result to the sink"
        before = recorder.fresh_locomotion()
        processed = sim_pipeline.status().processed
        # with the send in the main process, a stuck collector sent nothing new (repeats for
        # stale_after_s, then silence); from the fusion worker, every new result goes out
        wait_until(lambda: recorder.fresh_locomotion() >= before + 30,
                   "30 new locomotion results while the collector is stuck")
        assert sim_pipeline.status().processed == processed, "the collector really was stuck meanwhile"
    finally:
        stuck.release.set()
        sim_pipeline.remove_sink(stuck)


@pytest.mark.slow
@needs_model
def test_seq_goes_on_from_one_sender_across_a_killed_fusion_worker(
    sim_pipeline: Pipeline, recorder: DatagramRecorder
) -> None:
    sim_pipeline.set_workstations([("127.0.0.1", recorder.port)])
    sim_pipeline.start("simulator")
    wait_until(lambda: recorder.fresh_locomotion() >= 5, "locomotion from the running pipeline")
    fuse = sim_pipeline.workers()["fuse"]
    os.kill(fuse, signal.SIGKILL)
    wait_for(lambda: sim_pipeline.workers().get("fuse") not in (None, fuse), 60, "a new fusion worker")
    count = len(recorder.of_type("locomotion"))
    wait_until(lambda: len(recorder.of_type("locomotion")) >= count + 30, "locomotion from the new worker")
    sim_pipeline.send_prompt("Walk forward", "forward", 3.0)  # by the fusion worker, on its stream
    wait_until(lambda: recorder.of_type("prompt"), "the prompt from the running pipeline")
    sim_pipeline.stop()
    wait_until(lambda: any(m["state"] == "stopped" for m in recorder.of_type("heartbeat")),
               "a heartbeat that says stopped (the main process's emitter)")
    sim_pipeline.send_prompt("Stand still", "still", 1.0)  # by the main process's emitter
    wait_until(lambda: len(recorder.of_type("prompt")) == 2, "the prompt of the stopped pipeline")
    assert [m["text"] for m in recorder.of_type("prompt")] == ["Walk forward", "Stand still"]
    senders = {addr for addr, _ in recorder.got}
    assert len(senders) == 1, f"one socket sends the stream, whichever process: {senders}"
    seqs = [m["seq"] for _, m in recorder.got]
    assert all(b > a for a, b in itertools.pairwise(seqs)), "seq never repeats or goes back"
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "one seq per datagram, no gap"


def _hold_reader_lock(q: Any, held: Any) -> None:
    """What a worker killed inside ``get`` leaves: the queue's reader lock taken, never let go."""
    q._rlock.acquire()
    held.set()
    time.sleep(600)


@pytest.mark.slow
@needs_model
def test_a_fusion_worker_started_again_reads_control_messages_its_killed_predecessor_jammed(
    sim_pipeline: Pipeline, recorder: DatagramRecorder
) -> None:
    """A lone restart keeps the other workers' queues, but the fusion worker gets a new control
    queue: on the old one, a predecessor killed inside ``get`` holds the reader lock for ever, and
    the prompts, the navigator and the navigation mode would never reach the new worker."""
    sim_pipeline.set_workstations([("127.0.0.1", recorder.port)])
    sim_pipeline.start("simulator")
    wait_until(lambda: recorder.fresh_locomotion() >= 5, "locomotion from the running pipeline")
    workers = sim_pipeline.workers()
    run = sim_pipeline._run
    assert run is not None and run.control_q is not None
    fork = multiprocessing.get_context("fork")  # inherits the queue as the worker did
    held = fork.Event()
    holder = fork.Process(target=_hold_reader_lock, args=(run.control_q, held), daemon=True)
    holder.start()
    try:
        assert held.wait(30)
        for pid in (holder.pid, workers["fuse"]):  # both die: the lock stays taken
            assert pid is not None
            os.kill(pid, signal.SIGKILL)
    finally:
        holder.join(10)
    wait_for(lambda: sim_pipeline.workers().get("fuse") not in (None, workers["fuse"]), 60,
             "a new fusion worker")
    assert sim_pipeline.workers()["simulator"] == workers["simulator"], "the fusion worker was started alone"
    count = len(recorder.of_type("locomotion"))
    wait_until(lambda: len(recorder.of_type("locomotion")) >= count + 30, "locomotion from the new worker")
    sim_pipeline.send_prompt("Step left", "left", 2.0)
    wait_until(lambda: recorder.of_type("prompt"), "the prompt through the new worker's control queue", 30)
    assert recorder.of_type("prompt")[0]["text"] == "Step left"


class Results:
    """A main-process sink that keeps the fused results (the collector's thread appends)."""

    def __init__(self) -> None:
        self.got: list[FrameResult] = []

    def on_result(self, result: FrameResult) -> None:
        self.got.append(result)


def _adapted(result: FrameResult) -> bool:
    return shows_fixed(result.action.probs if result.action is not None else None)


@pytest.mark.slow
@needs_model
def test_a_fusion_worker_started_again_keeps_the_run_s_navigation_and_adaptation_and_numbers_people_anew(
    sim_pipeline: Pipeline, recorder: DatagramRecorder
) -> None:
    """The mode and the adaptation changed while the run goes on (the status shows them) hold for a
    fusion worker started again after a crash too. It numbers people past the ids its predecessor
    gave out: the chosen navigator's id is nobody now, so nobody moves until the operator chooses
    again (a new tracker would give that id to whoever it found first)."""
    results = Results()
    sim_pipeline.add_sink(results)
    sim_pipeline.set_workstations([("127.0.0.1", recorder.port)])
    sim_pipeline.start("simulator")
    wait_until(lambda: recorder.fresh_locomotion() >= 5, "locomotion from the running pipeline")
    wait_until(lambda: len(sim_pipeline.status().people) == 2, "the walker and the bystander")
    walker = results.got[-1].navigator  # the simulator's walker, nearest the centre
    assert walker is not None
    sim_pipeline.set_navigation("each", [walker])
    sim_pipeline.set_adaptation(FIXED)
    wait_until(lambda: any(m["mode"] == "each" for m in recorder.of_type("navigation")), "the mode each")
    wait_until(lambda: len(results.got) > 30 and all(_adapted(r) for r in results.got[-30:]),
               "one second of adapted outputs")
    before = max(p.user_id for r in results.got for p in r.people3d)
    fuse = sim_pipeline.workers()["fuse"]
    os.kill(fuse, signal.SIGKILL)
    wait_for(lambda: sim_pipeline.workers().get("fuse") not in (None, fuse), 60, "a new fusion worker")
    seen, announced = len(results.got), len(recorder.of_type("navigation"))
    wait_until(lambda: len(results.got) >= seen + 60 and len(recorder.of_type("navigation")) > announced,
               "two seconds of results and a navigation datagram from the new worker")
    after = results.got[seen:]
    assert sim_pipeline.status().navigation.mode == "each"
    assert {r.navigation.mode for r in after if r.navigation is not None} == {"each"}, (
        "the new worker navigates in the mode the pipeline shows"
    )
    assert {m["mode"] for m in recorder.of_type("navigation")[announced:]} == {"each"}
    ids = {p.user_id for r in after for p in r.people3d}
    assert ids and min(ids) > before, f"new numbers past {before}: {sorted(ids)}"
    assert all(r.navigation is not None and not r.navigation.commands for r in after[-30:]), (
        "the chosen id is nobody now: nobody navigates"
    )
    events = [e.message for e in sim_pipeline.drain_events() if e.kind == "navigator"]
    assert any(f"numbered from {before + 1}" in m for m in events), events
    walker = results.got[-1].navigator
    assert walker is not None and walker > before
    sim_pipeline.set_navigation("each", [walker])  # the operator chooses again
    seen = len(results.got)
    wait_until(lambda: len(results.got) >= seen + 60, "two seconds of results")
    assert all(_adapted(r) for r in results.got[-30:]), "the new worker applies the participant's adaptation"


def test_the_book_hands_seq_and_endpoints_between_the_two_emitters() -> None:
    book = StreamBook.create()
    rx = DatagramRecorder()
    sock = stream_socket(EmitterConfig())
    config = EmitterConfig(heartbeat_s=10.0)
    standby = UdpEmitter(config, [("127.0.0.1", rx.port)], shared=book, role="standby", sock=sock)
    fusion = UdpEmitter(config, shared=StreamBook.attach(book.spec), role="fusion", sock=sock)
    try:
        standby.tick(time.monotonic())  # nobody else sends: the standby's heartbeat goes out
        assert fusion.endpoints == [], "the fusion emitter follows the book when it sends"
        t = time.monotonic()
        fusion.tick(t)  # ticks the book, follows the endpoints, sends its own heartbeat
        assert fusion.endpoints == [("127.0.0.1", rx.port)]
        assert book.fusion_sends(t + 0.05)
        standby.set_state("running")
        standby.tick(t + 0.1)  # the fusion emitter sends now: the standby stays silent
        book.release()
        standby.tick(time.monotonic())  # the fusion emitter is gone: the standby's heartbeat goes out
        wait_until(lambda: len(rx.got) >= 3, "three heartbeats")
        assert [m["seq"] for _, m in rx.got] == [0, 1, 2], "one seq, shared"
        assert [m["state"] for _, m in rx.got] == ["stopped", "stopped", "running"]
        assert standby.sent == fusion.sent == 3, "both count the stream's datagrams"
        with pytest.raises(InputError, match="at most"):
            standby.set_endpoints([("127.0.0.1", p) for p in range(1000, 1001 + MAX_ENDPOINTS)])
        assert book.endpoints()[1] == [("127.0.0.1", rx.port)], "a rejected list changes nothing"
        with pytest.raises(ValueError, match="do not go together"):
            UdpEmitter(config, role="fusion")
    finally:
        standby.close()
        fusion.close()
        rx.close()
        book.unlink()


def test_the_operator_s_hold_set_in_the_main_process_is_what_the_fusion_worker_s_emitter_sends() -> None:
    """The hold lives in the book: the standby (main process) sets it, the fusion emitter (another
    book attached, as in the worker) sends every locomotion command still from its next datagram,
    with the user, yaw and position as they were; released, the command goes out as submitted."""
    from pipeline.emitter.protocol import LocomotionCommand

    book = StreamBook.create()
    rx = DatagramRecorder()
    sock = stream_socket(EmitterConfig())
    config = EmitterConfig(rate_hz=60.0, heartbeat_s=100.0, stale_after_s=100.0)
    standby = UdpEmitter(config, [("127.0.0.1", rx.port)], shared=book, role="standby", sock=sock)
    fusion = UdpEmitter(config, shared=StreamBook.attach(book.spec), role="fusion", sock=sock)
    t = time.monotonic()
    forward = LocomotionCommand(3, "forward", 0.8, 40.0, 1.2, (0.25, -0.5, 0.0), t)
    try:
        fusion.submit(forward)  # sent at once (after the fusion emitter's first heartbeat)
        standby.set_held(True, "session")
        assert fusion.held and standby.held and book.held
        assert fusion.hold_by == book.hold_by == "session", "who holds goes through the book too"
        fusion.tick(t + 1.0)  # a repeat: held
        fusion.submit(replace(forward, timestamp_s=t + 1.1))  # a fresh result, due at the next tick
        fusion.tick(t + 2.0)  # held too
        standby.set_held(False)
        fusion.tick(t + 3.0)  # released: as submitted
        wait_until(lambda: len(rx.of_type("locomotion")) >= 4, "four locomotion datagrams")
        loco = rx.of_type("locomotion")
        said = [m["by"] for m in rx.of_type("hold")]  # said on each change and after a heartbeat
        assert said[-1] is None and set(said[:-1]) == {"session"}, f"the fusion emitter says who: {said}"
        assert [(m["action"], m["speed_mps"], m["confidence"]) for m in loco] == [
            ("forward", 1.2, 0.8), ("still", 0.0, 1.0), ("still", 0.0, 1.0), ("forward", 1.2, 0.8)]
        assert all(m["user_id"] == 3 and m["yaw_deg"] == 40.0 and m["position_m"] == [0.25, -0.5, 0.0]
                   for m in loco), "the hold changes the command, not who or where"
        with pytest.raises(ValueError, match="main process sets it"):
            fusion.set_held(True)
        assert not book.held, "the fusion emitter cannot hold the stream"
    finally:
        standby.close()
        fusion.close()
        rx.close()
        book.unlink()


def test_a_datagram_takes_its_seq_only_once_it_is_built(monkeypatch: pytest.MonkeyPatch) -> None:
    """A sender that dies while it builds a datagram (here: its encoder fails) leaves no gap in
    ``seq``: the next datagram, from whichever emitter, carries the seq the lost one would have."""
    book = StreamBook.create()
    rx = DatagramRecorder()
    config = EmitterConfig(heartbeat_s=10.0)
    emitter = UdpEmitter(config, [("127.0.0.1", rx.port)], shared=book, role="standby")

    def dies_while_building(*args: Any) -> dict[str, Any]:
        raise RuntimeError("the sender died while building")

    try:
        emitter.tick(time.monotonic())
        wait_until(lambda: len(rx.got) == 1, "the first heartbeat")
        monkeypatch.setattr(udp, "prompt_message", dies_while_building)
        with pytest.raises(RuntimeError, match="while building"):
            emitter.send_prompt("Walk forward", "forward", 3.0)
        assert book.peek_seq() == 1, "the datagram never built took no seq"
        monkeypatch.undo()
        emitter.send_prompt("Walk forward", "forward", 3.0)
        wait_until(lambda: len(rx.got) == 2, "the prompt")
        assert [(m["type"], m["seq"]) for _, m in rx.got] == [("heartbeat", 0), ("prompt", 1)]
        assert book.peek_seq() == 2
    finally:
        emitter.close()
        rx.close()
        book.unlink()


# -- seq across server processes (emitter.seq_file) ------------------------------------------------
_SENDER = """
import sys, time
from pathlib import Path
from pipeline.emitter.udp import EmitterConfig, UdpEmitter
from pipeline.runtime.stream import StreamBook
book = StreamBook.create(seq_file=Path(sys.argv[1]), lease=int(sys.argv[3]))
emitter = UdpEmitter(EmitterConfig(heartbeat_s=0.005), [("127.0.0.1", int(sys.argv[2]))], shared=book,
                     role="standby")
emitter.start()
time.sleep(600)
"""


def test_a_server_killed_mid_stream_leaves_its_successor_above_every_seq_it_sent(tmp_path: Path) -> None:
    """A real process sends heartbeats 200 times a second with a lease of 20 (renewed every 10
    datagrams) and is killed with SIGKILL: the next book starts above every seq that arrived."""
    seq_file = tmp_path / "stream-seq"
    rx = DatagramRecorder()
    proc = subprocess.Popen([sys.executable, "-c", _SENDER, str(seq_file), str(rx.port), "20"], cwd=ROOT)
    try:
        wait_until(lambda: len(rx.got) >= 150, "150 heartbeats from the sending process")
        proc.kill()
        proc.wait(30)
        time.sleep(0.2)  # what was in flight has arrived
        sent = [m["seq"] for _, m in rx.got]
        assert sent[0] == 0 and sent == list(range(len(sent))), "a first process starts at 0"
        book = StreamBook.create(seq_file=seq_file, lease=20)
        try:
            first = book.take_seq()
            assert max(sent) < first <= max(sent) + 21, f"{first} after {max(sent)}: above, within a lease"
        finally:
            book.unlink()
    finally:
        proc.kill()
        rx.close()


def test_the_lease_in_the_seq_file_stays_above_every_seq_taken(tmp_path: Path) -> None:
    seq_file = tmp_path / "state" / "stream-seq"  # its folder is made
    book = StreamBook.create(seq_file=seq_file, lease=6)
    try:
        assert int(seq_file.read_text()) == 6, "the lease is written before the first seq is taken"
        for _ in range(40):
            seq = book.take_seq()
            assert int(seq_file.read_text()) > seq
        book.release_lease()  # a clean close: the next process goes on without a gap
        assert int(seq_file.read_text()) == 40 == book.peek_seq()
    finally:
        book.unlink()
    again = StreamBook.create(seq_file=seq_file, lease=6)
    try:
        assert again.take_seq() == 40
    finally:
        again.unlink()


@pytest.mark.parametrize("content", ["", "12x\n", "-5\n", "1.5\n", "\u00b2\n"])
def test_a_seq_file_that_holds_no_seq_number_is_refused_and_left_alone(tmp_path: Path, content: str) -> None:
    seq_file = tmp_path / "stream-seq"
    seq_file.write_text(content, encoding="utf-8")
    with pytest.raises(InputError, match="does not hold a seq number"):
        StreamBook.create(seq_file=seq_file)
    assert seq_file.read_text(encoding="utf-8") == content


def test_a_seq_file_that_cannot_be_written_again_is_said_once_and_the_stream_goes_on(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / "state"
    book = StreamBook.create(seq_file=folder / "stream-seq", lease=4)
    try:
        shutil.rmtree(folder)
        folder.write_text("a file where the folder was")  # the lease cannot be renewed now
        with caplog.at_level(logging.WARNING, logger="pipeline.runtime.stream"):
            seqs = [book.take_seq() for _ in range(30)]
        assert seqs == list(range(30)), "the stream goes on"
        said = [r for r in caplog.records if "cannot be written" in r.getMessage()]
        assert len(said) == 1, [r.getMessage() for r in said]
    finally:
        book.unlink()


def test_a_pipeline_closed_cleanly_is_followed_without_a_gap_and_a_handover_keeps_the_file_ahead(
    tmp_path: Path,
) -> None:
    """Real pipelines, a real UDP socket: a second server process's pipeline (the same seq file)
    goes on with the next seq; a pipeline that handed over leaves the file to its successor."""
    seq_file = tmp_path / "stream-seq"
    rx = DatagramRecorder()
    emitter = EmitterConfig(heartbeat_s=0.02, seq_file=seq_file)

    def build(handover: Handover | None = None) -> Pipeline:
        return Pipeline(RuntimeConfig(), None, workstations=[("127.0.0.1", rx.port)], emitter=emitter,
                        handover=handover)

    try:
        first = build()
        wait_until(lambda: len(rx.got) >= 5, "heartbeats of the first pipeline")
        handover = first.hand_over()
        second = build(handover)
        count = len(rx.got)
        wait_until(lambda: len(rx.got) >= count + 5, "heartbeats of the pipeline that took over")
        first.close()  # after its successor took over: it must not write its own, older, place back
        assert int(seq_file.read_text()) > max(m["seq"] for _, m in rx.got), "the file stays ahead"
        second.close()
        third = build()  # as a new server process does
        try:
            count = len(rx.got)
            wait_until(lambda: len(rx.got) >= count + 3, "heartbeats of the new server's pipeline")
        finally:
            third.close()
        seqs = [m["seq"] for _, m in rx.got]
        assert seqs == list(range(len(seqs))), f"one sequence across all three, no gap: {seqs}"
    finally:
        rx.close()
