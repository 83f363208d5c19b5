"""nav/stop on the in-memory bus: taken ahead of queued goals, voiding every goal that came before it, commanding
zero at once, even when the queue is full."""

from tests.support.navigator import NavigatorRig, long_path, reply
from zenav.common import codec
from zenav.common import messages as m


def test_stop_is_dispatched_before_queued_long_paths(rig):
    path = codec.encode(long_path(10_000))
    held = [rig.bus.query("zenav/r1/nav/follow_path", path) for _ in range(15)]
    stop = rig.bus.query("zenav/r1/nav/stop")
    assert rig.nav.drain(limit=1) == 1
    assert reply(stop, m.StopReply).state == "STOPPED" and not any(q.replies for q in held)
    assert rig.published("cmd_vel")[-1] == m.CmdVel(t=0.0, v=0.0, omega=0.0)


def test_a_stop_voids_every_goal_that_reached_the_navigator_before_it(rig):
    reply(rig.query("nav/move_straight", {"speed": 0.2}))  # accepted and driving
    rig.step(5)
    path = codec.encode(long_path(10_000))
    held = [rig.bus.query("zenav/r1/nav/follow_path", path) for _ in range(15)]  # queued behind the worker
    waiting = rig.bus.query("zenav/r1/nav/move_to_point", codec.encode({"x": 1.0, "y": 0.0, "wait": True}))
    stop = rig.bus.query("zenav/r1/nav/stop")
    later = rig.bus.query("zenav/r1/nav/move_to_point", codec.encode({"x": 0.5, "y": 0.5}))  # arrives after the stop
    sent = len(rig.published("cmd_vel"))
    rig.nav.drain()
    assert reply(stop, m.StopReply).state == "STOPPED"
    for q in [*held, waiting]:
        err = reply(q)
        assert err.error == "unavailable" and "nav/stop" in err.message, err
    assert reply(later).goal_id == 2  # the goal sent after the stop drives
    assert rig.nav.counters.values["goals_voided"] == 16
    assert {s.goal_id for s in rig.published("nav/state")} == {0, 1, 2}  # none of the voided ever ran
    assert all(c.t == 0.0 and c.v == 0.0 for c in rig.published("cmd_vel")[sent:])  # nothing drove before the later goal's pose


def test_a_goal_in_hand_when_a_stop_arrives_does_not_start(rig, monkeypatch):
    from zenav.services.navigator import intake

    resolve = intake.move_to_point
    stops = []

    def stop_arrives_meanwhile(req, cfg):  # the stop reaches the navigator while the worker resolves the goal
        stops.append(rig.bus.query("zenav/r1/nav/stop"))
        return resolve(req, cfg)

    monkeypatch.setattr(intake, "move_to_point", stop_arrives_meanwhile)
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    assert reply(q).error == "unavailable" and "nav/stop" in reply(q).message
    assert reply(stops[0], m.StopReply).state == "STOPPED" and rig.nav.machine.goal_id == 0
    rig.step(5)
    assert rig.cmd == (0.0, 0.0) and rig.nav.machine.goal_id == 0


def test_stop_commands_zero_on_arrival_and_nothing_computed_before_it_follows(rig):
    reply(rig.query("nav/move_straight", {"speed": 0.2}))
    rig.step(5)
    sent = len(rig.published("cmd_vel"))
    assert rig.cmd[0] > 0.0
    stop = rig.bus.query("zenav/r1/nav/stop")  # arrived; the worker has not taken it yet
    assert rig.published("cmd_vel")[sent:] == [m.CmdVel(t=0.0, v=0.0, omega=0.0)] and not stop.replies
    s = rig.bot.state  # the pose the worker had in hand when the stop arrived
    rig.nav.on_pose(m.Pose(t=rig.clock.now(), x=s.x, y=s.y, theta=s.theta, v=s.v, omega=s.omega))
    assert len(rig.published("cmd_vel")) == sent + 1 and rig.cmd == (0.0, 0.0)
    rig.nav.drain()
    assert reply(stop, m.StopReply).state == "STOPPED" and rig.nav.machine.result == "cancelled"
    reply(rig.query("nav/move_straight", {"speed": 0.2}))  # the next goal drives again
    rig.step(3)
    assert rig.cmd[0] > 0.0


def test_a_stop_the_full_queue_refuses_still_commands_zero():
    r = NavigatorRig()
    r.pose()
    reply(r.query("nav/move_straight", {"speed": 0.2}))
    r.step(3)
    lane = r.nav.limits.queue_items  # the priority lane's bound
    stops = [r.bus.query("zenav/r1/nav/stop") for _ in range(lane + 1)]
    assert reply(stops[-1], m.StopReply).error == "unavailable" and r.cmd == (0.0, 0.0)
    r.nav.drain()
    assert all(reply(q, m.StopReply).state == "STOPPED" for q in stops[:-1])
    reply(r.query("nav/move_straight", {"speed": 0.2}))  # the refused stop holds nothing back
    r.step(3)
    assert r.cmd[0] > 0.0
    r.nav.close()
