"""The navigation commands of `zenav`: arguments, requests, output and exit codes, on a fake stack."""

import math

import msgpack
import pytest

from zenav.cli import nav, watch
from zenav.cli.checks import Failed
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE, build_parser
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.bus import Subscribed
from zenav.common.client import Client, Internal, InvalidArgument, Unavailable


class Handle:
    def __init__(self, table, entry):
        self.table, self.entry = table, entry

    def undeclare(self):
        if self.entry in self.table:
            self.table.remove(self.entry)


class FakeBus:
    """The stack's side of the wire from a table: each query's reply (or error to answer),
    and the nav/state and pose messages published while a query is answered."""

    def __init__(self, answers, states=(), poses=()):
        self.answers, self.states, self.poses = answers, list(states), list(poses)
        self.sent, self.subs, self.tokens, self.watchers = [], [], [], []
        self.subscribed, self.tokens_during_query = [], None
        self.closed = False

    def publish(self, key, data):
        for k, cb in list(self.subs):
            if k == key:
                cb(key, data)

    def subscribe(self, key, cb):
        self.subscribed.append(key)
        self.subs.append((key, cb))
        return Handle(self.subs, self.subs[-1])

    def newest(self, key):
        return Subscribed(self, key)

    def token(self, key):
        self.tokens.append(key)
        return Handle(self.tokens, key)

    def watch_tokens(self, key, cb):
        self.watchers.append((key, cb))
        return Handle(self.watchers, self.watchers[-1])

    def get(self, selector, payload=None, timeout=5.0, urgent=False):
        robot, suffix = selector.split("/", 2)[1:]
        self.sent.append((suffix, msgpack.unpackb(payload) if payload else None, timeout))
        self.tokens_during_query = list(self.tokens)
        for suffix_, msgs in (("nav/state", self.states), ("pose", self.poses)):
            for msg in msgs:
                self.publish(f"zenav/{robot}/{suffix_}", codec.encode(msg))
        answer = self.answers[suffix]
        if isinstance(answer, Exception):
            return [(False, codec.encode(m.ErrorReply(error=answer.code, message=answer.message)))]
        return [(True, codec.encode(answer))]

    def close(self):
        self.closed = True

    def withdrawn(self):
        """Whether every subscription, watch and token was taken back."""
        return self.subs == [] and self.watchers == [] and self.tokens == []


def parse(*argv):
    return build_parser().parse_args(list(argv))


def run(argv, answers, states=(), poses=()):
    """Run a command on a Robot over a FakeBus (the session nav.open_robot opens, as `zenav` does)."""
    bus = FakeBus(answers, states, poses)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nav, "open_bus", lambda args: bus)
        code = nav.run(parse(*argv))
    return code, bus


ACCEPTED = m.GoalReply(goal_id=7, state="MOVING_TO_POINT", speed=0.2)


@pytest.mark.parametrize(
    "argv, suffix, request_",
    [
        (["goto", "1", "-0.5"], "nav/move_to_point", {"x": 1.0, "y": -0.5}),
        (
            ["goto", "1", "2", "--speed", "0.1", "--tolerance", "0.02"],
            "nav/move_to_point",
            {"x": 1.0, "y": 2.0, "speed": 0.1, "tolerance": 0.02},
        ),
        (["turn", "1.5"], "nav/turn_to_heading", {"heading": 1.5}),
        (
            ["turn", "90", "--deg", "--tolerance", "2", "--speed", "45"],
            "nav/turn_to_heading",
            {"heading": math.pi / 2, "tolerance": math.radians(2), "speed": math.pi / 4},
        ),
        (["face", "0", "1"], "nav/turn_to_point", {"x": 0.0, "y": 1.0}),
        (["straight", "-0.1"], "nav/move_straight", {"speed": -0.1}),
        (["straight", "0.2", "--distance", "0.5"], "nav/move_straight", {"speed": 0.2, "distance": 0.5}),
        (["path", "1,0", "1,1", "--speed", "0.15"], "nav/follow_path", {"points": [[1.0, 0.0], [1.0, 1.0]], "speed": 0.15}),
        (["path", "--", "-1,0", "0,-1.5"], "nav/follow_path", {"points": [[-1.0, 0.0], [0.0, -1.5]]}),
        (["goto", "1", "0", "--backwards"], "nav/move_to_point", {"x": 1.0, "y": 0.0, "forwards": False}),
        (["turn", "-90", "--deg", "--direction", "ccw"], "nav/turn_to_heading", {"heading": -math.pi / 2, "direction": "ccw"}),
        (["face", "1", "1", "--direction", "cw"], "nav/turn_to_point", {"x": 1.0, "y": 1.0, "direction": "cw"}),
        (["swing", "90", "left", "--deg"], "nav/swing_to_heading", {"heading": math.pi / 2, "side": "left"}),
        (["face", "0", "1", "--backwards"], "nav/turn_to_point", {"x": 0.0, "y": 1.0, "forwards": False}),
        (["path", "1,0", "1,1", "--backwards"], "nav/follow_path", {"points": [[1.0, 0.0], [1.0, 1.0]], "forwards": False}),
    ],
)
def test_commands_send_the_contract_request(argv, suffix, request_, capsys):
    code, bus = run(argv, {suffix: ACCEPTED})
    assert code == EXIT_OK
    [(sent, req, timeout)] = bus.sent
    assert sent == suffix and req.keys() == request_.keys() and timeout == nav.QUERY_TIMEOUT  # no lease without --wait
    assert all(req[k] == (v if k == "points" else pytest.approx(v)) for k, v in request_.items())
    assert "goal 7 MOVING_TO_POINT" in capsys.readouterr().out and bus.withdrawn()


