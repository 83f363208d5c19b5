"""How moves end: every exit reason, the tolerance as the exit, the re-check, poses, chaining, no swing."""

import math
import random

import pytest

from zenav.common import messages as m
from zenav.common.contract import Exit, GoalResult, State
from zenav.common.geometry import wrap_angle
from zenav.services.navigator import intake
from zenav.services.navigator.controllers import PoseSample, Wheelbase
from zenav.services.navigator.goals import Goal, GoalMachine
from zenav.services.navigator.params import Params

WHEELS = Wheelbase(0.1156, 0.03365, 10.0)
DT = 0.01  # [s] pose period
LAG = 0.06  # [s] first-order lag of the simulated motors (the default stop_lead)


def machine(**cfg):
    mc = GoalMachine(Params(**cfg), WHEELS)
    mc.on_pose(PoseSample(0.0, 0.0, 0.0, 0.0))
    return mc


def to_point(x, y, tol=0.01, **kw):
    return Goal(State.MOVING_TO_POINT, points=((x, y),), speed=0.2, tolerance=tol, **kw)


def still(mc, x, y, theta=0.0, until=10.0):
    """Poses at rest at (x, y, theta) every DT, checks every 5th, until the goal ends (bounded)."""
    for i in range(1, round(until / DT) + 1):
        t = round(i * DT, 6)
        _, end = mc.on_pose(PoseSample(t, x, y, theta))
        if end is None and i % 5 == 0:
            end = mc.check(t)
        if end is not None:
            return t, end
    raise AssertionError("the goal did not end")


class Unicycle:
    """A kinematic robot whose speeds follow the commands with a first-order lag; seeded pose noise."""

    def __init__(self, x=0.0, y=0.0, theta=0.0, noise=0.0, seed=0):
        self.x, self.y, self.theta, self.v, self.omega, self.t = x, y, theta, 0.0, 0.0, 0.0
        self.noise, self.rng = noise, random.Random(seed)

    def sample(self):
        n = self.noise
        g = self.rng.gauss
        return PoseSample(self.t, self.x + g(0, n), self.y + g(0, n), self.theta + g(0, n / 0.3), self.v, self.omega)

    def step(self, cmd):
        a = DT / LAG
        self.v += a * (cmd[0] - self.v)
        self.omega += a * (cmd[1] - self.omega)
        self.theta = wrap_angle(self.theta + self.omega * DT)
        self.x += self.v * math.cos(self.theta) * DT
        self.y += self.v * math.sin(self.theta) * DT
        self.t = round(self.t + DT, 6)


def drive(goal, bot=None, max_s=40.0, **cfg):
    """Run a goal on a Unicycle to its end: (end, steps, trace of (x, y, theta, v cmd, index))."""
    bot = bot or Unicycle()
    mc = GoalMachine(Params(**cfg), WHEELS)
    mc.on_pose(bot.sample())
    mc.start(goal, bot.t)
    trace = []
    for step in range(round(max_s / DT)):
        cmd, end = mc.on_pose(bot.sample())
        if end is None and step % 5 == 0:
            end = mc.check(bot.t)
        if end is not None:
            return end, step, trace, bot
        trace.append((bot.x, bot.y, bot.theta, cmd[0], mc.feedback(bot.t).next_point))
        bot.step(cmd)
    raise AssertionError("the goal did not end")


def run_on(mc, bot, max_s=20.0):
    """Drive the machine's running goal on `bot` until it ends (bounded): (the last command, the End, every command)."""
    cmds = []
    for _ in range(round(max_s / DT)):
        cmd, end = mc.on_pose(bot.sample())
        cmds.append(cmd)
        if end is not None:
            return cmd, end, cmds
        bot.step(cmd)
    raise AssertionError("the goal did not end")


# ---------------------------------------------------------------- each exit reachable
def test_within_tolerance_ends_the_move_and_the_recheck_passes():
    end, *_ = drive(to_point(1.0, 0.0))
    assert (end.result, end.exit, end.message) == (GoalResult.SUCCEEDED, Exit.WITHIN_TOLERANCE, "arrived")


