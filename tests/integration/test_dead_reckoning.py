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
TURN_TOLERANCE = math.radians(2.0)  # [rad] a turn is done this close to its heading

# A world that is exactly the nominal robot: no error source at all.
PERFECT = dict(
    wheel_radius_err_left=0.0,
    wheel_radius_err_right=0.0,
    track_width_err=0.0,
    slip_sigma=0.0,
    load_radius_err=0.0,
    ticks_per_rev=100_000,
    motor_deadband=0.0,
    gyro_bias_dps=0.0,
    gyro_noise_dps=0.0,
    gyro_scale_err=0.0,
    accel_bias=0.0,
    accel_noise=0.0,
    compass_noise_deg=0.0,
)


def drive_square(client, timeout: float = 120.0):
    """Drive a 1 m square (4 x straight then 90 deg left) on odom, then stop; return (odoms, truth by t).

    Each leg aims at an absolute odom-frame corner or heading, so a late command
    (a loaded host) costs only time: the next leg corrects any overshoot.
    """
    odoms: queue.Queue = queue.Queue()
    truth: dict[float, m.Truth] = {}
    client.subscribe("odom", odoms.put)
    client.subscribe("sim/truth", lambda msg: truth.__setitem__(round(msg.t, 6), msg))
    corners = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]
    legs = [leg for i, c in enumerate(corners) for leg in (("straight", i, c), ("turn", i + 1, None))]
    seen: list[m.Odom] = []
    deadline = time.monotonic() + timeout
    while True:
        assert time.monotonic() < deadline, f"square not finished in {timeout} s; {len(legs)} legs left"
        seen.append(odoms.get(timeout=10.0))
        while not odoms.empty():  # act on the newest pose only, never on a backlog
            seen.append(odoms.get_nowait())
        o = seen[-1]
        cmd = m.CmdVel(t=o.t, v=0.0, omega=0.0)
        while legs:
            kind, i, corner = legs[0]
            heading_err = wrap_angle(i * math.pi / 2 - o.theta)
            if kind == "straight":
                left = (corner[0] - o.x) * math.cos(i * math.pi / 2) + (corner[1] - o.y) * math.sin(i * math.pi / 2)
                if left > 0.0:
                    v = min(SPEED, max(0.03, SLOW_DOWN * left))
                    cmd = m.CmdVel(t=o.t, v=v, omega=SLOW_DOWN * heading_err)
                    break
            elif abs(heading_err) > TURN_TOLERANCE:
                omega = math.copysign(min(TURN_RATE, max(0.3, SLOW_DOWN * abs(heading_err))), heading_err)
                cmd = m.CmdVel(t=o.t, v=0.0, omega=omega)
                break
            legs.pop(0)
        client.publish("cmd_vel", cmd)
        tr = truth.get(round(o.t, 6))
        if not legs and tr is not None and abs(tr.v) < 1e-3 and abs(tr.omega) < 1e-2:
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
    # the robot really went around and stopped: back near the start after ~4 m of travel
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
