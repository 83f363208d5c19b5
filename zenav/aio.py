"""The robot library for asyncio programs: `zenav.robot`'s methods as coroutines.

    import asyncio
    from zenav.aio import AsyncRobot

    async def main() -> None:
        async with AsyncRobot("r1") as bot:
            await bot.wait_ready()
            goal = await bot.move_to_point(1.0, 0.0)
            async for state in goal.updates():
                print(state.distance_remaining)
            print(await goal)                  # a Goal is awaitable: its Result

    asyncio.run(main())

Built on the synchronous `zenav.robot.Robot`: queries run in a worker thread, and
goal ends and progress wake the event loop from Zenoh's thread, so waiting on a
goal holds no thread.
"""

from __future__ import annotations

import asyncio
import functools
import warnings
from collections.abc import AsyncIterator, Awaitable, Callable, Coroutine, Generator, Iterable
from typing import Any

from zenav.common import messages as m
from zenav.common.client import QueryBus
from zenav.common.goalschema import GoalSpec
from zenav.common.roles import DRIVE_SERVICES
from zenav.goalapi import GoalMethods
from zenav.robot import CONNECT_TIMEOUT, DRIVE_PERIOD, POSE_TIMEOUT, QUERY_TIMEOUT, Result
from zenav.robot import Goal as SyncGoal
from zenav.robot import Robot as SyncRobot

__all__ = ["AsyncRobot", "Goal"]


async def _within(aw: Awaitable[object], timeout: float | None) -> bool:
    """Await `aw`; False (and `aw` cancelled) if it did not finish in `timeout` seconds (None: no limit)."""
    try:
        await asyncio.wait_for(aw, timeout)
    except asyncio.TimeoutError:  # Python 3.10's is not the built-in TimeoutError
        return False
    return True


class Goal:
    """A goal the navigator took; `await goal` is `await goal.wait()`."""

    def __init__(self, robot: AsyncRobot, goal: SyncGoal) -> None:
        self.id, self.reply = goal.id, goal.reply
        self._robot, self._goal = robot, goal

    def __repr__(self) -> str:
        return repr(self._goal)

    def __await__(self) -> Generator[Any, None, Result]:
        return self.wait().__await__()

    def done(self) -> bool:
        """Whether the goal has ended."""
        return self._goal.done()

    def result(self) -> Result | None:
        """How the goal ended; None while it runs."""
        return self._goal.result()

    def feedback(self) -> m.NavState | None:
        """The newest nav/state of this goal; None before the first."""
        return self._goal.feedback()

    @property
    def travelled(self) -> float:
        """How far the robot has travelled since the goal started [m] (a turn: turned [rad])."""
        return self._goal.travelled

    async def wait_until(self, distance: float, timeout: float | None = None) -> bool:
        """True once the robot has travelled `distance` [m] (a turn: turned [rad]) in this goal; False if the goal
        ended short of it; TimeoutError if neither happened in `timeout` seconds."""

        async def reached() -> None:
            with self._goal._marked(distance):
                await self._robot._until(functools.partial(self._goal._reached, distance))

        if not await _within(reached(), timeout):
            try:
                return await asyncio.to_thread(self._goal.wait_until, distance, 0.0)  # asks nav/status whether it ended unseen
            except TimeoutError:
                raise TimeoutError(f"goal {self.id} travelled {self.travelled:.3f} of {distance:.3f} in {timeout} s") from None
        return self._goal.wait_until(distance, 0.0)

    async def cancel(self) -> bool:
        """Stop the robot if this goal is still the running one; whether it was."""
        return await asyncio.to_thread(self._goal.cancel)

    async def wait(self, timeout: float | None = None) -> Result:
        """The goal's Result once it ends; TimeoutError if it did not end in `timeout` seconds."""
        if not await _within(self._robot._until(self._goal.done), timeout):
            try:
                return await asyncio.to_thread(self._goal.wait, 0.0)  # asks nav/status whether it ended unseen
            except TimeoutError:
                raise TimeoutError(f"goal {self.id} did not end in {timeout} s") from None
        return self._goal.wait(0.0)

    async def updates(self, timeout: float | None = None) -> AsyncIterator[m.NavState]:
        """Each new nav/state of this goal (the newest, if several came since the last), until it ends."""
        last: m.NavState | None = None
        loop = asyncio.get_running_loop()
        deadline = None if timeout is None else loop.time() + timeout
        while True:
            left = None if deadline is None else max(0.0, deadline - loop.time())
            if not await _within(self._robot._until(functools.partial(self._news, last)), left):  # never across a yield
                raise TimeoutError(f"goal {self.id} did not end in {timeout} s")
            st, ended = self._goal.feedback(), self._goal.done()
            if st is not None and st is not last:
                last = st
                yield st
            if ended:
                return

    def _news(self, last: m.NavState | None) -> bool:
        """Whether a nav/state newer than `last` came, or the goal ended."""
        return self._goal.feedback() is not last or self._goal.done()


