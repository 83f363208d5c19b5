"""sim + motor + odometry on a real router: a test drives a 1 m square through cmd_vel."""
from __future__ import annotations

import math
import queue
import time

import pytest

from zenav.common import messages as m
from zenav.common.geometry import wrap_angle

RTF = 2.0  # the stack follows the sim's clock, so it runs faster than realtime unchanged
SPEED = 0.2  # [m/s] top speed of a straight leg
TURN_RATE = 1.0  # [rad/s] top rate of a turn
SLOW_DOWN = 4.0  # [1/s] speed = remaining * SLOW_DOWN near a leg's end: a late command overshoots little

# A world that is exactly the nominal robot: no error source at all.
PERFECT = dict(
    wheel_radius_err_left=0.0, wheel_radius_err_right=0.0, track_width_err=0.0, slip_sigma=0.0,
    load_radius_err=0.0, ticks_per_rev=100_000, motor_deadband=0.0, gyro_bias_dps=0.0, gyro_noise_dps=0.0,
    gyro_scale_err=0.0, accel_bias=0.0, accel_noise=0.0, compass_noise_deg=0.0,
)


def drive_square(client, timeout: float = 120.0):
    """Drive 4 x (1 m straight, 90 deg left) judged by odom; return (odom list, truth by t)."""
    odoms: queue.Queue = queue.Queue()
    truth: dict[float, m.Truth] = {}
    client.subscribe("odom", odoms.put)
    client.subscribe("sim/truth", lambda msg: truth.__setitem__(round(msg.t, 6), msg))
    seen = []
    legs = [("straight", 1.0), ("turn", math.pi / 2)] * 4
    start = None
    deadline = time.monotonic() + timeout
    while legs:
        assert time.monotonic() < deadline, f"square not finished in {timeout} s; {len(legs)} legs left"
        o = odoms.get(timeout=10.0)
        seen.append(o)
        if start is None:
            start = o
        kind, amount = legs[0]
        if kind == "straight" and math.hypot(o.x - start.x, o.y - start.y) >= amount:
            legs.pop(0)
            start = o
        elif kind == "turn" and abs(wrap_angle(o.theta - start.theta)) >= amount:
            legs.pop(0)
            start = o
        if legs:
            kind, amount = legs[0]
            if kind == "straight":
                left = amount - math.hypot(o.x - start.x, o.y - start.y)
                cmd = m.CmdVel(t=o.t, v=min(SPEED, max(0.03, SLOW_DOWN * left)), omega=0.0)
            else:
                left = amount - abs(wrap_angle(o.theta - start.theta))
                cmd = m.CmdVel(t=o.t, v=0.0, omega=min(TURN_RATE, max(0.3, SLOW_DOWN * left)))
        else:
            cmd = m.CmdVel(t=o.t, v=0.0, omega=0.0)
        client.publish("cmd_vel", cmd)
    return seen, truth


def final_error(odoms, truth):
    for o in reversed(odoms):
        tr = truth.get(round(o.t, 6))
        if tr is not None:
            return math.hypot(o.x - tr.x, o.y - tr.y), abs(wrap_angle(o.theta - tr.theta)), tr
    raise AssertionError("no truth sample matches any odom t")


@pytest.mark.parametrize("scenario, max_err, min_err", [("perfect", 0.01, 0.0), ("default", 0.15, 0.002)])
def test_square_odometry_error_is_what_the_scenario_explains(make_stack, client, scenario, max_err, min_err):
    overrides = {"sim": {"rtf": RTF}}
    if scenario == "perfect":
        overrides["scenario"] = PERFECT
    make_stack(["sim", "motor", "odometry"], **overrides)
    client.wait_alive(["sim", "motor", "odometry"], timeout=20.0)
    odoms, truth = drive_square(client)
    err, dth, tr = final_error(odoms, truth)
    # the robot really went around: back near the start after ~4 m of travel
    assert math.hypot(tr.x, tr.y) < 0.5
    assert min_err <= err <= max_err, f"{scenario}: odom vs truth {err * 100:.2f} cm"
    assert dth < math.radians(10.0)


def test_odom_carries_the_encoder_sample_time(make_stack, client):
    make_stack(["sim", "odometry"], sim={"rtf": RTF})
    client.wait_alive(["sim", "odometry"], timeout=20.0)
    enc_t, odom_t = set(), []
    client.subscribe("sensors/encoders", lambda e: enc_t.add(e.t))
    odoms: queue.Queue = queue.Queue()
    client.subscribe("odom", odoms.put)
    for i in range(110):  # about a second of sim time
        o = odoms.get(timeout=10.0)
        assert o.frame == "odom"
        if i >= 10:  # the first few may come from samples sent before our subscription was routed
            odom_t.append(o.t)
    client.latest("sensors/encoders").wait(lambda e: e.t >= odom_t[-1], timeout=10.0)
    assert odom_t == sorted(odom_t)
    assert set(odom_t) <= enc_t  # each odom is stamped with the encoder sample it came from
