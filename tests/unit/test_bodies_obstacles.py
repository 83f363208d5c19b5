"""The sim's bodies among the field's obstacles: a footprint driven into a box or a post is held at contact."""

import math

from zenav.common.config import Settings
from zenav.common.field import circle_shape, polygon_shape
from zenav.common.scenarios import scenario
from zenav.world.bodies import block
from zenav.world.sim import SimRobot

BOX = polygon_shape("box", [[0.55, -0.1], [0.75, -0.1], [0.75, 0.1], [0.55, 0.1]])


def test_a_step_into_a_box_is_held_at_contact_and_named():
    x, y, met = block(0.44, 0.0, 0.47, 0.0, 0.1, {}, None, (BOX,))
    assert met == ["box"] and x <= 0.45 + 1e-12 and BOX.clearance(x, y) >= 0.1 - 1e-12
    assert block(0.44, 0.0, 0.41, 0.0, 0.1, {}, None, (BOX,)) == (0.41, 0.0, [])  # away from it: free


def test_a_glancing_step_along_a_post_slides_round_it():
    post = circle_shape("post", [1.0, 0.0, 0.1])
    x, y, met = block(0.8, 0.05, 0.82, 0.07, 0.1, {}, None, (post,))
    assert met == ["post"] and math.hypot(x - 1.0, y) >= 0.2 - 1e-12 and y > 0.05


def test_the_sim_robot_keeps_out_of_the_fields_obstacles():
    settings = Settings.load(None, field={"file": "table"})
    bot = SimRobot(settings.robot, scenario("default"), 1, body_radius=0.1, obstacles=settings.field.shapes())
    for _ in range(400):  # 4 s at 0.3 m/s: 1.2 m straight on, through the box without it
        bot.drive(0.3, 0.0, 0.01)
    box = settings.field.shapes()[0]
    assert box.clearance(bot.state.x, bot.state.y) >= 0.1 - 1e-9 and "obstacles[0] 'box'" in bot.met
