"""The goal machine among other robots: each pose, traffic.py decides whether the goal drives on (perhaps slower),
waits, steps aside or detours.

Pure, like the machine it extends: the pose and the other robots' bodies come in as arguments. Only goals through
points (move_to_point, move_to_pose, follow_path) are steered round robots, while they drive between their points
(not while turning at the end or settling); turns and straights are left to the motor's guard. A robot waits standing
(zero commanded, no progress expected, a fresh controller when it drives on) for at most `robot_wait` [s] in all
before it drives again; then the goal aborts (stalled) saying whom it waited for. A detour replaces the way's next
points up to where it rejoins them; its corners are passed within `waypoint_tolerance`. A slowed robot drives its
commands' forward speed times the decision's scale. It steps aside for a robot on its goal once per goal.
What it did is counted (`counts`, COUNTERS: the navigator's diag).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import replace

from zenav.common import messages as m
from zenav.common.config import Field
from zenav.common.contract import Exit, State
from zenav.services.navigator.controllers import PoseSample, Wheelbase
from zenav.services.navigator.goal import End, Goal, Run, behind, path_rest
from zenav.services.navigator.goals import GoalMachine
from zenav.services.navigator.params import Params
from zenav.services.navigator.traffic import Decision, Other, Traffic

REPLAN = 0.2  # [s] after a detour or a wait, decided again this much later (planning costs milliseconds)
STEERED = (State.MOVING_TO_POINT, State.MOVING_TO_POSE, State.FOLLOWING_PATH)
# diag counters: detours round robots taken, stops to wait for one, slowdowns to let one pass, steps aside
COUNTERS = ("robot_detours", "robot_waits", "robot_slowdowns", "robot_asides")

Command = tuple[float, float]


class TrafficMachine(GoalMachine):
    """A GoalMachine that gives way to, and drives round, other robots (`drive` in place of `on_pose`)."""

    def __init__(
        self,
        params: Params,
        wheels: Wheelbase,
        area: Field | None = None,
        gated: bool = True,
        traffic: Traffic | None = None,
    ) -> None:
        super().__init__(params, wheels, area, gated)
        self.traffic = traffic  # None: other robots are left to the guard
        self.waiting = ""  # the robot waited for now ("": none)
        self.why = ""  # why it waits, for nav/state ("": it does not)
        self.scale = 1.0  # [-] the fraction of the commanded forward speed driven now (< 1: letting a robot pass)
        self.counts: Counter[str] = Counter()  # COUNTERS, since the machine was made
        self._aside = False  # the running goal stepped aside already
        self._waited = 0.0  # [s] waited so far by the running goal
        self._since: float | None = None  # [s] pose t of the last pose waited on
        self._next = -math.inf  # [s] pose t from which to decide again
        self._own = 0  # the goal's first point of its own way (those before it and after run.index: a detour round robots)

    def start(self, goal: Goal, now: float) -> End | None:
        """Start a goal (GoalMachine.start), its waiting counted afresh."""
        self._waited, self._since, self.waiting, self.why, self._next = 0.0, None, "", "", -math.inf
        self.scale, self._aside, self._own = 1.0, False, 0
        return super().start(goal, now)

    def drive(self, pose: PoseSample, others: Sequence[Other]) -> tuple[Command | None, End | None]:
        """Take a pose among `others`: the command (None when idle), and the End if the goal ended."""
        run = self._run
        decision = Decision()
        if self.traffic is not None and run is not None and others and self._steered(run):
            if pose.t < self._next:  # decided a moment ago: as then (a wait goes on; a detour is driven)
                decision = Decision(self.waiting, self.why, scale=self.scale)
            else:
                way = run.goal.points[run.index :]
                base = max(self._own - run.index, 0)
                decision = self.traffic.decide((pose.x, pose.y), way, others, abs(run.goal.speed), not self._aside, base)
                if decision.detour is not None or decision.wait or decision.scale < 1.0:
                    self._next = pose.t + REPLAN
        if run is not None and decision.detour is not None:
            self._reroute(run, pose, decision)
        if run is None or decision.driving:
            return self._drive_on(pose, decision)
        if not self.waiting:
            self.counts["robot_waits"] += 1
        if self._since is not None:
            self._waited += max(pose.t - self._since, 0.0)
        self.waiting, self.why, self._since, self.scale = decision.wait, decision.why, pose.t, 1.0
        limit = self.params.robot_wait  # [s] of waiting in all, per goal
        if self._waited > limit:
            why = self.why
            self.waiting, self.why, self._since = "", "", None
            return (0.0, 0.0), self.abort(f"{why}: waited {self._waited:.1f} s, over robot_wait = {limit:g} s", Exit.STALLED)
        self._pause(run, pose)
        return (0.0, 0.0), None

    def _drive_on(self, pose: PoseSample, decision: Decision) -> tuple[Command | None, End | None]:
        """The goal's command for this pose, its forward speed scaled as decided."""
        if decision.scale < 1.0 and self.scale == 1.0:
            self.counts["robot_slowdowns"] += 1
        self.waiting, self.why, self._since, self.scale = "", decision.why, None, decision.scale
        cmd, end = self.on_pose(pose)
        if cmd is not None and end is None and self.scale < 1.0:
            cmd = self._cmd = (cmd[0] * self.scale, cmd[1])
        return cmd, end

    def way(self, points: int = m.WAY_POINTS) -> tuple[tuple[float, float], ...]:
        """The next `points` points the running goal drives through while steered round robots and driving (else none):
        told to the other robots (in its commands, which the motor's body carries) so that they see where it goes."""
        run = self._run
        if run is None or self.traffic is None or not self._steered(run) or self.waiting:
            return ()
        return tuple((p[0], p[1]) for p in run.goal.points[run.index : run.index + points])

    @staticmethod
    def _steered(run: Run) -> bool:
        """Whether the run drives between points now (not turning at its end, facing, settling or chained)."""
        return run.goal.state in STEERED and run.settle_from is None and not run.turning and not run.facing and run.exit is None

    def _pause(self, run: Run, pose: PoseSample) -> None:
        """Stand still on this pose: zero commanded, the progress check restarted, a fresh controller for later."""
        self._lag(pose.t)
        self.pose = pose
        self._cmd = (0.0, 0.0)
        run.best, run.locked = None, False
        self._aim(run, behind(pose) if run.sign < 0.0 else pose)

    def _reroute(self, run: Run, pose: PoseSample, decision: Decision) -> None:
        """The way's next points up to `rejoin` replaced by the detour."""
        assert decision.detour is not None
        self.counts["robot_asides" if decision.aside else "robot_detours"] += 1
        self._aside = self._aside or decision.aside
        goal, i, k = run.goal, run.index, decision.rejoin
        tols = [self._point_tolerance(run, j) for j in range(len(goal.points))]
        corners = len(decision.detour) - 1
        points = goal.points[:i] + decision.detour + goal.points[i + k + 1 :]
        tolerances = tols[:i] + [self.params.waypoint_tolerance] * corners + tols[i + k :]
        run.goal = replace(goal, points=tuple(points), point_tolerances=tuple(tolerances))
        self._own = i if decision.aside else i + corners  # a step aside is the way now: driven to, not replaced
        run.rest = path_rest(run.goal.points)
        run.locked = False
        self._aim(run, behind(pose) if run.sign < 0.0 else pose)
