"""The robot library's goal methods, declared once for `zenav.robot.Robot` and `zenav.aio.AsyncRobot`.

Each method takes its goal's fields (common/goalschema.py: a test holds them equal) and hands them to the robot's
`_send`, which the synchronous robot answers with a `Goal` and the asyncio one with a coroutine of its `Goal`.
Units are the contract's: metres, radians, seconds.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any, Generic, TypeVar

from zenav.common.goalschema import GOALS, GoalSpec

G = TypeVar("G")


class GoalMethods(Generic[G]):
    """The goals a robot drives; `_send` makes each a request and sends it."""

    def _send(self, spec: GoalSpec, fields: dict[str, Any]) -> G:
        raise NotImplementedError

    def move_to_point(
        self,
        x: float,
        y: float,
        *,
        speed: float | None = None,
        tolerance: float | None = None,
        timeout: float | None = None,
        forwards: bool = True,
        plan: bool = True,
        min_speed: float | None = None,
        early_exit_range: float | None = None,
    ) -> G:
        """Drive to (x [m], y [m]) in the map frame; speed [m/s] and tolerance [m] default to the navigator's.

        Every goal but move_straight also takes:
        `timeout` [s]: the move stops after this long, exit `timeout`;
        `min_speed` [m/s, rad/s for turns] > 0: a chained goal (LemLib's motion chaining) that never slows below it
        and ends at speed (exit `chained`) `early_exit_range` [m, rad] before its target: send the next goal at once;
        and but for turn_to_heading and swing_to_heading, `forwards=False`: the robot's back leads.
        `plan=False` (move_to_point, move_to_pose, follow_path): straight, not round the field's obstacles.
        """
        return self._send(GOALS["move_to_point"], locals())

    def move_to_pose(
        self,
        x: float,
        y: float,
        theta: float,
        *,
        speed: float | None = None,
        tolerance: float | None = None,
        heading_tolerance: float | None = None,
        lead: float | None = None,
        timeout: float | None = None,
        forwards: bool = True,
        plan: bool = True,
        min_speed: float | None = None,
        early_exit_range: float | None = None,
    ) -> G:
        """Drive to (x [m], y [m]) and arrive with heading `theta` [rad] (of the robot's front, backing in too);
        tolerances [m] and [rad]; `lead` [0..1] how far the boomerang's carrot sits before the point, per metre to it."""
        return self._send(GOALS["move_to_pose"], locals())

    def turn_to_heading(
        self,
        heading: float,
        *,
        speed: float | None = None,
        tolerance: float | None = None,
        timeout: float | None = None,
        direction: str = "auto",
        min_speed: float | None = None,
        early_exit_range: float | None = None,
    ) -> G:
        """Turn in place to `heading` [rad, CCW from +x]; speed [rad/s], tolerance [rad];
        `direction` "cw" or "ccw": that way round, the long way if need be ("auto": the shorter way)."""
        return self._send(GOALS["turn_to_heading"], locals())

    def swing_to_heading(
        self,
        heading: float,
        side: str,
        *,
        speed: float | None = None,
        tolerance: float | None = None,
        timeout: float | None = None,
        direction: str = "auto",
        min_speed: float | None = None,
        early_exit_range: float | None = None,
    ) -> G:
        """Turn to `heading` [rad] about one wheel, `side` "left" or "right", which stays still (LemLib's swingToHeading);
        the options as turn_to_heading's."""
        return self._send(GOALS["swing_to_heading"], locals())

    def turn_to_point(
        self,
        x: float,
        y: float,
        *,
        speed: float | None = None,
        tolerance: float | None = None,
        timeout: float | None = None,
        forwards: bool = True,
        direction: str = "auto",
        min_speed: float | None = None,
        early_exit_range: float | None = None,
    ) -> G:
        """Turn in place to face (x [m], y [m]), or to turn the back to it; speed [rad/s], tolerance [rad]; `direction`
        as turn_to_heading's."""
        return self._send(GOALS["turn_to_point"], locals())

    def move_straight(self, speed: float, *, distance: float | None = None) -> G:
        """Drive on the current heading at `speed` [m/s, negative reverses], for `distance` [m] or until stopped."""
        return self._send(GOALS["move_straight"], locals())

    def follow_path(
        self,
        points: Iterable[Sequence[float]],
        *,
        speed: float | None = None,
        tolerance: float | None = None,
        waypoint_tolerance: float | None = None,
        timeout: float | None = None,
        forwards: bool = True,
        plan: bool = True,
        min_speed: float | None = None,
        early_exit_range: float | None = None,
    ) -> G:
        """Drive through the points in order, (x [m], y [m]) or (x, y, tolerance [m]); nav/state's next_point says
        which is next. `tolerance` is the last point's, `waypoint_tolerance` the others' that name none."""
        points = [list(p) for p in points]
        return self._send(GOALS["follow_path"], locals())
