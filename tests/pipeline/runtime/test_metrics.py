"""Live counters: percentiles, rates, the dynamic frame rate, queues that drop the oldest."""

from __future__ import annotations

import math
import multiprocessing as mp

import numpy as np
import pytest

from pipeline.runtime.messages import WorkerEvent, drain_latest, put_latest
from pipeline.runtime.metrics import AdaptiveRate, LatencyWindow, RateMeter, RuntimeMetrics, ema, percentiles


def test_percentiles_match_numpy() -> None:
    values = np.random.default_rng(0).exponential(5.0, 1000)
    got = percentiles(values)
    assert got["p50"] == pytest.approx(np.percentile(values, 50))
    assert got["p99"] == pytest.approx(np.percentile(values, 99))
    assert all(math.isnan(v) for v in percentiles([]).values())


def test_latency_window_slides() -> None:
    w = LatencyWindow(size=10)
    for v in range(100):
        w.add(float(v))
    assert w.values() == [float(v) for v in range(90, 100)], "only the last 10 samples"
    assert w.count == 100
    assert w.summary()["p50"] == pytest.approx(94.5)


def test_rate_meter() -> None:
    r = RateMeter(window_s=2.0)
    for i in range(61):
        r.tick(i / 30.0)
    assert r.rate(2.0) == pytest.approx(30.0, rel=0.02)
    assert r.rate(100.0) == 0.0, "nothing in the window"


def test_runtime_metrics_counts() -> None:
    m = RuntimeMetrics(window=5)
    m.frame(1.0, {"detect": 3.0, "end_to_end": 8.0, "unknown": 1.0}, dropped=2)
    m.frame(1.1, {"detect": 5.0, "end_to_end": 9.0}, dropped=0)
    assert (m.processed, m.dropped) == (2, 2)
    assert m.latency_summary()["detect"]["p50"] == pytest.approx(4.0)


@pytest.mark.parametrize(("busy", "period"), [(0.001, 1 / 30), (0.1, 0.11), (0.0, 1 / 30)])
def test_adaptive_rate(busy: float, period: float) -> None:
    assert AdaptiveRate(30.0).period_s(busy) == pytest.approx(period)


@pytest.mark.parametrize(("fps", "headroom"), [(0.0, 1.1), (30.0, 0.9)])
def test_adaptive_rate_rejects(fps: float, headroom: float) -> None:
    with pytest.raises(ValueError, match="target_fps"):
        AdaptiveRate(fps, headroom)


def test_ema() -> None:
    assert ema(None, 4.0) == 4.0
    assert ema(4.0, 8.0, alpha=0.25) == pytest.approx(5.0)


def test_bounded_queue_drops_the_oldest() -> None:
    q = mp.get_context("spawn").Queue(maxsize=2)
    try:
        dropped = sum(put_latest(q, i) for i in range(5))
        assert dropped == 3
        import time

        time.sleep(0.1)  # the feeder thread flushes
        first = q.get(timeout=2)
        newest, skipped = drain_latest(q, first)
        assert (newest, skipped) == (4, 1), "the two newest survive; drain hands the newest"
    finally:
        q.close()
        q.join_thread()


def test_worker_event_kind_checked() -> None:
    with pytest.raises(ValueError, match="kind must be one of"):
        WorkerEvent("w", "exploded")  # type: ignore[arg-type]