def test_clamped_speed_is_shown(capsys):
    code, _ = run(["goto", "1", "0", "--speed", "9"], {"nav/move_to_point": m.GoalReply(goal_id=1, state="MOVING_TO_POINT", speed=0.3)})
    assert code == EXIT_OK and "at 0.30 m/s" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, request_",
    [
        (["set-pose", "0.5", "-1"], {"x": 0.5, "y": -1.0}),
        (["set-pose", "0", "0", "90", "--deg"], {"x": 0.0, "y": 0.0, "theta": math.pi / 2}),
    ],
)
def test_set_pose(argv, request_, capsys):
    code, bus = run(argv, {"localizer/set_pose": m.PoseStamped(t=1.0, x=0.5, y=-1.0, theta=0.0)})
    [(sent, req, _)] = bus.sent
    assert code == EXIT_OK and sent == "localizer/set_pose" and req == pytest.approx(request_)
    assert "pose set: x +0.500 y -1.000" in capsys.readouterr().out


def test_stop(capsys):
    code, bus = run(["stop", "--robot", "r2"], {"nav/stop": m.StopReply(state="STOPPED")})
    assert code == EXIT_OK and bus.sent[0][0] == "nav/stop" and "STOPPED" in capsys.readouterr().out
    assert bus.subscribed == ["zenav/r2/pose", "zenav/r2/nav/state"] and bus.withdrawn()


@pytest.mark.parametrize("moving", [True, False])
def test_drive_stops_a_running_goal_then_commands_cmd_vel_for_its_time_and_zero(moving, capsys):
    idle = {"state": "STOPPED", "goal_id": 0, "goal": None, "result": None, "distance_remaining": None, "pose": None}
    status = m.StatusReply(**{**idle, "is_moving": moving})
    bus = FakeBus({"nav/status": status, "nav/stop": m.StopReply(state="STOPPED")})
    commands = []
    bus.subs.append(("zenav/r1/cmd_vel", lambda key, data: commands.append(codec.decode(data, m.CmdVel))))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nav, "open_bus", lambda args: bus)
        code = nav.run(parse("drive", "-0.1", "0.5", "--for", "0.06"))
    assert code == EXIT_OK and [q for q, _, _ in bus.sent] == ["nav/status", *(["nav/stop"] if moving else [])]
    assert len(commands) >= 2 and set(commands[:-1]) == {m.CmdVel(t=0.0, v=-0.1, omega=0.5)}
    assert commands[-1] == m.CmdVel(t=0.0, v=0.0, omega=0.0)
    assert "then stopped" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv",
    [
        ["drive", "0.1"],  # no --for
        ["drive", "0.1", "--for", "0"],
        ["drive", "nan", "--for", "1"],
        ["goto", "1"],
        ["goto", "one", "2"],
        ["goto", "nan", "0"],
        ["path"],
        ["path", "1;0"],
        ["path", "1,0,2"],
        ["turn"],
        ["straight"],
        ["fly"],
    ],
)
def test_bad_arguments_are_usage_errors(argv):
    with pytest.raises(SystemExit) as e:
        parse(*argv)
    assert e.value.code == EXIT_USAGE


@pytest.mark.parametrize(
    "error, code",
    [
        (InvalidArgument("x: out of range"), EXIT_USAGE),
        (Unavailable("no pose yet"), EXIT_UNAVAILABLE),
        (Internal("boom"), EXIT_FAILED),
    ],
)
def test_error_replies_map_to_exit_codes(error, code, capsys):
    got, _ = run(["goto", "1", "0"], {"nav/move_to_point": error})
    assert got == code and error.message in capsys.readouterr().err


