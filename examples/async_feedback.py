"""Watch a goal's feedback from an asyncio program: `python examples/async_feedback.py`.

While the robot drives, the program prints the distance left and the ETA from
nav/state; another task could do anything else meanwhile. Runs against a running
stack (`zenav up`); ZENOH_CONNECT picks the router.
"""

import asyncio

from zenav.aio import AsyncRobot


def number(value: float | None, unit: str) -> str:
    return "-" if value is None else f"{value:.2f} {unit}"


async def main() -> int:
    async with AsyncRobot() as bot:
        await bot.wait_ready()
        results = []
        for x, y in [(0.5, 0.0), (0.0, 0.0)]:
            goal = await bot.move_to_point(x, y, speed=0.2)
            async for state in goal.updates():
                if state.result is None:
                    print(f"goal {goal.id}: {number(state.distance_remaining, 'm')} to go, eta {number(state.eta, 's')}", flush=True)
            results.append(await goal)  # a goal is awaitable: its Result
            print(results[-1], flush=True)
        return 0 if all(r.succeeded for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(asyncio.run(main()))
