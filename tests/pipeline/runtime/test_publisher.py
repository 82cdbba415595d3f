"""The live status, pushed (issue 16 item 4): one typed status to every subscriber on the
publisher's clock; the pipeline publishes its start and stop at once."""

from __future__ import annotations

import threading
import time

import pytest

from pipeline.runtime.pipeline import Pipeline
from pipeline.runtime.publisher import StatusPublisher
from pipeline.runtime.status import PipelineStatus
from tests.waiting import wait_until

from .live import wait_for


class Built:
    """A status builder that counts its calls (each status carries its number in ``processed``)."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self) -> PipelineStatus:
        self.calls += 1
        return PipelineStatus("running", processed=self.calls)


class Collected:
    def __init__(self) -> None:
        self.statuses: list[PipelineStatus] = []
        self.threads: list[str] = []

    def on_status(self, status: PipelineStatus) -> None:
        self.statuses.append(status)
        self.threads.append(threading.current_thread().name)


class Broken:
    def on_status(self, status: PipelineStatus) -> None:
        raise RuntimeError("a subscriber that fails")


def test_nothing_is_built_without_a_subscriber() -> None:
    built = Built()
    publisher = StatusPublisher(built, rate_hz=10.0)
    publisher.publish_now()
    publisher.close()
    assert built.calls == 0, "nobody listens: no status is built"


def test_the_publisher_s_clock_pushes_the_status_whether_or_not_anything_changed() -> None:
    built, got = Built(), Collected()
    publisher = StatusPublisher(built, rate_hz=50.0)
    publisher.subscribe(got)
    wait_until(lambda: len(got.statuses) >= 3, "three statuses on the publisher's clock")
    publisher.close()
    assert [s.processed for s in got.statuses] == list(range(1, len(got.statuses) + 1)), (
        "in order, each built once")
    assert set(got.threads) == {"cavewalk-status"}, "on the publisher's own thread"
    with pytest.raises(RuntimeError, match="closed"):
        publisher.subscribe(Collected())


def test_publish_now_is_synchronous_and_a_failing_subscriber_stops_nobody() -> None:
    built, got, later = Built(), Collected(), Collected()
    publisher = StatusPublisher(built, rate_hz=0.01)  # a period of 100 s: the clock is not due again here
    publisher.subscribe(Broken())
    publisher.subscribe(got)
    wait_until(lambda: len(got.statuses) == 1, "the first status at once")
    publisher.publish_now()  # on this thread, before it returns, whatever the period
    # the newest build, the one after the first; that first may be build 2 (the clock's first
    # status can go out to the broken subscriber alone, before ``got`` subscribed)
    first = got.statuses[0].processed
    assert [s.processed for s in got.statuses] == [first, first + 1] and built.calls == first + 1
    assert got.threads[-1] == threading.current_thread().name
    publisher.subscribe(later)  # a new subscriber gets its first status at once
    wait_until(lambda: len(later.statuses) == 1, "the new subscriber's first status")
    assert len(got.statuses) == 3
    publisher.unsubscribe(got)
    publisher.publish_now()
    assert len(got.statuses) == 3 and len(later.statuses) == 2, "unsubscribed: no more statuses"
    publisher.close()


@pytest.mark.slow
def test_the_pipeline_pushes_typed_statuses_from_start_to_stop(sim_pipeline: Pipeline) -> None:
    got = Collected()
    sim_pipeline.subscribe(got)
    sim_pipeline.start("simulator")
    assert got.statuses and got.statuses[-1].state in ("starting", "running"), (
        "the start's status is pushed before start() returns")
    wait_for(lambda: any(s.state == "running" and s.people3d for s in got.statuses), 60,
             "a pushed status with the simulated people")
    running = next(s for s in got.statuses if s.state == "running" and s.people3d)
    assert running.source == "simulator" and [c.name for c in running.cameras] == [
        "cam01", "cam02", "cam03", "cam04"]
    assert all(s.joints_m.shape == (17, 3) for s in running.people3d), "the 3D view gets arrays"
    assert {p.user_id for p in running.people} == {s.user_id for s in running.people3d}
    sim_pipeline.stop()
    assert got.statuses[-1].state == "stopped", "the stop's status is pushed before stop() returns"
    stamps = [s.timestamp_s for s in got.statuses]
    assert stamps == sorted(stamps), "statuses arrive in the order they were made"


def test_a_subscriber_that_comes_while_a_status_is_being_built_gets_its_first_at_once() -> None:
    """The clock's thread takes the subscribers, then waits for a publish under way (a start's
    ``publish_now``); one who subscribes meanwhile is not in that round, and still gets a status at
    once after it (before, that round reset the clock and the newcomer waited a whole period)."""
    release, building = threading.Event(), threading.Event()

    class Slow(Built):
        def __call__(self) -> PipelineStatus:
            if self.calls == 1:  # the second build: the publish_now below, held
                building.set()
                release.wait(30)
            return super().__call__()

    first, second, late = Collected(), Collected(), Collected()
    publisher = StatusPublisher(Slow(), rate_hz=0.01)  # a period of 100 s
    try:
        publisher.subscribe(first)
        wait_until(lambda: len(first.statuses) == 1, "the first subscriber's first status")
        now = threading.Thread(target=publisher.publish_now)
        now.start()
        assert building.wait(30), "publish_now is building (and holds the publish)"
        publisher.subscribe(second)  # the clock's thread takes (first, second), then waits
        time.sleep(0.2)
        publisher.subscribe(late)  # not in that round
        release.set()
        now.join(30)
        wait_until(lambda: late.statuses, "the late subscriber's first status", timeout_s=20)
        assert second.statuses and len(first.statuses) >= 3
    finally:
        release.set()
        publisher.close()