def test_settled_a_small_error_held():
    mc = machine(settle_error=0.02, settle_time=0.5, big_time=5.0, rest_time=0.2)
    mc.start(to_point(1.0, 0.0), 0.0)
    t, end = still(mc, 0.985, 0.0)  # 1.5 cm short, not moving closer
    assert end.exit == Exit.SETTLED and end.result == GoalResult.ABORTED and t == pytest.approx(0.5 + 0.2, abs=0.03)
    assert "1.50 cm from the goal (tolerance 1.00 cm): exit settled" in end.message
    assert mc.exit == Exit.SETTLED


def test_big_error_a_large_error_held():
    mc = machine(big_error=0.05, big_time=1.5, rest_time=0.2)
    mc.start(to_point(1.0, 0.0), 0.0)
    t, end = still(mc, 0.97, 0.0)  # 3 cm short: outside settle_error, inside big_error
    assert end.exit == Exit.BIG_ERROR and end.result == GoalResult.ABORTED and t == pytest.approx(1.5 + 0.2, abs=0.03)


def test_timeout_stops_the_move_then_rechecks():
    mc = machine(rest_time=0.2)
    mc.start(to_point(1.0, 0.0, timeout=1.0), 0.0)
    t, end = still(mc, 0.5, 0.0)
    assert end.exit == Exit.TIMEOUT and end.result == GoalResult.ABORTED and t == pytest.approx(1.0 + 0.2, abs=0.011)
    assert mc.on_pose(PoseSample(t + DT, 0.5, 0.0, 0.0)) == (None, None)


def test_config_goal_timeout_applies_to_goals_naming_none():
    mc = machine(goal_timeout=0.5, rest_time=0.0)
    mc.start(to_point(1.0, 0.0), 0.0)
    t, end = still(mc, 0.5, 0.0)
    assert end.exit == Exit.TIMEOUT and t == pytest.approx(0.5, abs=0.011)


def test_stalled_no_progress_aborts_at_once():
    mc = machine(progress_timeout=2.0)
    mc.start(to_point(1.0, 0.0), 0.0)
    t, end = still(mc, 0.0, 0.0)
    assert end.exit == Exit.STALLED and end.result == GoalResult.ABORTED and "no progress" in end.message and t == pytest.approx(2.05)


def test_passed_a_point_abeam_outside_the_tolerance():
    mc = machine(retries=0)
    mc.start(to_point(1.0, 0.0), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.01, 0.95, 0.004, 0.0))  # locked: drives along its heading
    assert cmd[0] > 0 and cmd[1] == 0.0
    cmd, end = mc.on_pose(PoseSample(0.02, 1.001, 0.012, 0.0))  # past abeam, 1.2 cm off
    assert cmd == (0.0, 0.0) and end is None
    _, end = still(mc, 1.001, 0.012)
    assert end.exit == Exit.PASSED and end.result == GoalResult.ABORTED


@pytest.mark.parametrize("how, exit", [("cancel", Exit.CANCELLED), ("abort", Exit.ABORTED)])
def test_cancelled_and_aborted(how, exit):
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    assert getattr(mc, how)("why").exit == exit and mc.exit == exit


def test_succeeded_only_if_the_recheck_is_within_tolerance():
    """A turn whose coast ends past a tight tolerance is not a success."""
    mc = machine(rest_time=0.1, retries=0)
    mc.start(Goal(State.TURNING_TO_HEADING, heading=0.5, speed=2.0, tolerance=math.radians(0.1)), 0.0)
    mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.49))  # the coast is predicted to reach it: the turn stops
    _, end = still(mc, 0.0, 0.0, theta=0.5 + math.radians(0.2))  # it coasted 0.2 deg past
    assert end.result == GoalResult.ABORTED and "0.20 deg off the heading (tolerance 0.10 deg)" in end.message


