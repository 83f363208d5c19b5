"""The scenario's scheduled faults: what the world does to its samples and fixes at time t.

gyro_dead: no IMU sample; encoder_frozen: the left encoder count holds;
duplicate: every encoder and IMU sample and every VPS fix is sent twice;
future_stamp: samples and fixes are stamped FUTURE_OFFSET seconds ahead;
a VPS outage loses every capture inside it. Pure: time comes in as t.
"""

from __future__ import annotations

from typing import NamedTuple

from zenav.common.scenarios import Fault, Scenario

FUTURE_OFFSET = 1000.0  # [s] how far ahead a `future_stamp` fault stamps its samples


def active(faults: tuple[Fault, ...], t: float) -> frozenset[str]:
    """The kinds of fault under way at time t [s]."""
    return frozenset(f.kind for f in faults if f.start <= t < f.start + f.duration)


class Effect(NamedTuple):
    """What the faults do to the samples taken (or fixes captured) at one instant."""

    stamp: float  # [s] the t the samples carry
    copies: int  # how many times each sample is sent
    imu: bool  # whether the IMU sample is sent at all
    freeze_left: bool  # whether the left encoder count holds


def at(scenario: Scenario, t: float) -> Effect:
    """The faults' effect on what is sampled at t [s]."""
    if not scenario.faults:
        return Effect(t, 1, True, False)
    kinds = active(scenario.faults, t)
    return Effect(
        stamp=t + FUTURE_OFFSET if "future_stamp" in kinds else t,
        copies=2 if "duplicate" in kinds else 1,
        imu="gyro_dead" not in kinds,
        freeze_left="encoder_frozen" in kinds,
    )


def vps_outage_window(scenario: Scenario) -> tuple[float, float] | None:
    """(start, end) [s] of the camera's outage, None when it has none."""
    start = scenario.vps_outage_start
    return None if start is None else (start, start + scenario.vps_outage_duration)


def vps_outage(scenario: Scenario, t: float) -> bool:
    """Whether the camera is out at t [s] (every capture lost)."""
    window = vps_outage_window(scenario)
    return window is not None and window[0] <= t < window[1]


class EncoderHold:
    """The left count an encoder_frozen fault holds: the count when the fault began."""

    def __init__(self) -> None:
        self.held: int | None = None  # [ticks] while frozen

    def apply(self, effect: Effect, left: int) -> int:
        """The left count to send under `effect` for the true count `left` [ticks]."""
        if not effect.freeze_left:
            self.held = None
            return left
        if self.held is None:
            self.held = left
        return self.held
