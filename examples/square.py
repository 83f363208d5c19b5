"""Drive in a square, as seed 003's navigation example: `python examples/square.py`.

Runs against a running stack (`zenav up`); ZENOH_CONNECT picks the router.
"""

from zenav import Robot

with Robot() as bot:
    bot.wait_ready()
    for x, y in [(0.5, 0.0), (0.5, 0.5), (0.0, 0.5), (0.0, 0.0)]:
        print(bot.move_to_point(x, y, speed=0.2, tolerance=0.01).wait())
