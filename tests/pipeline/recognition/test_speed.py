"""Speed from stepping in place, on the simulator's stepping (ground-truth intended speed known)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.recognition.speed import (
    SpeedConfig,
    cadence_sps,
    gap_filled,
    leg_heights,
    rising_crossings,
    speed_from_heights,
    speed_mps,
)
from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment


@pytest.mark.parametrize("action", ["forward", "left", "right"])
@pytest.mark.parametrize("cadence", [1.3, 2.2])
def test_speed_follows_the_cadence(action: str, cadence: float) -> None:
    motion = simulate_user(
        MotionScript((Segment(action, 5.0, cadence_steps_per_s=cadence),)),
        body_from_height(1.75),
        30.0,
        seed=3,
    )
    got = [speed_mps(motion.joints_m[i - 75 : i], 30.0, action, SpeedConfig()) for i in range(90, 150, 15)]
    truth = float(motion.speed_mps[120])
    assert truth > 0
    np.testing.assert_allclose(got, truth, rtol=0.08, err_msg=f"{action} at {cadence} steps/s")


def test_faster_stepping_is_faster() -> None:
    speeds = []
    for cadence in (1.2, 1.6, 2.0, 2.4):
        m = simulate_user(
            MotionScript((Segment("forward", 4.0, cadence_steps_per_s=cadence),)), body_from_height(1.6), 30.0
        )
        speeds.append(speed_mps(m.joints_m[-75:], 30.0, "forward", SpeedConfig()))
    assert speeds == sorted(speeds) and speeds[0] < speeds[-1], f"speeds {speeds}"


def test_still_is_zero_and_few_steps_give_the_default_cadence() -> None:
    m = simulate_user(MotionScript((Segment("still", 3.0),)), body_from_height(1.8), 30.0)
    cfg = SpeedConfig()
    assert speed_mps(m.joints_m, 30.0, "still", cfg) == 0.0
    # a standing person "classified" forward: no steps seen -> default cadence, not 0 or a wild value
    assert speed_mps(m.joints_m, 30.0, "forward", cfg) == pytest.approx(
        cfg.default_cadence_sps * cfg.forward_step_m
    )


@pytest.mark.parametrize("action", ["forward", "left", "right"])
def test_the_streams_leg_heights_give_exactly_the_speed_of_the_frames(action: str) -> None:
    motion = simulate_user(
        MotionScript((Segment(action, 4.0, cadence_steps_per_s=1.7),)), body_from_height(1.7), 30.0, seed=5
    )
    frames = motion.joints_m[30:105].copy()
    frames[20:24, 13:17] = np.nan  # knees and ankles lost for four frames
    frames[40, 15, 2] = np.nan
    heights = np.array([leg_heights(f) for f in frames])
    left, right = gap_filled(heights[:, 0]), gap_filled(heights[:, 1])
    want = speed_mps(frames, 30.0, action, SpeedConfig())
    assert want > 0
    assert speed_from_heights(left, right, 30.0, action, SpeedConfig()) == want
    assert not np.isfinite(heights[20:24]).any() and np.isfinite(left).all()


def test_rising_crossings_ignore_noise_inside_the_dead_band() -> None:
    t = np.arange(90) / 30.0
    sig = np.sin(2 * np.pi * 1.0 * t) + np.random.default_rng(0).normal(0, 0.05, t.size)
    times = rising_crossings(sig, 30.0)
    # the wave starts at its mid-level rising: that first rise is not armed, the next two count
    assert len(times) == 2, f"one rise per period of a 1 Hz wave over 3 s, got {times}"
    np.testing.assert_allclose(np.diff(times), 1.0, atol=0.07)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"forward_step_m": 0.0}, "forward_step_m"),
        ({"amplitude_range": (1.5, 0.5)}, "amplitude_range"),
        ({"default_cadence_sps": 5.0}, "cadence"),
        ({"amplitude_gain": -1.0}, "amplitude_gain"),
    ],
)
def test_bad_config(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SpeedConfig(**kwargs)  # type: ignore[arg-type]


def test_unknown_action() -> None:
    with pytest.raises(ValueError, match="action"):
        speed_mps(np.zeros((30, 17, 3)), 30.0, "jump", SpeedConfig())


def test_the_cadence_is_the_median_interval_between_crossings_within_the_bounds() -> None:
    """cadence_sps: steps per crossing over the median interval (the middle one, or the mean of the
    middle two), clipped to the configured range; the default with fewer than two crossings."""
    config = SpeedConfig()
    rng = np.random.default_rng(8)
    for n in range(2, 30):
        times = np.sort(rng.uniform(0.0, 3.0, n))
        want = np.clip(1.5 / np.median(np.diff(times)), config.min_cadence_sps, config.max_cadence_sps)
        assert cadence_sps(times, 1.5, config) == float(want)
    assert cadence_sps(np.array([0.0, 1.0, 3.0, 3.125]), 1.0, config) == 1.0  # intervals 1, 2, 1/8
    assert cadence_sps(np.array([0.0, 0.25, 1.0]), 1.0, config) == 2.0  # the mean of 1/4 and 3/4
    assert cadence_sps(np.array([0.0, 0.01]), 1.0, config) == config.max_cadence_sps
    assert cadence_sps(np.array([0.0, 30.0]), 1.0, config) == config.min_cadence_sps
    assert cadence_sps(np.array([1.0]), 1.0, config) == config.default_cadence_sps
