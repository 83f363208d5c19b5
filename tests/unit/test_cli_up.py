"""`zenav up`: the service registry's orders, and the demo giving way to an operator's goal."""

from __future__ import annotations

import argparse

from zenav import services
from zenav.cli import up
from zenav.cli.main import main
from zenav.common import keys
from zenav.common import messages as m
from zenav.common.client import Latest
from zenav.common.scenarios import SQUARE
from zenav.robot import Result


def test_the_registry_names_each_service_class_and_stops_the_navigator_first():
    assert services.NAMES == ("sim", "motor", "odometry", "vps", "localizer", "navigator")
    for name in services.NAMES:
        assert services.load(name).name == name
    assert services.stop_order() == ["navigator", "localizer", "vps", "odometry", "motor", "sim"]
    assert services.stop_order(["sim", "motor", "navigator"]) == ["navigator", "motor", "sim"]
    assert set(keys.SERVICES) == set(services.ALL)  # the contract's diag/<service> topics name the same


def state(goal_id: int, result: str | None) -> m.NavState:
    return m.NavState(t=1.0, state="STOPPED" if result else "MOVING_TO_POINT", goal_id=goal_id, result=result)


def test_the_gate_waits_for_a_quiet_period_after_someone_else_s_goal():
    gate = up.DemoGate(quiet=5.0)
    gate.mine.add(1)
    assert gate.update(state(1, None), 0.0)  # its own goal
    assert not gate.update(state(2, None), 1.0)  # someone else's, running
    assert not gate.update(state(2, None), 9.0)
    assert not gate.update(state(2, "succeeded"), 10.0)  # ended: quiet from the last time it was seen running
    assert gate.update(state(2, "succeeded"), 14.0)
    assert not gate.update(state(3, "cancelled"), 14.5)  # another one, ended before it was ever seen
    assert gate.update(state(3, "cancelled"), 19.5)
    gate.interrupted(20.0)  # a demo goal was cancelled (nav/stop): someone acted
    assert not gate.update(state(3, "cancelled"), 24.0) and gate.update(state(3, "cancelled"), 25.0)


def test_the_gate_waits_while_someone_drives_by_cmd_vel_with_the_navigator_idle():
    gate = up.DemoGate(quiet=5.0)
    gate.mine.add(1)
    moving, zero = m.CmdVel(t=0.0, v=0.1, omega=0.0), m.CmdVel(t=0.0, v=0.0, omega=0.0)
    gate.commanded(moving, state(1, None), 0.0)  # the navigator's own, while a goal runs
    gate.commanded(zero, state(1, "cancelled"), 0.5)  # the zero of a stop
    assert gate.update(state(1, "cancelled"), 1.0) and gate.who == ""
    gate.commanded(moving, state(1, "cancelled"), 1.0)  # teleop
    gate.commanded(m.CmdVel(t=0.0, v=0.0, omega=0.5), state(1, "cancelled"), 3.0)
    assert not gate.update(state(1, "cancelled"), 7.9) and gate.who == "cmd_vel"
    assert gate.update(state(1, "cancelled"), 8.0)


class FakeDone:
    """`done` of the demo: its waits move a fake clock on, the test's script runs on each."""

    def __init__(self, script) -> None:
        self.t, self._set, self.script = 0.0, False, script

    def is_set(self) -> bool:
        return self._set

    def set(self) -> None:
        self._set = True

    def wait(self, timeout: float) -> bool:
        self.t += timeout
        self.script(self.t)
        return self._set


class FakeGoal:
    def __init__(self, goal_id: int, result: Result) -> None:
        self.id, self._result = goal_id, result

    def wait(self, timeout: float) -> Result:
        return self._result


