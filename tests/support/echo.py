"""A service with a handler of each runtime kind, for the runtime's tests on the in-memory bus."""

from zenav.common import messages as m
from zenav.common.runtime import QueryError, Service, on_liveliness, publish, query, subscribe, timer


class Echo(Service):
    """Named motor: cmd_vel to wheels, a 0.5 s timer, the navigator's liveliness, and set_pose."""

    name = "motor"

    def __init__(self, *a):
        super().__init__(*a)
        self.ticks = []
        self.held = None

    @subscribe("cmd_vel")
    @publish("motors/wheels")
    def on_cmd(self, msg: m.CmdVel) -> m.Wheels:
        if msg.v > 100:
            raise RuntimeError("boom")
        return m.Wheels(t=msg.t, left=msg.v, right=msg.omega)

    @timer(0.5)
    def tick(self, now: float) -> None:
        self.ticks.append(now)

    @on_liveliness("navigator")
    @publish("motors/wheels")
    def navigator_presence(self, alive: bool):
        self.navigator_alive = alive
        return None if alive else m.Wheels(t=0.0, left=0.0, right=0.0)

    @query("localizer/set_pose")
    def set_pose(self, req: m.SetPose, q):
        if req.x == 13.0:
            raise QueryError("unavailable", "unlucky")
        if req.x == 7.0:
            self.held = q  # answered later
            return None
        return m.PoseStamped(t=0.0, x=req.x or 0.0, y=req.y or 0.0, theta=0.0)