def test_bad_values_are_refused_before_sending(capsys):
    got, bus = run(["goto", "1", "0", "--tolerance", "-1"], {})
    assert got == EXIT_USAGE and bus.sent == [] and "$.tolerance" in capsys.readouterr().err


def test_no_router_is_unavailable(capsys):
    def refuse(args):
        raise Failed(EXIT_UNAVAILABLE, "no Zenoh router at tcp/127.0.0.1:1 (Timeout!)")

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nav, "open_bus", refuse)
        assert nav.run(parse("goto", "1", "0")) == EXIT_UNAVAILABLE
    assert capsys.readouterr().err == "zenav goto: no Zenoh router at tcp/127.0.0.1:1 (Timeout!)\n"


def progress_states():
    return [
        m.NavState(t=1.0, state="MOVING_TO_POINT", goal_id=3, distance_remaining=0.8, eta=4.0, elapsed=0.5),
        m.NavState(t=2.0, state="STOPPED", goal_id=3, result="succeeded", elapsed=5.0),
    ]


@pytest.mark.parametrize("result, code", [("succeeded", EXIT_OK), ("cancelled", EXIT_FAILED), ("aborted", EXIT_FAILED)])
def test_wait_holds_a_lease_and_maps_the_result(result, code, capsys):
    accepted = m.GoalReply(goal_id=3, state="MOVING_TO_POINT", speed=0.2)
    running, ended = progress_states()
    ended = m.NavState(t=2.0, state="STOPPED", goal_id=3, result=result, message="arrived" if result == "succeeded" else "why")
    pose = m.Pose(t=2.0, x=1.0, y=0.0, theta=0.0, v=0.0, omega=0.0)
    got, bus = run(["goto", "1", "0", "--wait"], {"nav/move_to_point": accepted}, [running, ended], [pose])
    assert got == code
    [(_, req, timeout)] = bus.sent
    assert "wait" not in req and req["lease"].startswith("zenav/r1/lease/") and timeout == nav.QUERY_TIMEOUT
    assert bus.tokens_during_query == [req["lease"]] and bus.withdrawn()  # held until the command ends
    out = capsys.readouterr()
    assert f"goal 3 {result}" in out.out and "x +1.000" in out.out and "after 1.5 s" in out.out
    assert "goal 3" in out.err  # the progress line


def test_wait_ends_with_a_preempting_goal(capsys):
    accepted = m.GoalReply(goal_id=3, state="MOVING_TO_POINT", speed=0.2)
    other = m.NavState(t=2.0, state="TURNING_TO_HEADING", goal_id=4)
    got, _ = run(["goto", "1", "0", "--wait"], {"nav/move_to_point": accepted}, [progress_states()[0], other])
    assert got == EXIT_FAILED and "goal 3 cancelled: preempted by goal 4" in capsys.readouterr().out


def test_wait_with_a_timeout(capsys):
    accepted = m.GoalReply(goal_id=3, state="TURNING_TO_HEADING", speed=2.0)
    status = m.StatusReply(state="TURNING_TO_HEADING", is_moving=True, goal_id=3, goal=None, result=None, distance_remaining=1.0, pose=None)
    answers = {"nav/turn_to_heading": accepted, "nav/status": status}
    got, bus = run(["turn", "1", "--wait", "--timeout", "0.05"], answers)
    assert got == EXIT_UNAVAILABLE and "goal 3 did not end in 0.05 s" in capsys.readouterr().err
    assert [s for s, _, _ in bus.sent] == ["nav/turn_to_heading", "nav/status"] and bus.withdrawn()


def test_wait_with_a_lost_navigator(capsys):
    got, bus = run(["turn", "1", "--wait", "--timeout", "60"], {"nav/turn_to_heading": Unavailable("no reply")})
    assert got == EXIT_UNAVAILABLE and "no reply" in capsys.readouterr().err and bus.withdrawn()


def test_progress_line():
    line = nav.progress(progress_states()[0])
    assert "MOVING_TO_POINT" in line and "goal 3" in line and "0.800 m" in line and "eta 4.0 s" in line
    turning = m.NavState(t=1.0, state="TURNING_TO_HEADING", goal_id=1, distance_remaining=0.5, next_point=None)
    assert "0.500 rad" in nav.progress(turning)


GOALS = (["goto", "1", "2"], ["turn", "1"], ["swing", "1", "left"], ["face", "1", "2"], ["straight", "0.1"], ["path", "1,2"])
CLIENT_COMMANDS = (*GOALS, ["stop"], ["set-pose", "0", "0"], ["drive", "0.1", "--for", "1"], ["status"])