class FakeRobot:
    """A robot whose navigator takes the demo's goals; the operator sends goal 3 while goal 2 runs."""

    def __init__(self, done: FakeDone) -> None:
        self.done, self.nav, self.sent = done, Latest(), []
        self.client = self

    def latest(self, suffix: str) -> Latest:
        assert suffix == "nav/state"
        return self.nav

    def subscribe(self, suffix: str, callback) -> FakeRobot:
        assert suffix == "cmd_vel"  # nobody drives by hand here
        return self

    def undeclare(self) -> None:
        pass

    def wait_ready(self, timeout: float) -> None:
        pass

    def move_to_point(self, x: float, y: float) -> FakeGoal:
        self.sent.append((self.done.t, x, y))
        goal_id = len(self.sent) if len(self.sent) < 3 else len(self.sent) + 1  # the operator's goal is 3
        if goal_id == 2:  # preempted by the operator's goal, which runs on
            self.nav.put(state(3, None))
            return FakeGoal(2, Result(2, "cancelled", "preempted by goal 3", None, 1.0))
        self.nav.put(state(goal_id, "succeeded"))
        if len(self.sent) == 4:
            self.done.set()
        return FakeGoal(goal_id, Result(goal_id, "succeeded", "arrived", None, 1.0))


def test_the_demo_pauses_while_an_operator_drives_and_resumes_after_the_quiet(monkeypatch):
    bot: FakeRobot | None = None

    def operator(t: float) -> None:  # the operator's goal ends at t = 3 s
        assert bot is not None
        if t >= 3.0 and bot.nav.msg.goal_id == 3 and bot.nav.msg.result is None:
            bot.nav.put(state(3, "succeeded"))

    done = FakeDone(operator)
    bot = FakeRobot(done)
    lines: list[str] = []
    up.demo_loop(bot, done, lines.append, now=lambda: done.t)  # type: ignore[arg-type]
    times = [t for t, _, _ in bot.sent]
    corners = [(x, y) for _, x, y in bot.sent]
    assert corners == [SQUARE[0], SQUARE[1], SQUARE[1], SQUARE[2]]  # the preempted corner again, after the pause
    assert times[:2] == [0.0, 0.0]
    # quiet from the last nav/state that showed goal 3 running (the demo looks every 0.2 s)
    assert 3.0 + up.DEMO_QUIET - 0.25 <= times[2] <= 3.0 + up.DEMO_QUIET + 0.25
    assert any(line.startswith("demo: paused: someone else is driving (goal 3)") for line in lines), lines
    assert "demo: resuming the square" in lines


def test_an_unknown_service_is_refused_naming_the_services(capsys):
    assert main(["up", "--services", "odometry,localizr"]) == 2
    assert capsys.readouterr().err == f"zenav up: unknown service(s): localizr (the services: {', '.join(services.ALL)})\n"


def test_router_connect_with_connect_is_refused_saying_why(capsys):
    assert main(["up", "--connect", "tcp/127.0.0.1:7447", "--router-connect", "tcp/10.0.0.1:7447"]) == 2
    assert "--router-connect links the router zenav up embeds; with --connect it embeds none" in capsys.readouterr().err


def test_the_services_are_peers_on_one_host_and_clients_of_their_router_across_hosts():
    def mode(*argv: str) -> str:
        parser = argparse.ArgumentParser()
        up.add_arguments(parser.add_subparsers())
        child = up.child_args(parser.parse_args(["up", *argv]), "tcp/127.0.0.1:7447")
        return child[child.index("--zenoh-mode") + 1]

    assert mode() == "peer"
    assert mode("--listen", "tcp/10.77.0.1:7447") == "client"  # other hosts' routers link to this one
    assert mode("--router-connect", "tcp/10.77.0.1:7447") == "client"  # this one links to another host's
    assert mode("--connect", "tcp/127.0.0.1:7447") == "client"
    assert mode("--listen", "tcp/10.77.0.1:7447", "--zenoh-mode", "peer") == "peer"


def test_vps_also_starts_one_more_vps_per_camera_each_under_its_own_name(capsys):
    from zenav.common.config import Settings

    settings = Settings.load(None, vps={"source": "camera", "also": ["onboard"]})
    more = up.more_vps(settings, ["sim", "vps", "localizer"])
    assert more == {"vps_onboard": ["--set", 'vps.source="onboard"', "--set", 'vps.name="onboard"', "--set", "vps.also=[]"]}
    assert up.more_vps(settings, ["sim", "localizer"]) == {}  # no vps in this run, none beside it
    assert up.more_vps(Settings.load(None), ["vps"]) == {}
    assert main(["up", "--set", 'vps.source="onboard"', "--set", 'vps.also=["onboard"]']) == 2
    assert "also = ['onboard']: each a source other than this vps's own (onboard), once" in capsys.readouterr().err
