"""The robot library against the real navigator on the in-memory bus, with a manual clock and a kinematic robot."""

import inspect
import math
import threading

import pytest

from tests.support.navigator import MAX_STEPS, World
from zenav import aio
from zenav.common.goalschema import GOALS
from zenav.robot import InvalidArgument, Robot, Unavailable, ZenavError


@pytest.fixture
def bot(world):
    with Robot("r1", bus=world) as r:
        yield r


def test_move_to_point_arrives_with_feedback_on_the_way(world, bot):
    goal = bot.move_to_point(0.3, 0.0, speed=0.2, tolerance=0.01)
    assert goal.reply.state == "MOVING_TO_POINT" and goal.reply.speed == 0.2 and not goal.done() and bot.is_moving()
    remaining = []
    world.drive(lambda: goal.done() or remaining.append(goal.feedback().distance_remaining))
    res = goal.wait(timeout=0)
    assert res.succeeded and res.message == "arrived" and res.goal_id == goal.id and goal.result() is res
    assert res.pose.x == pytest.approx(0.3, abs=0.01) and res.elapsed > 1.0
    assert remaining[0] > 0.25 and remaining[-1] < 0.02 and not bot.is_moving()
    assert str(res).startswith(f"goal {goal.id} succeeded: arrived at x +0.29") and str(res).endswith(f"after {res.elapsed:.1f} s")


def test_every_goal_kind(world, bot):
    for send in (
        lambda: bot.turn_to_heading(math.pi / 2, tolerance=0.02),
        lambda: bot.turn_to_point(0.0, -1.0),
        lambda: bot.move_straight(0.2, distance=0.1),
        lambda: bot.follow_path([(0.1, -0.1), (0.2, -0.1)], speed=0.15),
    ):
        goal = send()
        world.drive(goal.done)
        assert goal.result().succeeded, goal.result()
    assert [sorted(r) for r in world.goals_sent()] == [
        ["heading", "lease", "tolerance"],
        ["lease", "x", "y"],
        ["distance", "lease", "speed"],
        ["lease", "points", "speed"],
    ]
    assert world.goals_sent()[3]["points"] == [[0.1, -0.1], [0.2, -0.1]]


def test_a_goal_s_own_timeout_lead_and_waypoint_tolerance_reach_the_navigator_and_the_result_says_why_it_ended(world, bot):
    goal = bot.move_to_point(0.5, 0.0, speed=0.1, timeout=1.0)  # 5 s of driving cut at 1 s
    world.drive(goal.done)
    res = goal.result()
    assert res.result == "aborted" and res.exit == "timeout" and "exit timeout" in res.message and res.elapsed < 2.0
    goal = bot.move_to_pose(0.3, 0.2, math.pi / 2, lead=0.3, heading_tolerance=0.05, timeout=20.0)
    world.drive(goal.done)
    assert goal.result().succeeded and goal.result().exit in ("within_tolerance", "settled"), goal.result()
    goal = bot.follow_path([(0.4, 0.2), (0.4, 0.0, 0.02)], waypoint_tolerance=0.03, timeout=30.0)
    world.drive(goal.done)
    assert goal.result().succeeded, goal.result()
    first = bot.turn_to_heading(0.0, timeout=10.0)
    second = bot.turn_to_point(0.0, 0.0, timeout=10.0)
    world.drive(second.done)
    assert (first.result().result, first.result().exit) == ("cancelled", "cancelled") and second.result().succeeded
    sent = world.goals_sent()
    assert [r["timeout"] for r in sent] == [1.0, 20.0, 30.0, 10.0, 10.0]
    assert (sent[1]["lead"], sent[1]["heading_tolerance"], sent[2]["waypoint_tolerance"]) == (0.3, 0.05, 0.03)
    assert sent[2]["points"] == [[0.4, 0.2], [0.4, 0.0, 0.02]]


def test_forwards_false_backs_the_robot_and_is_sent_only_when_false(world, bot):
    goal = bot.move_to_point(-0.3, 0.0, forwards=False)  # behind the robot, which faces +x
    world.drive(goal.done)
    assert goal.result().succeeded and world.theta == pytest.approx(0.0, abs=0.05)  # backed straight there
    x, y = world.x, world.y
    goal = bot.turn_to_point(0.0, 1.0, forwards=False)
    world.drive(goal.done)
    assert goal.result().succeeded and world.theta == pytest.approx(math.atan2(1.0 - y, -x) - math.pi, abs=0.01)  # the back to it
    bot.follow_path([(-0.3, -0.3)], forwards=False).cancel()
    bot.move_to_pose(0.0, 0.0, 0.0, forwards=False).cancel()
    bot.move_to_point(0.0, 0.0).cancel()
    assert [r.get("forwards") for r in world.goals_sent()] == [False, False, False, False, None]


