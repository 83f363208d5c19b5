"""Sensor faults on the real stack: `zenav up` processes on a real router, the faults
scheduled in the simulated world (scenario.faults), the robot driving goals throughout.

One run of about a minute of stack time is recorded (diag, poses, truth, encoders,
goal ends); each test reads one fault's window from it: the services say they are
degraded while it lasts, the pose covariance grows where information is lost, the
bad samples are counted and dropped, and everything is back to normal after.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

import pytest

from tests.support.procs import Stack
from zenav.common.client import Unavailable
from zenav.services import NAMES
from zenav.services.navigator.controllers import sigmas

pytestmark = pytest.mark.system

START = 2**31 - 400  # [ticks] both encoders start here: they wrap within the first 0.3 m
JITTER = 0.12  # [s] +/- on the VPS latency at 10 Hz: fixes arrive out of order
WINDOWS = {  # [s] stack time (start, end) of each scheduled fault
    "duplicate": (10.0, 12.0),
    "future_stamp": (14.0, 14.05),
    "gyro_dead": (17.0, 21.0),
    "vps_outage": (25.0, 33.0),
    "encoder_frozen": (38.0, 41.0),
}
END = 46.0  # [s] stack time the recording stops
FAULTS = ", ".join(f'{{kind = "{k}", start = {a}, duration = {round(b - a, 3)}}}' for k, (a, b) in WINDOWS.items() if k != "vps_outage")
LAST_FIX = 0.5  # [s] after the outage starts, the fixes captured before it have all arrived (the VPS's ~0.3 s)
MAX_SIGMA = 0.015  # [m] navigator.max_position_sigma: above the outage's growth, below the frozen encoder's
GOALS = [(0.8, 0.0), (0.8, 0.6), (0.0, 0.6), (0.0, 0.0)]  # driven in a loop


@dataclass
class Recording:
    diag: dict[str, list] = field(default_factory=lambda: {s: [] for s in NAMES})
    poses: list = field(default_factory=list)  # (t, x, y, sigma_xy)
    truth: dict = field(default_factory=dict)  # round(t, 2) -> (x, y)
    ticks: list = field(default_factory=list)  # left counts
    ends: list = field(default_factory=list)  # nav/state of each ended goal
    odom_t: list = field(default_factory=list)

    def status(self, service: str, a: float, b: float) -> list:
        """(t, status, message) of the service's diag in [a, b)."""
        return [(d.t, d.status, d.message) for d in self.diag[service] if a <= d.t < b]

    def counter(self, service: str, name: str, at: float) -> int:
        """A diag counter's value in the newest diag before `at`."""
        before = [d for d in self.diag[service] if d.t < at]
        return before[-1].counters.get(name, 0) if before else 0

    def sigma(self, a: float, b: float) -> float:
        """Largest position sigma [m] of the poses in [a, b)."""
        return max(s for t, _, _, s in self.poses if a <= t < b)

    def error(self, a: float, b: float) -> float:
        """RMS pose error vs truth [m] in [a, b)."""
        errs = [
            (x - self.truth[round(t, 2)][0]) ** 2 + (y - self.truth[round(t, 2)][1]) ** 2
            for t, x, y, _ in self.poses
            if a <= t < b and round(t, 2) in self.truth
        ]
        return math.sqrt(sum(errs) / len(errs))


def drive(stack: Stack, done: threading.Event) -> None:
    """Send the goals in a loop, each after the previous one ended, until `done`."""
    c, k = stack.client, 0
    while not done.is_set():
        x, y = GOALS[k % len(GOALS)]
        try:
            rep = c.query("nav/move_to_point", {"x": x, "y": y}, timeout=5)
        except Unavailable:  # not ready (no fix yet, uncertain): on the next state
            stack.nav.wait(lambda s, t=stack.nav.msg.t if stack.nav.msg else -1: s.t > t, timeout=5)
            continue
        stack.nav.wait(lambda s, g=rep.goal_id: done.is_set() or (s.goal_id == g and s.result is not None), timeout=60)
        k += 1


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    extra = [
        "--set",
        f"scenario.faults=[{FAULTS}]",
        "--set",
        f"scenario.vps_jitter={JITTER}",
        "--set",
        f"scenario.vps_outage_start={WINDOWS['vps_outage'][0]}",
        "--set",
        f"scenario.vps_outage_duration={WINDOWS['vps_outage'][1] - WINDOWS['vps_outage'][0]}",
        "--set",
        f"sim.encoder_start={START}",
        "--set",
        f"navigator.max_position_sigma={MAX_SIGMA}",
        # The accelerometer would find the frozen encoder at once (the body keeps its speed, the odometry's halves)
        # and the covariance of the slip would abort each goal before the odometry can name the encoder: this run
        # is about the odometry's own finding (the accelerometer's: tests/unit/test_localizer_*.py).
        "--set",
        "localizer.impact_speed=0",
    ]
    stack = Stack(tmp_path_factory.mktemp("sensor_faults"), extra)
    r = Recording()
    c = stack.client
    for s in NAMES:
        c.subscribe(f"diag/{s}", r.diag[s].append)
    c.subscribe("pose", lambda p: r.poses.append((p.t, p.x, p.y, sigmas(p.cov)[0])))
    c.subscribe("sim/truth", lambda tr: r.truth.__setitem__(round(tr.t, 2), (tr.x, tr.y)))
    c.subscribe("sensors/encoders", lambda e: r.ticks.append(e.left))
    c.subscribe("odom", lambda o: r.odom_t.append(o.t))
    c.subscribe("nav/state", lambda s: s.result is not None and r.ends.append(s))
    done = threading.Event()
    driver = threading.Thread(target=drive, args=(stack, done), daemon=True)
    try:
        c.wait_alive(NAMES, timeout=90)
        driver.start()
        stack.truth.wait(lambda tr: tr.t >= END, timeout=END * 4)
    finally:
        done.set()
        driver.join(timeout=10)
        print(stack.close()[-3000:])
    return r


