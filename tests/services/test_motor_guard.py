"""The motor's guard on the in-memory bus: a raw cmd_vel driven at a box, another robot or the field's edge stops short."""

import math

import pytest

from tests.support.rig import Rig
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.field import polygon_shape
from zenav.services.motor.service import Motor

R = 0.0673 / 2.0
BOX = [[0.55, -0.1], [0.75, -0.1], [0.75, 0.1], [0.55, 0.1]]
FIELD = {"obstacles": [{"name": "box", "polygon": BOX}]}
RADIUS = 0.1  # [robot] radius, the default


class MotorRig:
    """The motor's rig and a robot that moves as its wheel commands say, its pose sent back every 10 ms."""

    def __init__(self, **sections):
        self.rig = Rig(Motor, t0=10.0, **sections)
        self.x, self.y, self.theta = 0.0, 0.0, 0.0

    def step(self, v: float, omega: float, steps: int, every: int = 10, way: m.Way = ()) -> None:
        """Send cmd_vel (t = 0: now, as teleop does; `way`: as the navigator tells it) every `every` steps and drive the
        robot for `steps` steps of 10 ms."""
        for i in range(steps):
            if i % every == 0:
                self.rig.put("cmd_vel", m.CmdVel(t=0.0, v=v, omega=omega, way=way))
            wheels = self.rig.got("motors/wheels")
            left, right = (wheels[-1].left, wheels[-1].right) if wheels else (0.0, 0.0)
            speed, turn = (left + right) * R / 2.0, (right - left) * R / 0.1156
            self.x += speed * math.cos(self.theta) * 0.01
            self.y += speed * math.sin(self.theta) * 0.01
            self.theta += turn * 0.01
            self.rig.clock.advance(0.01)
            self.rig.put("pose", m.Pose(t=self.rig.t, x=self.x, y=self.y, theta=self.theta, v=speed, omega=turn))


def test_a_raw_cmd_vel_at_the_box_stops_before_contact_and_says_why():
    bot = MotorRig(field=FIELD)
    box = polygon_shape("box", BOX)
    bot.step(0.3, 0.0, 300)  # 3 s at 0.3 m/s would take it 0.9 m, through the box
    gap = box.clearance(bot.x, bot.y) - RADIUS
    assert 0.0 < gap < 0.03  # stopped short of contact, close to it
    c = bot.rig.svc.counters.values
    assert c["guard_stopped"] > 0 and c["guard_slowed"] > 0
    said = bot.rig.got("motor/guard")
    assert said[-1].stopped and said[-1].reason.startswith("obstacles[0] 'box'") and said[-1].reason.endswith("ahead")
    here = (bot.x, bot.y)
    bot.step(0.0, 2.0, 50)  # turning in place is free: the footprint is a disc
    assert bot.theta > 0.5 and math.dist(here, (bot.x, bot.y)) < 1e-3
    bot.theta = math.pi  # facing away, it drives off
    bot.step(0.3, 0.0, 50)
    assert bot.x < here[0] - 0.1
    assert bot.rig.got("motor/guard")[-1].reason == ""


def test_reversing_into_the_box_stops_too():
    bot = MotorRig(field=FIELD)
    bot.x, bot.theta = 1.1, 0.0  # beyond the box, its back to it
    bot.step(-0.3, 0.0, 300)
    assert 0.0 < polygon_shape("box", BOX).clearance(bot.x, bot.y) - RADIUS < 0.03
    assert bot.rig.got("motor/guard")[-1].reason.endswith("behind")


def test_another_robot_on_the_field_topic_stops_it():
    bot = MotorRig()
    body = m.Body(t=5.0, robot="r2", x=0.6, y=0.0, radius=0.1)  # stamped on its own clock
    for _ in range(40):  # the other robot keeps saying where it is, every 100 ms of the run below
        bot.rig.bus.publish(keys.field_key("robots"), codec.encode(body))
        bot.step(0.3, 0.0, 10)
    assert 0.0 < math.dist((bot.x, bot.y), (0.6, 0.0)) - 0.2 < 0.03
    assert bot.rig.got("motor/guard")[-1].reason.startswith("robot r2")


def test_the_edge_stops_it_only_with_guard_edges():
    bot = MotorRig(field={"x_max": 0.5}, motor={"guard_edges": True})
    bot.step(0.3, 0.0, 300)
    assert 0.5 - RADIUS - 0.03 < bot.x < 0.5 - RADIUS
    bot = MotorRig(field={"x_max": 0.5})  # by default a robot may square up against the edge
    bot.step(0.3, 0.0, 300)
    assert bot.x > 0.5


def test_it_sends_its_robots_body_and_passes_commands_it_cannot_judge():
    bot = MotorRig(field=FIELD)
    bot.rig.put("cmd_vel", m.CmdVel(t=0.0, v=0.3, omega=0.0))  # no pose yet: passed, counted
    assert bot.rig.got("motors/wheels")[-1].left == pytest.approx(0.3 / R)
    assert bot.rig.svc.counters.values["guard_blind"] == 1
    bot.step(0.0, 0.0, 20)
    bodies = [codec.decode(d, m.Body) for k, d in bot.rig.bus.published if k == keys.field_key("robots")]
    assert bodies and bodies[-1].robot == "r1" and bodies[-1].radius == RADIUS


def test_its_body_tells_the_way_of_the_command_it_drives_and_none_standing():
    bot = MotorRig()
    way = ((1.0, 0.0), (1.0, 1.0))
    bot.step(0.2, 0.0, 50, way=way)
    bodies = [codec.decode(d, m.Body) for k, d in bot.rig.bus.published if k == keys.field_key("robots")]
    assert bodies and bodies[-1].way == way
    bot.step(0.0, 0.0, 20, way=way)
    bodies = [codec.decode(d, m.Body) for k, d in bot.rig.bus.published if k == keys.field_key("robots")]
    assert bodies[-1].way == ()  # standing: it goes nowhere