def test_a_recheck_over_the_tolerance_moves_again_a_bounded_number_of_times():
    """A late fix moves the pose after the stop: the move corrects, `retries` times at most."""
    mc = machine(rest_time=0.1, retries=1)
    mc.start(to_point(1.0, 0.0), 0.0)
    assert mc.on_pose(PoseSample(0.01, 0.995, 0.0, 0.0)) == ((0.0, 0.0), None)  # within: the move stops
    cmd, end = mc.on_pose(PoseSample(0.12, 0.98, 0.0, 0.0))  # the re-check finds it 2 cm short
    assert end is None and cmd[0] > 0 and mc.active  # moving again
    assert mc.on_pose(PoseSample(0.13, 0.995, 0.0, 0.0)) == ((0.0, 0.0), None)
    _, end = mc.on_pose(PoseSample(0.24, 0.97, 0.0, 0.0))  # over again: no retry left
    assert end.result == GoalResult.ABORTED and end.exit == Exit.WITHIN_TOLERANCE and "3.00 cm from the goal" in end.message


def test_a_backwards_move_corrects_backwards():
    """The re-check of a backwards move finds it 2 cm short: it backs on, and the next re-check ends it."""
    mc = machine(rest_time=0.1, retries=1)
    mc.on_pose(PoseSample(0.0, 0.0, 0.0, math.pi))  # facing -x: (1, 0) is behind it
    mc.start(to_point(1.0, 0.0, backwards=True), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.005, 0.5, 0.0, math.pi))
    assert cmd[0] < 0.0  # backing
    assert mc.on_pose(PoseSample(0.01, 0.995, 0.0, math.pi)) == ((0.0, 0.0), None)  # within: the move stops
    cmd, end = mc.on_pose(PoseSample(0.12, 0.98, 0.0, math.pi))  # the re-check finds it 2 cm short
    assert end is None and cmd[0] < 0.0 and cmd[1] == 0.0  # backing on, straight
    assert mc.on_pose(PoseSample(0.13, 0.998, 0.0, math.pi)) == ((0.0, 0.0), None)
    _, end = mc.on_pose(PoseSample(0.24, 0.998, 0.0, math.pi))
    assert end.result == GoalResult.SUCCEEDED


def test_a_recheck_finding_the_point_sideways_turns_to_face_it_then_drives_onto_it():
    """A late fix moves the pose 2 cm sideways after the stop: straight on cannot reach it; a turn in place then a drive does."""
    mc = machine(rest_time=0.1, retries=1)
    mc.start(to_point(1.0, 0.0), 0.0)
    assert mc.on_pose(PoseSample(0.01, 0.995, 0.0, 0.0)) == ((0.0, 0.0), None)  # within: the move stops
    cmd, end = mc.on_pose(PoseSample(0.12, 1.0, -0.02, 0.0))  # the re-check finds the point 2 cm to the left
    assert end is None and cmd[0] == 0.0 and cmd[1] > 0.0  # turning in place toward it
    bot = Unicycle(x=1.0, y=-0.02)
    bot.t = 0.12
    for _ in range(round(10.0 / DT)):
        bot.step(cmd)
        cmd, end = mc.on_pose(bot.sample())
        if end is not None:
            break
    assert end is not None and end.result == GoalResult.SUCCEEDED, end
    assert math.hypot(1.0 - bot.x, bot.y) <= 0.01 and abs(bot.theta) > math.radians(30)  # it turned: not straight on


def test_a_sideways_offset_the_estimates_noise_explains_is_not_chased_by_a_turn():
    """1.2 cm off the line on a pose whose sigma is 0.6 cm: corrected straight on (no swing), then judged."""
    mc = machine(rest_time=0.1, retries=1)
    mc.start(to_point(1.0, 0.0), 0.0)
    assert mc.on_pose(PoseSample(0.01, 0.995, 0.0, 0.0, sigma_xy=0.006)) == ((0.0, 0.0), None)
    cmd, end = mc.on_pose(PoseSample(0.12, 0.98, -0.012, 0.0, sigma_xy=0.006))
    assert end is None and cmd[0] > 0.0 and cmd[1] == 0.0  # straight on


