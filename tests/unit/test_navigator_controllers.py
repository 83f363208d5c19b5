"""The point trackers on a pure kinematic robot (no noise, no lag)."""

import math

import pytest

from zenav.common.geometry import wrap_angle
from zenav.services.navigator import controllers
from zenav.services.navigator.controllers import PoseSample, Wheelbase, check_polar_gains, make_target
from zenav.services.navigator.params import CONTROLLERS, Params

WHEELS = Wheelbase(track=0.1156, radius=0.03365, max_wheel_speed=10.0)
DT = 0.01  # [s]


def drive(name, start, goal, speed=0.2, seconds=30.0):
    """Integrate the controller's commands until within 5 mm of the goal; the path taken."""
    params, ctrl = Params(controller=name), controllers.make(name)
    x, y, th = start
    target = make_target(PoseSample(0.0, x, y, th), goal[0], goal[1], speed, allow_reverse=name == "polar")
    path, v, w = [], 0.0, 0.0
    for i in range(round(seconds / DT)):
        if math.hypot(goal[0] - x, goal[1] - y) < 0.005:
            break
        v, w = controllers.limit(*ctrl(PoseSample(i * DT, x, y, th, v, w), target, params), params.max_turn_speed, WHEELS)
        path.append((x, y, th, v, w))
        x += v * math.cos(th + w * DT / 2) * DT
        y += v * math.sin(th + w * DT / 2) * DT
        th = wrap_angle(th + w * DT)
    return (x, y, th), path


STARTS = [(0.0, 0.0, 0.0), (0.0, 0.0, math.pi / 2), (2.0, 1.0, 0.0), (1.0, -1.0, -2.5), (0.5, 0.5, 3.0)]


@pytest.mark.parametrize("name", CONTROLLERS)
@pytest.mark.parametrize("start", STARTS)
def test_each_controller_converges(name, start):
    (x, y, _), path = drive(name, start, (1.0, 0.5))
    assert math.hypot(x - 1.0, y - 0.5) < 0.005, f"{name} from {start} stopped at {(x, y)}"
    assert max(abs(v) for *_, v, _ in path) <= 0.2 + 1e-9


def test_polar_reverses_to_a_goal_behind():
    (x, y, th), path = drive("polar", (0.0, 0.0, 0.0), (-0.6, 0.1))
    assert math.hypot(x + 0.6, y - 0.1) < 0.005
    assert all(v < 0 for *_, v, _ in path) and abs(th) < 0.5  # backed up, never turned round


@pytest.mark.parametrize("name", ["pid", "proportional"])
def test_forward_trackers_turn_round_for_a_goal_behind(name):
    (x, y, _), path = drive(name, (0.0, 0.0, 0.0), (-0.6, 0.1))
    assert math.hypot(x + 0.6, y - 0.1) < 0.005
    assert all(v >= 0 for *_, v, _ in path) and abs(path[0][3]) < 1e-9  # turns in place first


def test_pid_limits_forward_speed_while_the_heading_error_is_large():
    params = Params()
    ctrl = controllers.RotationPid()
    target = controllers.Target(0.0, 1.0, math.pi / 2, 0.2)
    v_far_off, _ = ctrl(PoseSample(0.0, 0.0, 0.0, 0.0), target, params)  # goal 90 deg to the left
    v_half, _ = controllers.RotationPid()(PoseSample(0.0, 0.0, 0.0, math.pi / 2 - 0.5), target, params)
    v_on, _ = controllers.RotationPid()(PoseSample(0.0, 0.0, 0.0, math.pi / 2), target, params)
    assert v_far_off == 0.0 and v_half == pytest.approx(0.1) and v_on == pytest.approx(0.2)


def test_pid_integral_is_bounded():
    params, ctrl = Params(), controllers.RotationPid()
    target = controllers.Target(0.0, 1.0, math.pi / 2, 0.2)
    for i in range(1000):
        ctrl(PoseSample(i * 0.1, 0.0, 0.0, 0.0), target, params)
    assert ctrl.integral == pytest.approx(params.pid_i_limit)


def test_speed_near_the_goal_stays_above_the_minimum():
    params = Params()
    target = controllers.Target(0.012, 0.0, 0.0, 0.2)
    for name in CONTROLLERS:
        v, _ = controllers.make(name)(PoseSample(0.0, 0.0, 0.0, 0.0), target, params)
        assert v >= params.crawl_speed, name


def test_stable_gains_pass_the_strong_condition():
    check_polar_gains(3.0, 8.0, -1.5)
    p = Params()
    check_polar_gains(p.k_rho, p.k_alpha, p.k_beta)


@pytest.mark.parametrize(
    "gains, equation",
    [
        ((0.0, 8.0, -1.5), "eq. 8"),
        ((3.0, 8.0, 0.5), "eq. 8"),
        ((-1.0, 8.0, -1.5), "eq. 8"),
        ((3.0, 2.9, -0.1), "eq. 8"),  # meets eq. 9's margin (0.92 > 0) but k_alpha < k_rho: the linearised system is unstable
        ((3.0, 3.5, -1.5), "eq. 9"),  # meets eq. 8 but not the strong condition
    ],
)
def test_unstable_gains_are_refused_naming_them_and_the_equation(gains, equation):
    with pytest.raises(ValueError) as e:
        check_polar_gains(*gains)
    text = str(e.value)
    assert all(f"{n}={g:g}" in text for n, g in zip(("k_rho", "k_alpha", "k_beta"), gains))
    assert f"({equation})" in text


def test_the_boomerang_carrot_slides_onto_the_goal():
    far = controllers.carrot(PoseSample(0.0, 0.0, 0.0, 0.0), 1.0, 0.0, math.pi / 2, 0.5)
    assert far == pytest.approx((1.0, -0.5))  # half the distance behind the goal along its heading
    assert controllers.carrot(PoseSample(0.0, 1.0, 0.0, 0.0), 1.0, 0.0, 0.0, 0.5) == pytest.approx((1.0, 0.0))


def test_limit_keeps_the_curvature_under_the_wheel_and_turn_limits():
    v, w = controllers.limit(0.5, 2.0, 3.0, WHEELS)
    fastest = (abs(v) + abs(w) * WHEELS.track / 2) / WHEELS.radius
    assert fastest == pytest.approx(10.0) and w / v == pytest.approx(4.0)
    v, w = controllers.limit(0.0, -6.0, 3.0, WHEELS)
    assert (v, w) == (0.0, -3.0)
    assert controllers.limit(0.1, 0.2, 3.0, WHEELS) == (0.1, 0.2)


def test_make_target_reverses_only_when_allowed_and_behind():
    pose = PoseSample(0.0, 0.0, 0.0, 0.0)
    assert make_target(pose, -1.0, 0.0, 0.2, True).reverse
    assert make_target(pose, -1.0, 0.0, 0.2, True).theta == pytest.approx(0.0)
    assert not make_target(pose, -1.0, 0.0, 0.2, False).reverse
    assert not make_target(pose, 1.0, 0.9, 0.2, True).reverse


def test_a_pid_per_target():
    assert controllers.make("pid") is not controllers.make("pid")
