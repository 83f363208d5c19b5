"""The navigation commands of `zenav`: arguments, requests, output and exit codes, on a fake client."""
import math

import pytest

from zenav.cli import nav, watch
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE, build_parser
from zenav.common import keys
from zenav.common import messages as m
from zenav.common.client import ClientError, Latest


class FakeBus:
    def __init__(self):
        self.tokens, self.watchers = [], []

    def token(self, key):
        bus = self
        bus.tokens.append(key)

        class Handle:
            def undeclare(self):
                bus.tokens.remove(key)

        return Handle()

    def watch_tokens(self, key, cb):
        self.watchers.append((key, cb))


class FakeClient:
    """Answers queries from a table: a reply, or a ClientError to raise."""

    def __init__(self, answers, states=()):
        self.robot, self.bus, self.answers, self.sent = "r1", FakeBus(), answers, []
        self.states, self._latest, self.subs = list(states), {}, {}
        self.closed = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.closed = True

    def key(self, suffix):
        return keys.key(self.robot, suffix)

    def latest(self, suffix):
        if suffix not in self._latest:
            self._latest[suffix] = Latest()
        return self._latest[suffix]

    def subscribe(self, suffix, cb, typ=None):
        self.subs[suffix] = cb

    def query(self, suffix, request=None, timeout=5.0):
        self.sent.append((suffix, request, timeout))
        self.tokens_during_query = list(self.bus.tokens)
        for st in self.states:
            self.latest("nav/state").put(st)
        answer = self.answers[suffix]
        if isinstance(answer, Exception):
            raise answer
        return answer


def parse(*argv):
    return build_parser().parse_args(list(argv))


def run(argv, answers, states=()):
    client = FakeClient(answers, states)
    code = nav.run(parse(*argv), lambda args: client)
    return code, client


ACCEPTED = m.GoalReply(goal_id=7, state="MOVING_TO_POINT", speed=0.2)


@pytest.mark.parametrize(
    "argv, suffix, request_",
    [
        (["goto", "1", "-0.5"], "nav/move_to_point", {"x": 1.0, "y": -0.5}),
        (["goto", "1", "2", "--speed", "0.1", "--tolerance", "0.02"], "nav/move_to_point",
         {"x": 1.0, "y": 2.0, "speed": 0.1, "tolerance": 0.02}),
        (["turn", "1.5"], "nav/turn_to_heading", {"heading": 1.5}),
        (["turn", "90", "--deg", "--tolerance", "2", "--speed", "45"], "nav/turn_to_heading",
         {"heading": math.pi / 2, "tolerance": math.radians(2), "speed": math.pi / 4}),
        (["face", "0", "1"], "nav/turn_to_point", {"x": 0.0, "y": 1.0}),
        (["straight", "-0.1"], "nav/move_straight", {"speed": -0.1}),
        (["straight", "0.2", "--distance", "0.5"], "nav/move_straight", {"speed": 0.2, "distance": 0.5}),
        (["path", "1,0", "1,1", "--speed", "0.15"], "nav/follow_path", {"points": [[1.0, 0.0], [1.0, 1.0]], "speed": 0.15}),
        (["path", "--", "-1,0", "0,-1.5"], "nav/follow_path", {"points": [[-1.0, 0.0], [0.0, -1.5]]}),
    ],
)
def test_commands_send_the_contract_request(argv, suffix, request_, capsys):
    code, client = run(argv, {suffix: ACCEPTED})
    assert code == EXIT_OK
    [(sent, req, timeout)] = client.sent
    assert sent == suffix and req.keys() == request_.keys() and timeout == nav.QUERY_TIMEOUT
    assert all(req[k] == (v if k == "points" else pytest.approx(v)) for k, v in request_.items())
    assert "goal 7 MOVING_TO_POINT" in capsys.readouterr().out and client.closed


def test_clamped_speed_is_shown(capsys):
    code, _ = run(["goto", "1", "0", "--speed", "9"], {"nav/move_to_point": m.GoalReply(goal_id=1, state="MOVING_TO_POINT", speed=0.3)})
    assert code == EXIT_OK and "at 0.30 m/s" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, request_",
    [(["set-pose", "0.5", "-1"], {"x": 0.5, "y": -1.0}), (["set-pose", "0", "0", "90", "--deg"], {"x": 0.0, "y": 0.0, "theta": math.pi / 2})],
)
def test_set_pose(argv, request_, capsys):
    code, client = run(argv, {"localizer/set_pose": m.PoseStamped(t=1.0, x=0.5, y=-1.0, theta=0.0)})
    [(sent, req, _)] = client.sent
    assert code == EXIT_OK and sent == "localizer/set_pose" and req == pytest.approx(request_)
    assert "pose set: x +0.500 y -1.000" in capsys.readouterr().out


