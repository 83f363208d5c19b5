"""Follow a path and call a function as each point is passed: `python examples/path_callbacks.py`.

nav/state's next_point is the index of the point being approached: when it moves
on, the points before it have been passed (the last one when the goal succeeds).
Runs against a running stack (`zenav up`); ZENOH_CONNECT picks the router.
"""

from collections.abc import Sequence

from zenav import Robot

PATH = [(0.4, 0.0), (0.4, 0.4), (0.0, 0.4), (0.0, 0.0)]  # [m] map frame


def passed(index: int, point: Sequence[float]) -> None:
    """What to do at each point: here, say so."""
    print(f"passed point {index} at {point}", flush=True)


def main() -> int:
    with Robot() as bot:
        bot.wait_ready()
        goal = bot.follow_path(PATH, speed=0.2)
        done = 0  # points passed so far
        for state in goal.updates():
            reached = len(PATH) if state.result == "succeeded" else state.next_point or 0
            for index in range(done, reached):
                passed(index, PATH[index])
            done = max(done, reached)
        result = goal.wait()
        print(result)
        return 0 if result.succeeded else 1


if __name__ == "__main__":
    raise SystemExit(main())
