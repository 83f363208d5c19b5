"""A competition-style autonomous routine: `python examples/autonomous.py`.

Out to a game piece with the intake started partway (`wait_until`, as LemLib's
waitUntil), chained into a turn toward a second one without stopping (`min_speed`,
LemLib's motion chaining), then backing into a scoring zone (`forwards=False`), the
back turned to where the pieces were, and backing home. The intake and the scoring
are prints here.
Runs against a running stack (`zenav up`); ZENOH_CONNECT picks the router.
"""

from zenav import Robot


def intake(on: bool) -> None:
    print(f"intake {'on' if on else 'off'}", flush=True)


with Robot() as bot:
    bot.wait_ready()
    results = []
    goal = bot.move_to_point(0.4, 0.0, speed=0.2, min_speed=0.1, early_exit_range=0.02)  # ends at speed, 2 cm before
    if goal.wait_until(0.25):  # False if the move ended short of it
        intake(True)
        print(f"  after {goal.travelled:.3f} m of the move", flush=True)
    results.append(goal.wait())
    results.append(bot.move_to_point(0.5, 0.2).wait())  # sent at once: it takes over at speed
    intake(False)
    results.append(bot.move_to_point(0.3, 0.3, forwards=False).wait())  # the back leads
    results.append(bot.turn_to_point(0.5, 0.0, forwards=False).wait())  # the back to where the piece was
    print("score", flush=True)
    results.append(bot.move_to_pose(0.0, 0.0, 0.0, forwards=False).wait())  # home, facing +x as it started
    for result in results:
        print(result, flush=True)
    raise SystemExit(0 if all(r.succeeded for r in results) else 1)