class AsyncRobot(GoalMethods[Coroutine[Any, Any, Goal]]):
    """One robot's navigation and localization, for asyncio programs (see `zenav.robot.Robot`).

    The goal methods are zenav.robot.Robot's (zenav.goalapi): here each returns a coroutine of the Goal."""

    def __init__(
        self,
        robot: str | None = None,
        connect: str | None = None,
        *,
        mode: str | None = None,
        lease: bool = True,
        connect_timeout: float = CONNECT_TIMEOUT,
        timeout: float = QUERY_TIMEOUT,
        bus: QueryBus | None = None,
    ) -> None:
        """The arguments of `zenav.robot.Robot`; `open()` (or `async with`) connects."""
        self._connect = functools.partial(
            SyncRobot, robot, connect, mode=mode, lease=lease, connect_timeout=connect_timeout, timeout=timeout, bus=bus
        )
        self._sync: SyncRobot | None = None
        self._changed = asyncio.Event()  # replaced by a fresh one at each change

    async def __aenter__(self) -> AsyncRobot:
        return await self.open()

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    async def open(self) -> AsyncRobot:
        """Connect (Unavailable if no router answers within connect_timeout)."""
        if self._sync is None:
            loop = asyncio.get_running_loop()
            self._sync = await asyncio.to_thread(self._connect)

            def wake() -> None:
                try:
                    loop.call_soon_threadsafe(self._wake)
                except RuntimeError:  # the loop is closed
                    pass

            self._sync.on_change(wake)
        return self

    async def close(self) -> None:
        """Withdraw the lease (the navigator stops a goal of this robot's) and close the session."""
        if self._sync is not None:
            await asyncio.to_thread(self._sync.close)

    @property
    def sync(self) -> SyncRobot:
        """The synchronous robot underneath."""
        if self._sync is None:
            raise RuntimeError("the robot is not open: use `async with AsyncRobot(...)` or `await robot.open()`")
        return self._sync

    @property
    def lease_key(self) -> str | None:
        """The liveliness key sent as every goal's lease (None without a lease)."""
        return self.sync.lease_key

    async def wait_ready(self, timeout: float = 30.0, services: Iterable[str] = DRIVE_SERVICES) -> None:
        """Until the navigator would take a goal (see `zenav.robot.Robot.wait_ready`)."""
        await asyncio.to_thread(self.sync.wait_ready, timeout, tuple(services))

    async def drive(self, v: float, omega: float = 0.0, seconds: float = 0.0) -> None:
        """Drive open loop at v [m/s] and omega [rad/s] for `seconds`, then command zero (see `zenav.robot.Robot.drive`);
        cancelled meanwhile, it commands zero."""
        cmd = await asyncio.to_thread(self.sync._drive_command, v, omega, seconds)
        loop = asyncio.get_running_loop()
        end = loop.time() + seconds
        try:
            while True:
                self.sync.client.publish("cmd_vel", cmd)
                left = end - loop.time()
                if left <= 0.0:
                    return
                await asyncio.sleep(min(DRIVE_PERIOD, left))
        finally:
            self.sync.client.publish("cmd_vel", m.CmdVel(t=0.0, v=0.0, omega=0.0))

    async def stop(self) -> str:
        """Cancel whatever goal runs and command zero at once; the navigator's state."""
        return await asyncio.to_thread(self.sync.stop)

    async def is_moving(self) -> bool:
        """Whether a goal runs."""
        return await asyncio.to_thread(self.sync.is_moving)

    async def pose(self, timeout: float = POSE_TIMEOUT) -> m.Pose:
        """The newest pose; Unavailable if none comes in `timeout` s."""
        return await asyncio.to_thread(self.sync.pose, timeout)

    async def set_pose(self, x: float | None = None, y: float | None = None, theta: float | None = None) -> m.PoseStamped:
        """Tell the localizer where the robot is (at least one of x, y, theta: else InvalidArgument, nothing sent); the pose it took."""
        return await asyncio.to_thread(self.sync.set_pose, x, y, theta)

    async def status(self) -> m.StatusReply:
        """The navigator's nav/status."""
        return await asyncio.to_thread(self.sync.status)

    # ------------------------------------------------------------ internals
    def _send(self, spec: GoalSpec, fields: dict[str, Any]) -> Coroutine[Any, Any, Goal]:
        return self._goal(spec, fields)

    async def _goal(self, spec: GoalSpec, fields: dict[str, Any]) -> Goal:
        return Goal(self, await asyncio.to_thread(self.sync._send, spec, fields))

    def _wake(self) -> None:
        event, self._changed = self._changed, asyncio.Event()
        event.set()

    async def _until(self, ready: Callable[[], bool]) -> None:
        """Return once `ready()` holds, checking at each change a goal may have seen."""
        while True:
            event = self._changed
            if ready():
                return
            await event.wait()


def __getattr__(name: str) -> Any:
    """`zenav.aio.Robot`, the name of earlier releases: AsyncRobot, with a DeprecationWarning."""
    if name == "Robot":
        warnings.warn("zenav.aio.Robot is now zenav.aio.AsyncRobot", DeprecationWarning, stacklevel=2)
        return AsyncRobot
    raise AttributeError(f"module 'zenav.aio' has no attribute {name!r}")