def test_wait_until_returns_once_the_robot_has_travelled_that_far_and_false_when_the_goal_ends_short(world, bot):
    goal = bot.follow_path([(0.3, 0.0), (0.3, 0.3)])  # round a corner: farther than the straight line
    world.hide_state = True  # no nav/state: only the pose that takes it past the mark can wake the program
    returned, woke = threading.Event(), []

    def drive():  # the world runs in this thread, and stands still once past the mark
        world.drive(lambda: goal.travelled >= 0.45)
        woke.append(returned.wait(10.0))

    driver = threading.Thread(target=drive)
    driver.start()
    assert goal.wait_until(0.45, timeout=30.0)
    returned.set()
    driver.join(30.0)
    assert woke == [True]  # woken by that pose, not by the timeout
    assert not goal.done() and 0.45 <= goal.travelled < 0.46 and world.y > 0.1  # 0.45 m of way, not of straight line
    world.hide_state = False
    world.drive(goal.done)
    assert goal.result().succeeded and 0.5 < goal.travelled < 0.6  # the corner cut within the waypoint tolerance
    assert not goal.wait_until(5.0, timeout=0.0) and goal.wait_until(0.3, timeout=0.0)  # ended short; passed long ago
    turn, start = bot.turn_to_heading(0.0), world.theta  # from about +90 deg, after the path
    world.drive(turn.done)
    assert turn.travelled == pytest.approx(start, abs=0.02) and start > 1.3  # radians turned
    held = bot.move_straight(0.1)
    with pytest.raises(TimeoutError, match=f"goal {held.id} travelled 0.000 of 0.100"):
        held.wait_until(0.1, timeout=0.01)
    held.cancel()


def test_chained_goals_hand_over_at_speed_as_lemlib_s_motion_chaining(world, bot):
    first = bot.move_to_point(0.4, 0.0, min_speed=0.1, early_exit_range=0.02)
    world.drive(first.done)
    second = bot.move_to_point(0.7, 0.2)  # sent as soon as the first ends, as a program does
    world.drive(second.done)
    assert (first.result().result, first.result().exit) == ("succeeded", "chained") and second.result().succeeded
    speeds = [c.v for c in world.published("cmd_vel")]
    moving = [i for i, v in enumerate(speeds) if v > 0.0]
    assert min(speeds[moving[0] : moving[-1] + 1]) > 0.0  # from the first goal's start to the second's last move, never a stop
    sent = world.goals_sent()
    assert (sent[0]["min_speed"], sent[0]["early_exit_range"]) == (0.1, 0.02) and "min_speed" not in sent[1]


def test_the_asyncio_robot_has_every_method_of_the_robot_with_the_same_parameters():
    for name in GOALS:  # one declaration (zenav.goalapi): the asyncio robot's returns a coroutine of its Goal
        assert getattr(Robot, name) is getattr(aio.AsyncRobot, name), name
    for name in ("wait_ready", "stop", "is_moving", "pose", "set_pose", "status"):
        assert inspect.iscoroutinefunction(getattr(aio.AsyncRobot, name)), name
        assert list(inspect.signature(getattr(Robot, name)).parameters) == list(inspect.signature(getattr(aio.AsyncRobot, name)).parameters)


def test_updates_yield_each_new_state_until_the_end(world, bot):
    goal = bot.follow_path([(0.1, 0.0), (0.1, 0.1)])
    states = []
    for _ in range(MAX_STEPS):
        world.step()
        states += list(_take(goal.updates(timeout=0.0)))
        if goal.done():
            break
    points = [s.next_point for s in states if s.result is None]
    assert points[0] == 0 and points[-1] == 1 and states[-1].result == "succeeded"


def _take(updates):
    """The updates available now (a TimeoutError means none came)."""
    try:
        yield from updates
    except TimeoutError:
        return


def test_a_newer_goal_preempts_and_cancel_stops_only_the_running_goal(world, bot):
    first = bot.move_to_point(1.0, 0.0)
    world.drive(lambda: world.x > 0.05)
    second = bot.turn_to_heading(1.0)
    res = first.wait(timeout=0)
    assert res.result == "cancelled" and res.message == f"preempted by goal {second.id}"
    assert not first.cancel() and not second.done() and bot.is_moving()
    assert second.cancel() and second.wait(timeout=0).result == "cancelled" and world.cmd == (0.0, 0.0)


def test_stop(world, bot):
    goal = bot.move_straight(0.1)
    world.drive(lambda: world.x > 0.02)
    assert bot.stop() == "STOPPED" and world.cmd == (0.0, 0.0)
    assert goal.wait(timeout=0).result == "cancelled" and not bot.is_moving()


def test_drive_stops_the_running_goal_then_commands_cmd_vel_for_its_time_and_zero_after(world, bot):
    goal = bot.move_straight(0.1)
    world.drive(lambda: world.x > 0.02)
    before = len(world.published("cmd_vel"))
    bot.drive(-0.1, 0.2, seconds=0.12)
    assert goal.wait(timeout=0).result == "cancelled"  # stopped before the first command
    sent = [(c.t, c.v, c.omega) for c in world.published("cmd_vel")[before:]]
    ours = [c for c in sent if c != (0.0, 0.0, 0.0)]
    assert len(ours) >= 2 and set(ours) == {(0.0, -0.1, 0.2)}  # t = 0: "now", as teleop's
    assert sent[-len(ours) - 1 :] == [*ours, (0.0, 0.0, 0.0)]  # one run of them, then zero