# ---------------------------------------------------------------- the tolerance trades precision for time
def test_a_larger_tolerance_ends_sooner():
    steps, errors = [], []
    for tol in (0.2, 0.05, 0.01):
        end, n, _, bot = drive(to_point(1.0, 0.0, tol=tol))
        assert end.result == GoalResult.SUCCEEDED and end.exit == Exit.WITHIN_TOLERANCE
        steps.append(n)
        errors.append(math.hypot(1.0 - bot.x, bot.y))
    assert steps[0] < steps[1] < steps[2] and steps[2] - steps[0] > 50  # at least 0.5 s saved
    assert all(e <= tol for e, tol in zip(errors, (0.2, 0.05, 0.01))) and errors[0] > 0.1


# ---------------------------------------------------------------- move_to_pose
@pytest.mark.parametrize("controller", ["polar", "boomerang"])
@pytest.mark.parametrize("x, y, theta", [(1.0, 0.5, math.pi / 2), (0.8, -0.4, 0.0), (0.5, 0.5, math.pi)])
def test_move_to_pose_arrives_with_the_heading(controller, x, y, theta):
    goal = Goal(State.MOVING_TO_POSE, points=((x, y),), heading=theta, speed=0.2, tolerance=0.01, heading_tolerance=0.0087, lead=0.6)
    end, _, _, bot = drive(goal, pose_controller=controller)
    assert end.result == GoalResult.SUCCEEDED, end.message
    assert math.hypot(x - bot.x, y - bot.y) <= 0.01 and abs(wrap_angle(theta - bot.theta)) <= 0.0087


def test_move_to_pose_refuses_unstable_polar_gains_naming_the_equation():
    req = m.MoveToPose(x=1.0, y=0.0, theta=0.0)
    with pytest.raises(intake.Invalid, match="eq. 8"):
        intake.move_to_pose(req, Params(k_rho=3.0, k_alpha=2.9, k_beta=-0.1, pose_controller="polar"))
    with pytest.raises(intake.Invalid, match="eq. 9"):
        intake.move_to_pose(req, Params(k_rho=3.0, k_alpha=3.5, k_beta=-1.5, pose_controller="polar"))
    intake.move_to_pose(req, Params(k_rho=3.0, k_alpha=3.5, k_beta=-1.5, pose_controller="boomerang"))  # gains unused


# ---------------------------------------------------------------- chaining
def test_a_path_keeps_moving_through_its_points():
    path = ((0.5, 0.0), (1.0, 0.0), (1.0, 0.5), (0.5, 0.5))
    end, _, trace, _ = drive(Goal(State.FOLLOWING_PATH, points=path, speed=0.2, tolerance=0.01))
    assert end.result == GoalResult.SUCCEEDED
    between = [v for *_, v, i in trace if i is not None and 0 < i < len(path) - 1]
    assert len(between) > 100 and min(between) > 0.03  # never stopped: only the turn limit scales the through speed down


def test_a_missed_intermediate_point_is_turned_to_in_place_not_orbited():
    mc = machine()
    path = Goal(State.FOLLOWING_PATH, points=((0.5, 0.0), (1.0, 0.0)), speed=0.2, tolerance=0.01, point_tolerances=(0.01, 0.01))
    mc.start(path, 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.01, 0.6, 0.02, 0.0))  # past the first point, 2 cm beside it
    assert mc.feedback(0.01).next_point == 0 and cmd[0] == 0.0 and cmd[1] != 0.0


def test_each_point_may_carry_its_own_tolerance():
    goal, info = intake.follow_path(m.FollowPath(points=[(0.5, 0.0, 0.1), (1.0, 0.0), (1.0, 0.5)], waypoint_tolerance=0.02), Params())
    assert goal.point_tolerances == (0.1, 0.02, 0.01) and goal.tolerance == 0.01 and info["waypoint_tolerance"] == 0.02
    with pytest.raises(intake.Invalid, match=r"points\[1\]"):
        intake.follow_path(m.FollowPath(points=[(0.5, 0.0), (1.0, 0.0, -0.1)]), Params())


