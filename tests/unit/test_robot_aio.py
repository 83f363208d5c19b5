"""The asyncio robot library against the real navigator on the in-memory bus (tests.support.navigator.World)."""

import asyncio

import pytest

from tests.support.navigator import MAX_STEPS
from zenav import aio
from zenav.robot import InvalidArgument


def test_an_awaitable_goal_with_feedback(world):
    async def main():
        async with aio.AsyncRobot("r1", bus=world) as bot:
            goal = await bot.move_to_point(0.2, 0.0)

            async def drive():
                for _ in range(MAX_STEPS):
                    if goal.done():
                        return
                    world.step()
                    await asyncio.sleep(0)  # let the watchers run

            driver = asyncio.create_task(drive())
            states = [st async for st in goal.updates(timeout=30)]
            await driver
            res = await goal
            assert res.succeeded and goal.result() is res and goal.feedback() is states[-1]
            assert states[0].distance_remaining > 0.15 and states[-1].result == "succeeded"
            assert not await bot.is_moving() and (await bot.pose()).x == pytest.approx(0.2, abs=0.01)

            held = await bot.move_straight(0.1)
            with pytest.raises(TimeoutError, match=f"goal {held.id} did not end in 0.01 s"):
                await held.wait(timeout=0.01)
            assert await held.cancel() and (await held.wait(timeout=0)).result == "cancelled"
            assert (await bot.status()).state == "STOPPED" and bot.lease_key is not None
            with pytest.raises(InvalidArgument, match="heading"):
                await bot.turn_to_heading(float("inf"))

    asyncio.run(main())


def test_wait_until_in_asyncio(world):
    async def main():
        async with aio.AsyncRobot("r1", bus=world) as bot:
            goal = await bot.move_to_point(0.4, 0.0)

            async def drive(until):
                for _ in range(MAX_STEPS):
                    if until():
                        return
                    world.step()
                    await asyncio.sleep(0)

            world.hide_state = True  # no nav/state: only the pose that takes it past the mark can wake the program
            driver = asyncio.create_task(drive(lambda: goal.travelled >= 0.25))
            # woken by that pose, long before its own timeout
            assert await asyncio.wait_for(goal.wait_until(0.25, timeout=30), 10) and not goal.done()
            await driver
            world.hide_state = False
            assert 0.25 <= goal.travelled < 0.26 and world.x == pytest.approx(goal.travelled, abs=0.01)
            await drive(goal.done)
            assert not await goal.wait_until(1.0, timeout=1)  # it ended at 0.4 m
            held = await bot.move_straight(0.1)
            with pytest.raises(TimeoutError, match="travelled 0.000 of 0.100 in 0.01 s"):
                await held.wait_until(0.1, timeout=0.01)
            await held.cancel()

    asyncio.run(main())


def test_updates_time_out(world):
    async def main():
        async with aio.AsyncRobot("r1", bus=world, lease=False) as bot:
            goal = await bot.turn_to_heading(1.0)
            with pytest.raises(TimeoutError, match=f"goal {goal.id} did not end in 0.01 s"):
                async for _ in goal.updates(timeout=0.01):
                    pass
            assert await bot.stop() == "STOPPED"

    asyncio.run(main())


def test_a_robot_not_open_refuses_use(world):
    bot = aio.AsyncRobot("r1", bus=world)
    with pytest.raises(RuntimeError, match="not open"):
        bot.sync.pose()


def test_arguments_the_robot_does_not_take_fail_at_once(world):
    with pytest.raises(TypeError, match="colour"):
        aio.AsyncRobot("r1", bus=world, colour="red")
    with pytest.raises(InvalidArgument, match="robot"):
        asyncio.run(aio.AsyncRobot("no such robot!", bus=world).open())


def test_drive_in_asyncio_commands_zero_when_done_and_when_cancelled(world):
    zero = (0.0, 0.0, 0.0)

    def sent() -> list[tuple[float, float, float]]:
        return [(c.t, c.v, c.omega) for c in world.published("cmd_vel")]

    async def main():
        async with aio.AsyncRobot("r1", bus=world) as bot:
            await bot.drive(0.1, 0.0, seconds=0.08)
            ours = [c for c in sent() if c != zero]
            assert len(ours) >= 2 and set(ours) == {(0.0, 0.1, 0.0)} and sent()[-1] == zero
            before, loop, driving = len(sent()), asyncio.get_running_loop(), asyncio.Event()
            world.bus.subscribe("zenav/r1/cmd_vel", lambda key, data: loop.call_soon_threadsafe(driving.set))
            task = asyncio.create_task(bot.drive(-0.1, 0.0, seconds=60.0))
            await asyncio.wait_for(driving.wait(), timeout=10)  # its first command
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            assert sent()[-1] == zero and (0.0, -0.1, 0.0) in sent()[before:]
            with pytest.raises(InvalidArgument, match="seconds"):
                await bot.drive(0.1, 0.0, seconds=-1.0)
            with pytest.raises(InvalidArgument, match="x, y, theta: none given"):
                await bot.set_pose()

    asyncio.run(main())


def test_the_old_name_zenav_aio_robot_still_works_and_warns():
    with pytest.warns(DeprecationWarning, match="zenav.aio.AsyncRobot"):
        assert aio.Robot is aio.AsyncRobot
