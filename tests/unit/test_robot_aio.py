"""The asyncio robot library against the real navigator on the in-memory bus (tests.support.navigator.World)."""

import asyncio

import pytest

from tests.support.navigator import MAX_STEPS
from zenav import aio
from zenav.robot import InvalidArgument


def test_an_awaitable_goal_with_feedback(world):
    async def main():
        async with aio.Robot("r1", bus=world) as bot:
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


def test_updates_time_out(world):
    async def main():
        async with aio.Robot("r1", bus=world, lease=False) as bot:
            goal = await bot.turn_to_heading(1.0)
            with pytest.raises(TimeoutError, match=f"goal {goal.id} did not end in 0.01 s"):
                async for _ in goal.updates(timeout=0.01):
                    pass
            assert await bot.stop() == "STOPPED"

    asyncio.run(main())


def test_a_robot_not_open_refuses_use(world):
    bot = aio.Robot("r1", bus=world)
    with pytest.raises(RuntimeError, match="not open"):
        bot.sync.pose()


def test_arguments_the_robot_does_not_take_fail_at_once(world):
    with pytest.raises(TypeError, match="colour"):
        aio.Robot("r1", bus=world, colour="red")
    with pytest.raises(InvalidArgument, match="robot"):
        asyncio.run(aio.Robot("no such robot!", bus=world).open())