def test_a_chained_move_ends_at_speed_on_its_exit_line_and_holds_its_command_for_the_next_goal():
    """LemLib's motion chaining: min_speed 0.1 m/s, early_exit_range 3 cm; the next goal takes over at speed."""
    bot = Unicycle()
    mc = GoalMachine(Params(chain_time=0.2), WHEELS)
    mc.on_pose(bot.sample())
    mc.start(to_point(1.0, 0.0, min_speed=0.1, early_exit_range=0.03), bot.t)
    cmd, end, cmds = run_on(mc, bot)
    assert (end.result, end.exit, end.stop) == (GoalResult.SUCCEEDED, Exit.CHAINED, False)
    assert 0.97 <= bot.x < 0.975  # on the line 3 cm before the point (one pose past it at most)
    assert min(v for v, _ in cmds[50:]) >= 0.1  # never below min_speed once under way, nor zeroed at the end
    assert mc.state == State.STOPPED and mc.coasting
    bot.step(cmd)
    held, _ = mc.on_pose(bot.sample())
    assert held == cmd  # still driving, no goal running
    mc.start(to_point(1.5, 0.0), bot.t)  # the next goal, within chain_time
    nxt, _ = mc.on_pose(bot.sample())
    assert nxt[0] >= 0.1 and not mc.coasting  # it took over at speed


def test_a_chained_move_with_no_next_goal_stops_after_chain_time_and_a_stop_ends_the_hold_at_once():
    bot = Unicycle(x=0.9)
    mc = GoalMachine(Params(chain_time=0.2), WHEELS)
    mc.on_pose(bot.sample())
    mc.start(to_point(1.0, 0.0, min_speed=0.1), bot.t)
    cmd, end, _ = run_on(mc, bot)
    assert end.exit == Exit.CHAINED and cmd[0] >= 0.1
    held = []
    for _ in range(40):
        bot.step(cmd or (0.0, 0.0))
        cmd, _ = mc.on_pose(bot.sample())
        held.append(cmd)
    last, n = held[0], held.index((0.0, 0.0))
    assert held[:n] == [last] * n and last[0] >= 0.1 and n in (19, 20)  # held chain_time (0.2 s: 19 or 20 poses, as t rounds)
    assert held[n + 1] is None and not mc.coasting  # then zero, once: no goal, nothing more
    mc.start(to_point(1.5, 0.0, min_speed=0.1), bot.t)
    run_on(mc, bot)
    assert mc.coasting and mc.cancel("stopped") is None and not mc.coasting  # nav/stop: no goal, and the hold is gone


def test_a_chained_turn_keeps_its_min_speed_and_ends_early_exit_range_before_the_heading():
    bot = Unicycle()
    mc = GoalMachine(Params(), WHEELS)
    mc.on_pose(bot.sample())
    mc.start(Goal(State.TURNING_TO_HEADING, heading=1.5, speed=2.0, tolerance=0.0175, min_speed=1.0, early_exit_range=0.1), bot.t)
    cmd, end, cmds = run_on(mc, bot)
    assert end.exit == Exit.CHAINED and end.result == GoalResult.SUCCEEDED and not end.stop
    assert 1.4 <= bot.theta <= 1.42 and min(w for _, w in cmds) >= 1.0 and cmd == cmds[-2]  # one pose past 0.1 rad before, at most


def test_a_chained_goal_that_starts_within_its_early_exit_range_ends_on_the_next_pose_and_a_pose_reached_wrong_way_round_stops():
    mc = machine()
    mc.start(to_point(0.02, 0.0, min_speed=0.1, early_exit_range=0.03), 0.0)  # 2 cm ahead: within the 3 cm
    cmd, end = mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0))
    assert (end.result, end.exit) == (GoalResult.SUCCEEDED, Exit.CHAINED) and cmd == (0.0, 0.0)  # it held what it had: nothing
    turn = Goal(State.TURNING_TO_HEADING, heading=0.05, speed=2.0, tolerance=0.0175, min_speed=1.0, early_exit_range=0.1)
    mc.start(turn, 0.02)
    assert mc.on_pose(PoseSample(0.03, 0.0, 0.0, 0.0))[1].exit == Exit.CHAINED
    # A pose at (0.5, 0) facing -x, from the origin facing +x: the robot reaches the point without crossing the line
    # across that heading, so it cannot pass through the pose at speed: it ends as an unchained move (turn, stop, re-check).
    pose = Goal(State.MOVING_TO_POSE, ((0.5, 0.0),), math.pi, 0.2, 0.01, heading_tolerance=0.0175, lead=0.6, min_speed=0.1)
    end, *_, bot = drive(pose)
    assert (end.result, end.exit) == (GoalResult.SUCCEEDED, Exit.WITHIN_TOLERANCE) and end.stop
    assert math.hypot(bot.x - 0.5, bot.y) <= 0.01 and abs(wrap_angle(bot.theta - math.pi)) <= 0.0175