def test_stop(capsys):
    code, client = run(["stop", "--robot", "r2"], {"nav/stop": m.StopReply(state="STOPPED")})
    assert code == EXIT_OK and client.sent[0][0] == "nav/stop" and "STOPPED" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv",
    [["goto", "1"], ["goto", "one", "2"], ["goto", "nan", "0"], ["path"], ["path", "1;0"], ["path", "1,0,2"],
     ["turn"], ["straight"], ["fly"]],
)
def test_bad_arguments_are_usage_errors(argv):
    with pytest.raises(SystemExit) as e:
        parse(*argv)
    assert e.value.code == EXIT_USAGE


@pytest.mark.parametrize(
    "error, code",
    [
        (ClientError("invalid_argument", "x: out of range"), EXIT_USAGE),
        (ClientError("unavailable", "no pose yet"), EXIT_UNAVAILABLE),
        (ClientError("internal", "boom"), EXIT_FAILED),
    ],
)
def test_error_replies_map_to_exit_codes(error, code, capsys):
    got, _ = run(["goto", "1", "0"], {"nav/move_to_point": error})
    assert got == code and error.message in capsys.readouterr().err


def test_no_router_is_unavailable(capsys):
    def refuse(args):
        raise ClientError("unavailable", "no Zenoh router at tcp/127.0.0.1:1")

    assert nav.run(parse("goto", "1", "0"), refuse) == EXIT_UNAVAILABLE
    assert "no Zenoh router" in capsys.readouterr().err


def progress_states():
    return [
        m.NavState(t=1.0, state="MOVING_TO_POINT", goal_id=3, distance_remaining=0.8, eta=4.0, elapsed=0.5),
        m.NavState(t=2.0, state="STOPPED", goal_id=3, result="succeeded", elapsed=5.0),
    ]


@pytest.mark.parametrize("result, code", [("succeeded", EXIT_OK), ("cancelled", EXIT_FAILED), ("aborted", EXIT_FAILED)])
def test_wait_holds_a_lease_and_maps_the_result(result, code, capsys):
    pose = m.PoseStamped(t=9.0, x=1.0, y=0.0, theta=0.0)
    done = m.GoalReply(goal_id=3, state="STOPPED", result=result, pose=pose, message="arrived" if result == "succeeded" else "why")
    got, client = run(["goto", "1", "0", "--wait"], {"nav/move_to_point": done}, progress_states())
    assert got == code
    [(_, req, timeout)] = client.sent
    assert req["wait"] is True and req["lease"].startswith("zenav/r1/lease/cli-") and timeout == nav.WAIT_TIMEOUT
    assert client.tokens_during_query == [req["lease"]] and client.bus.tokens == []  # held while waiting only
    out = capsys.readouterr()
    assert f"goal 3 {result}" in out.out and "x +1.000" in out.out


def test_wait_with_a_timeout_and_lost_navigator(capsys):
    got, client = run(["turn", "1", "--wait", "--timeout", "60"], {"nav/turn_to_heading": ClientError("unavailable", "no reply")})
    assert got == EXIT_UNAVAILABLE and client.sent[0][2] == 60.0 and client.bus.tokens == []


def test_progress_line():
    line = nav.progress(progress_states()[0])
    assert "MOVING_TO_POINT" in line and "goal 3" in line and "0.800 m" in line and "eta 4.0 s" in line
    turning = m.NavState(t=1.0, state="TURNING_TO_HEADING", goal_id=1, distance_remaining=0.5, next_point=None)
    assert "0.500 rad" in nav.progress(turning)


def test_every_navigation_command_takes_the_deployment_options():
    for cmd in (["goto", "1", "2"], ["turn", "1"], ["face", "1", "2"], ["straight", "0.1"], ["path", "1,2"], ["stop"]):
        args = parse(*cmd, "--robot", "r9", "--connect", "tcp/10.0.0.2:7447", "--wait")
        assert (args.robot, args.connect, args.wait) == ("r9", "tcp/10.0.0.2:7447", True)


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
    client = FakeClient({})
    assert watch.run(parse("watch", "--once", "--period", "0"), lambda args: client) == EXIT_OK
    assert "zenav watch  robot r1" in capsys.readouterr().out and client.closed
    assert "sim/truth" in client.subs and client.bus.watchers[0][0] == "zenav/r1/alive/*"