@pytest.mark.parametrize("cmd", GOALS)
def test_goal_commands_take_the_connection_options_and_wait(cmd):
    args = parse(*cmd, "--robot", "r9", "--connect", "tcp/10.0.0.2:7447", "--zenoh-mode", "peer", "--wait")
    assert (args.robot, args.connect, args.zenoh_mode, args.wait) == ("r9", "tcp/10.0.0.2:7447", "peer", True)


@pytest.mark.parametrize("cmd", CLIENT_COMMANDS)
@pytest.mark.parametrize("option", [["--set", "sim.rtf=5"], ["--config", "x.toml"], ["--scenario", "harsh"], ["--seed", "3"]])
def test_client_commands_refuse_deployment_options(cmd, option, capsys):
    with pytest.raises(SystemExit) as e:
        parse(*cmd, *option)
    assert e.value.code == EXIT_USAGE and f"unrecognized arguments: {option[0]}" in capsys.readouterr().err


@pytest.mark.parametrize("cmd", [["stop"], ["set-pose", "0", "0"], ["drive", "0.1", "--for", "1"]])
def test_stop_and_set_pose_have_no_wait(cmd):
    with pytest.raises(SystemExit) as e:
        parse(*cmd, "--wait")
    assert e.value.code == EXIT_USAGE


@pytest.mark.parametrize(
    "argv, words",
    [
        (["turn", "90"], "heading 90 rad is outside [-2 pi, 2 pi]: for degrees add --deg"),
        (["turn", "--", "-7"], "heading -7 rad"),
        (["set-pose", "0", "0", "180"], "theta 180 rad"),
        (["goto", "1", "0", "--robot", "a/b"], "--robot: robot id 'a/b' must match"),
    ],
)
def test_bad_arguments_fail_in_one_line_before_connecting(argv, words, capsys):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nav, "open_bus", lambda args: pytest.fail("connected"))
        assert nav.run(parse(*argv)) == EXIT_USAGE
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1


@pytest.mark.parametrize("argv", [["turn", "6.28"], ["turn", "--", "-6.28"], ["turn", "90", "--deg"], ["turn", "-360", "--deg"]])
def test_headings_in_range_are_sent(argv):
    code, bus = run(argv, {"nav/turn_to_heading": ACCEPTED})
    assert code == EXIT_OK and abs(bus.sent[0][1]["heading"]) <= 2 * math.pi + 1e-9


@pytest.mark.parametrize(
    "heading, deg, wrong",
    [
        (6.28, False, False),
        (-2 * math.pi, False, False),
        (6.3, False, True),
        (-100.0, False, True),
        (720.0, True, False),
        (None, False, False),
    ],
)
def test_check_angle(heading, deg, wrong):
    assert (nav.check_angle("heading", heading, deg) is not None) == wrong


def test_watch_renders_state_pose_against_truth_fix_and_rates():
    truths = [m.Truth(t=t / 100, x=t / 1000, y=0.0, theta=0.0, v=0.1, omega=0.0) for t in range(100)]
    pose = m.Pose(t=0.5, x=0.052, y=0.0, theta=0.0, v=0.1, omega=0.0)
    assert watch.truth_at(truths, 0.5).t == 0.5 and watch.truth_at(truths, None).t == 0.99 and watch.truth_at([], 1.0) is None
    fix = m.Fix(
        t=0.2, t_arrival=0.5, latency=0.3, replay_depth=30, innovation=(0.01, 0.0, 0.0), mahalanobis_d2=1.5, accepted=True, reason=""
    )
    diag = m.Diag(t=1.0, service="odometry", uptime=3.0, counters={"msgs_in": 100}, rates={"odom": 100.0}, status="ok")
    text = watch.render("r1", progress_states()[0], pose, watch.truth_at(truths, 0.5), fix, {"odometry": diag}, {"odometry"})
    assert "MOVING_TO_POINT" in text and "0.800 m" in text
    assert "vs truth   0.20 cm" in text  # pose vs the truth at the pose's t
    assert "latency  300 ms" in text and "accepted" in text
    assert "odom 100" in text


def test_watch_once_on_a_fake_client(capsys):
    bus = FakeBus({})
    assert watch.run(parse("watch", "--once", "--period", "0"), lambda args: Client("r1", bus=bus)) == EXIT_OK
    assert "zenav watch  robot r1" in capsys.readouterr().out and bus.subs == []  # withdrawn on exit
    assert "zenav/r1/sim/truth" in bus.subscribed and bus.watchers[0][0] == "zenav/r1/alive/*"


def test_watch_without_a_router_says_so(capsys):
    def refuse(args):
        raise Unavailable("no Zenoh router at tcp/127.0.0.1:1")

    assert watch.run(parse("watch", "--once"), refuse) == EXIT_UNAVAILABLE
    assert "zenav watch: unavailable: no Zenoh router" in capsys.readouterr().err