@pytest.mark.parametrize("way, heading", [(1, -math.pi / 2), (-1, math.pi / 2), (1, math.pi / 2), (-1, -2.0)])
def test_a_turn_told_its_direction_turns_that_way_round_the_long_way_if_need_be(way, heading):
    """LemLib's AngularDirection: ccw to -90 deg from 0 turns 270 deg counter-clockwise; near the end, the shorter way."""
    bot = Unicycle()
    mc = GoalMachine(Params(), WHEELS)
    mc.on_pose(bot.sample())
    mc.start(Goal(State.TURNING_TO_HEADING, heading=heading, speed=2.0, tolerance=0.0175, direction=way), bot.t)
    long_way = (heading * way) % math.tau  # [rad] how far round that way
    assert mc.feedback(bot.t).distance_remaining == pytest.approx(long_way)
    _, end, cmds = run_on(mc, bot)
    turned = [w * way for _, w in cmds[:-1]]
    assert end.result == GoalResult.SUCCEEDED and abs(wrap_angle(bot.theta - heading)) <= 0.0175
    assert min(turned[: round(0.8 * len(turned))]) > 0.0 and sum(turned) * DT == pytest.approx(long_way, abs=0.1)  # that way round


def test_a_turn_told_its_direction_that_overshoots_turns_back_not_round_again():
    mc = machine()
    mc.start(Goal(State.TURNING_TO_HEADING, heading=-math.pi / 2, speed=2.0, tolerance=0.0175, direction=1), 0.0)  # ccw, 270 deg
    mc.on_pose(PoseSample(0.01, 0.0, 0.0, -math.pi / 2 - 0.5, omega=2.0))  # 0.5 rad to go, counter-clockwise
    cmd, _ = mc.on_pose(PoseSample(0.02, 0.0, 0.0, -math.pi / 2 + 0.05, omega=2.0))  # 0.05 rad past it
    assert cmd[1] <= 0.0 and mc.feedback(0.02).distance_remaining == pytest.approx(0.05)  # back the short way, not round again


def test_a_turn_told_its_direction_but_already_there_does_not_go_round():
    mc = machine()
    mc.start(Goal(State.TURNING_TO_HEADING, heading=-0.01, speed=2.0, tolerance=0.0175, direction=1), 0.0)
    cmd, end = mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0))
    assert cmd == (0.0, 0.0) and mc.feedback(0.01).distance_remaining == pytest.approx(0.0)  # within its tolerance: stopped


def test_early_exit_range_without_min_speed_is_refused():
    with pytest.raises(intake.Invalid, match="early_exit_range: only a chained move"):
        intake.move_to_point(m.MoveToPoint(x=1.0, y=0.0, early_exit_range=0.02), Params())
    goal, info = intake.turn_to_heading(m.TurnToHeading(heading=1.0, min_speed=9.0), Params())
    assert goal.min_speed == goal.speed == info["min_speed"] and info["early_exit_range"] == 0.0  # min_speed: at most the speed


# ---------------------------------------------------------------- no heading swing on arrival
@pytest.mark.parametrize("seed", range(5))
def test_no_heading_swing_in_the_last_5_cm(seed):
    bot = Unicycle(noise=0.002, seed=seed)
    end, _, trace, bot = drive(to_point(1.0, 0.05 * (seed - 2)), bot)
    last = [th for x, y, th, *_ in trace if math.hypot(bot.x - x, bot.y - y) <= 0.05]
    swing = max(abs(wrap_angle(th - last[0])) for th in last + [bot.theta])
    assert len(last) > 5 and math.degrees(swing) < 2.0
