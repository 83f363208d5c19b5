"""The navigator on the in-memory bus with a manual clock, driving the world's robot by its cmd_vel, for service tests.

from tests.support.navigator import NavigatorRig, reply

rig = NavigatorRig(field=None, **navigator_settings)
q = rig.query("nav/move_to_point", {"x": 0.5, "y": 0.0, "wait": True})  # -> the MemoryQuery, after draining
rig.run_until(q)                                # step until it has its reply (bounded): the decoded reply
rig.step(10)                                    # 10 pose periods: drive the robot, publish its pose (and odom sample)
rig.published("cmd_vel")                        # -> [m.CmdVel, ...] published so far
rig.x, rig.y, rig.theta, rig.cmd, rig.moving    # the robot (settable), the last command, stuck wheels
rig.cov                                         # the covariance its poses carry (settable)
rig.odom_frame                                  # the odometry's frame in the map frame, (x, y, theta) (settable)

With control on odom (the default), each pose goes out after the odom sample of its t, as in the stack: the
navigator steers on each sample by the pose before's correction (and takes each pose as the newest when it comes).

`World()` is that rig as the bus of `zenav.robot.Robot("r1", bus=world)`; `world.drive(until)` steps until `until()` holds.
"""

import threading

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import Settings
from zenav.common.scenarios import scenario
from zenav.services.navigator.correction import compose, inverse
from zenav.services.navigator.params import Params
from zenav.services.navigator.service import Navigator
from zenav.world.sim import SimRobot

DT = 0.01  # [s] pose period
MAX_STEPS = 3000  # 30 s of robot time, the bound of a drive loop
IDEAL = scenario("default", {"wheel_radius_err_left": 0.0, "wheel_radius_err_right": 0.0, "track_width_err": 0.0, "slip_sigma": 0.0})


class NavigatorRig:
    """A navigator and the world's robot (exact nominal geometry, no slip) driven by its cmd_vel."""

    def __init__(self, field=None, **cfg):
        self.bus, self.clock = MemoryBus(), ManualClock(100.0)
        settings = Settings.load(None, navigator=cfg, field=field or {})
        self.nav = Navigator(settings, self.bus, self.clock)
        self.nav.start()
        self.bot = SimRobot(settings.robot, IDEAL, seed=1)
        self.cmd = (0.0, 0.0)  # last cmd_vel (v, omega)
        self.moving = True  # False: the wheels are stuck, the commands do nothing
        self.cov = m.ZERO_COV  # the covariance each pose carries
        self.odom_frame = (0.3, -0.2, 0.5)  # the odometry's frame in the map frame (not the identity: the correction counts)
        self.on_odom = settings.section("navigator", Params).control_on == "odom"
        self.bus.subscribe("zenav/r1/cmd_vel", self._on_cmd)

    x = property(lambda self: self.bot.state.x, lambda self, v: self._shove(x=v))
    y = property(lambda self: self.bot.state.y, lambda self, v: self._shove(y=v))
    theta = property(lambda self: self.bot.state.theta, lambda self, v: self._shove(theta=v))

    def _shove(self, **pose):
        """Move the robot without stopping its wheels."""
        self.bot.state = self.bot.state._replace(**pose)

    def _on_cmd(self, key, data):
        msg = codec.decode(data, m.CmdVel)
        self.cmd = (msg.v, msg.omega)

    def pose(self):
        """The pose now (with control on odom, after the odom sample of its t)."""
        self._publish(self.samples())

    def odom(self):
        """The odometry's sample now (the robot in the odometry's frame), alone."""
        self._publish([kd for kd in self.samples() if kd[0].endswith("/odom")])

    def localize(self):
        """The localizer's pose now, alone."""
        self._publish([kd for kd in self.samples() if kd[0].endswith("/pose")])

    def _publish(self, samples):
        for key, data in samples:
            self.bus.publish(key, data)
            self.nav.drain()

    def samples(self):
        """(key, payload) of the odom sample now (with control on odom), then of the localizer's pose."""
        s, t = self.bot.state, self.clock.now()
        x, y, theta = compose(inverse(self.odom_frame), (s.x, s.y, s.theta))
        odom = [("zenav/r1/odom", codec.encode(m.Odom(t=t, x=x, y=y, theta=theta, v=s.v, omega=s.omega)))]
        pose = m.Pose(t=t, x=s.x, y=s.y, theta=s.theta, v=s.v, omega=s.omega, cov=self.cov)
        return [*(odom if self.on_odom else []), ("zenav/r1/pose", codec.encode(pose))]

    def step(self, n=1, poses=True):
        for _ in range(n):
            if self.moving:
                self.bot.drive(*self.cmd, DT)
            self.clock.advance(DT)
            if poses:
                self.pose()
            else:
                self.nav.drain()

    def query(self, suffix, payload=None, params=None):
        q = self.bus.query(keys.key("r1", suffix), codec.encode(payload) if payload is not None else b"", params)
        self.nav.drain()
        return q

    def run_until(self, q, max_s=60.0):
        """Step until the query has its reply (bounded)."""
        for _ in range(round(max_s / DT)):
            if q.replies:
                break
            self.step()
        return reply(q)

    def published(self, suffix):
        return [codec.decode(d, keys.TOPICS[suffix]) for k, d in self.bus.published if k == keys.key("r1", suffix)]


def reply(q, typ=m.GoalReply):
    """The one finished reply of `q`, decoded: `typ`, or ErrorReply."""
    [(ok, data)] = q.replies
    assert q.finished
    return codec.decode(data, typ if ok else m.ErrorReply)


class World(NavigatorRig):
    """The rig as the QueryBus of the robot library: a query drains the navigator at once; `sent` keeps what the library asked."""

    def __init__(self) -> None:
        super().__init__()
        self.sent: list[tuple[str, dict]] = []  # queries the library sent
        self.hide_state = False  # True: nav/state does not reach the library
        self.refused = threading.Event()  # set when a query got an error reply

    def publish(self, key, data):
        self.bus.publish(key, data)

    def subscribe(self, key, callback):
        def maybe(k, data):
            if not (self.hide_state and k.endswith("/nav/state")):
                callback(k, data)

        return self.bus.subscribe(key, maybe)

    def token(self, key):
        return self.bus.token(key)

    def watch_tokens(self, key, callback):
        return self.bus.watch_tokens(key, callback)

    def get(self, selector, payload=None, timeout=5.0, urgent=False):
        self.sent.append((selector.split("/", 2)[2], codec.decode(payload, dict) if payload else {}))
        q = self.bus.query(selector, payload or b"")
        self.nav.drain()
        if not all(ok for ok, _ in q.replies):
            self.refused.set()
        return q.replies

    def close(self):
        """The library closes its bus: the rig stays up."""

    def drive(self, until, steps=MAX_STEPS):
        """Step until `until()` holds (bounded); how many steps it took."""
        for n in range(steps):
            if until():
                return n
            self.step()
        raise AssertionError(f"not done in {steps} steps")

    def goals_sent(self):
        """The requests of every goal query the library sent."""
        return [req for suffix, req in self.sent if suffix.startswith("nav/") and suffix not in ("nav/stop", "nav/status")]


def long_path(n, y=0.0):
    """A follow_path request of n points along y, ending 1 m out."""
    return {"points": [[1.0 * (i + 1) / n, y] for i in range(n)]}