@pytest.mark.parametrize(("args", "field"), [((math.nan,), "v"), ((0.1, math.inf), "omega"), ((0.1, 0.0, -1.0), "seconds")])
def test_drive_refuses_a_number_that_is_not_finite_or_a_negative_time(world, bot, args, field):
    before = len(world.published("cmd_vel"))
    with pytest.raises(InvalidArgument, match=field):
        bot.drive(*args)
    assert len(world.published("cmd_vel")) == before  # nothing sent


def test_goals_carry_the_lease_and_closing_stops_the_robot(world):
    watcher = Robot("r1", bus=world, lease=False)
    bot = Robot("r1", bus=world)
    assert bot.lease_key.startswith("zenav/r1/lease/") and watcher.lease_key is None
    goal = bot.move_to_point(1.0, 0.0)
    assert world.goals_sent()[-1]["lease"] == bot.lease_key
    world.drive(lambda: world.x > 0.05)
    bot.close()
    world.step()
    st = watcher.status()
    assert st.goal_id == goal.id and st.result == "aborted" and world.cmd == (0.0, 0.0)
    watcher.move_to_point(0.0, 0.0)
    assert "lease" not in world.goals_sent()[-1]
    watcher.close()


def test_a_gone_navigator_aborts_the_goal(world, bot):
    goal = bot.move_straight(0.1)
    world.nav.close()  # withdraws its token
    res = goal.wait(timeout=0)
    assert res.result == "aborted" and res.message == "navigator gone"


def test_a_goal_that_ended_unseen_is_known_from_nav_status(world, bot):
    goal = bot.move_to_point(0.1, 0.0)
    world.hide_state = True
    world.drive(lambda: not world.nav.machine.active)
    assert not goal.done()
    assert goal.wait(timeout=0.01).result == "succeeded"


def test_wait_times_out(world, bot):
    goal = bot.move_straight(0.1)
    with pytest.raises(TimeoutError, match=f"goal {goal.id} did not end in 0.01 s"):
        goal.wait(timeout=0.01)


@pytest.mark.parametrize(
    "send, field",
    [
        (lambda bot: bot.move_to_point(math.nan, 0.0), "`$.x` is nan: a number must be finite"),
        (lambda bot: bot.move_to_point(0.0, 0.0, tolerance=-1.0), "$.tolerance"),
        (lambda bot: bot.follow_path([]), "$.points"),
        (lambda bot: bot.turn_to_heading(1.0, speed=0.0), "$.speed"),
        (lambda bot: bot.move_straight(0.0), "speed"),  # refused by the navigator
        (lambda bot: bot.turn_to_point(0.0, 0.0), "x, y"),  # where the robot is
    ],
)
def test_invalid_arguments_name_the_field(world, bot, send, field):
    with pytest.raises(InvalidArgument) as e:
        send(bot)
    assert e.value.code == "invalid_argument" and field in e.value.message
    assert isinstance(e.value, ZenavError) and isinstance(e.value, ValueError)


def test_set_pose_without_a_value_is_refused_before_sending(world, bot):
    with pytest.raises(InvalidArgument, match="x, y, theta: none given"):
        bot.set_pose()
    assert not [suffix for suffix, _ in world.sent if suffix == "localizer/set_pose"]


def test_no_pose_is_unavailable_and_not_ready():
    world = World()  # no pose published
    with Robot("r1", bus=world) as bot:
        with pytest.raises(Unavailable, match="no pose yet"):
            bot.move_to_point(1.0, 0.0)
        with pytest.raises(Unavailable, match="no pose in 0.01 s"):
            bot.pose(timeout=0.01)
        with pytest.raises(TimeoutError, match="navigator not ready after 0.05 s: no pose yet"):
            bot.wait_ready(timeout=0.05, services=["navigator"])
        with pytest.raises(TimeoutError, match="services not alive after 0.05 s: localizer, motor, odometry"):
            bot.wait_ready(timeout=0.05)
    world.nav.close()


def test_wait_ready_and_pose(world, bot):
    bot.wait_ready(timeout=1.0, services=["navigator"])  # the fresh pose the navigator has
    with pytest.raises(Unavailable):
        bot.pose(timeout=0.01)  # none since the robot connected
    world.step()
    assert bot.pose().t == world.clock.now()


def test_a_goal_refused_on_a_stale_pose_is_sent_again_on_the_next(world, bot):
    world.clock.advance(1.0)  # the newest pose is now stale

    def fresh_pose():
        assert world.refused.wait(5.0)
        for key, data in world.samples():  # the robot at rest where it started
            world.bus.publish(key, data)

    helper = threading.Thread(target=fresh_pose)
    helper.start()
    goal = bot.move_to_point(0.2, 0.0)
    helper.join(5.0)
    assert len(world.goals_sent()) == 2 and goal.reply.state == "MOVING_TO_POINT"


def test_bad_robot_id(world):
    with pytest.raises(InvalidArgument, match="robot"):
        Robot("no/such", bus=world)