def during(window: str, lead: float = 0.0) -> tuple[float, float]:
    a, b = WINDOWS[window]
    return a + lead, b


def test_the_robot_drove_all_along(rec):
    succeeded = [e for e in rec.ends if e.result == "succeeded"]
    assert len(succeeded) >= 4, [(e.goal_id, e.result, e.message) for e in rec.ends]
    assert rec.error(3.0, 9.0) < 0.05 and rec.error(END - 4.0, END) < 0.05


def test_encoder_counts_wrap_without_a_reset(rec):
    assert max(rec.ticks) > 2**31 - 500 and min(rec.ticks) < -(2**31) + 500  # both ends of int32 seen
    assert rec.counter("odometry", "encoder_resets", WINDOWS["encoder_frozen"][0]) == 0
    assert rec.error(3.0, 9.0) < 0.05


def test_out_of_order_fixes_are_applied_at_their_capture_time(rec):
    assert rec.counter("localizer", "fixes_out_of_order", 9.0) > 5
    assert rec.error(3.0, 9.0) < 0.05


def test_duplicates_are_dropped_once_counted(rec):
    a, b = WINDOWS["duplicate"]
    assert rec.counter("odometry", "dropped_stale", b + 1.5) - rec.counter("odometry", "dropped_stale", a) > 100
    assert rec.counter("localizer", "fixes_duplicate", b + 1.5) > 5
    assert rec.error(a, b + 1.0) < 0.05


def test_far_future_stamps_are_dropped_and_time_goes_on(rec):
    a, b = WINDOWS["future_stamp"]
    for service in ("odometry", "localizer"):
        assert rec.counter(service, "dropped_future", b + 2.0) >= 3, service
    assert max(rec.odom_t) >= END - 1.0 and max(rec.odom_t) < END + 5.0  # odom went on, no stamp jumped ahead
    assert rec.error(b, b + 3.0) < 0.05


def test_a_dead_gyro_degrades_the_localizer_until_it_is_back(rec):
    a, b = WINDOWS["gyro_dead"]
    assert any(s == "degraded" and "gyro" in msg for _, s, msg in rec.status("localizer", a + 1.0, b + 0.5))
    assert all("gyro" not in msg for _, _, msg in rec.status("localizer", b + 1.5, b + 4.0))
    assert rec.error(a, b + 2.0) < 0.05


def test_a_vps_outage_grows_the_covariance_and_recovers(rec):
    a, b = WINDOWS["vps_outage"]
    assert any(s == "degraded" and "no VPS fix" in msg for _, s, msg in rec.status("localizer", a + 3.5, b))
    # From the last fix (captured before the outage, applied by LAST_FIX after its start) the sigma only grows.
    start, end, after = rec.sigma(a + LAST_FIX, a + LAST_FIX + 0.2), rec.sigma(b - 0.5, b), rec.sigma(b + 3.0, b + 4.0)
    print(f"vps outage: position sigma {start * 100:.2f} cm at its start, {end * 100:.2f} cm at its end, {after * 100:.2f} after")
    # Small: the calibrated odometry drifts little in 8 s, and the robot rests between goals
    # (each move holds zero before its final check), so how much depends on the driving. Not compared
    # with the sigma before the outage: its peaks between two fixes can be as large.
    assert end > start and after < end
    assert all("no VPS fix" not in msg for _, _, msg in rec.status("localizer", b + 2.0, b + 4.0))


def test_a_frozen_encoder_is_reported_and_the_covariance_grows(rec):
    a, b = WINDOWS["encoder_frozen"]
    assert any(s == "degraded" and "left encoder silent" in msg for _, s, msg in rec.status("odometry", a + 0.5, b + 0.5))
    assert rec.counter("odometry", "encoder_silent", b + 1.5) >= 1
    # the count jumps by what it missed when it comes back: a new baseline, not a leap of the robot
    assert rec.counter("odometry", "encoder_resets", b + 1.5) - rec.counter("odometry", "encoder_resets", a) == 1
    before, during_, after = rec.sigma(a - 2.0, a), rec.sigma(a + 0.5, b), rec.sigma(b + 2.0, b + 3.0)
    print(f"frozen encoder: position sigma {before * 100:.2f} cm before, {during_ * 100:.2f} cm during, {after * 100:.2f} after")
    assert during_ > 1.5 * before and after < during_
    assert all(s == "ok" for _, s, _ in rec.status("odometry", b + 1.5, END))


def test_the_navigator_aborts_a_goal_when_the_pose_is_too_uncertain(rec):
    a, b = WINDOWS["encoder_frozen"]
    doubted = [(e.t, e.message) for e in rec.ends if e.result == "aborted" and "too uncertain" in e.message]
    assert doubted and all(a <= t < b + 1.0 for t, _ in doubted), doubted
    after = [(x, y) for t, x, y, _ in rec.poses if t > b + 1.0]
    assert math.dist(after[0], after[-1]) > 0.3  # and drives again once the encoder is back
