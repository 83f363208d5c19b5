"""The overhead camera's model: geometry, and frames rendered from the truth."""

import math

import cv2
import msgspec
import numpy as np
import pytest

from zenav.common.config import Camera
from zenav.world.camera import TAG_CELLS, TAG_QUIET, Lens, Mount, pixel_rays, plane_hits, project, tag_bitmap
from zenav.world.render import Body, Renderer

TILTED = Camera(yaw=0.2, tilt=0.04, k1=-0.1, k2=0.02)
SMALL = Camera(width=160, height=120, fx=133.25, fy=133.25)  # the default view at a quarter of the resolution (quicker)


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return Renderer(TILTED, seed=3)


def test_a_ray_through_a_projected_point_comes_back_to_it():
    lens, mount = Lens.of(TILTED), Mount.of(TILTED)
    pts = np.array([(0.0, 0.0, 0.0), (1.3, -0.2, 0.0), (-0.5, 1.2, 0.12)])
    px = project(lens, mount, pts)
    rays = pixel_rays(lens, mount, px[:, 0], px[:, 1])
    for (x, y, z), ray in zip(pts, rays):
        hx, hy = plane_hits(mount, ray, z)
        assert (hx, hy) == pytest.approx((x, y), abs=1e-6)


def test_the_image_reads_like_a_map():
    lens, mount = Lens.of(Camera(k1=0.0)), Mount.of(Camera(k1=0.0))
    centre, east, north = project(lens, mount, np.array([(0.5, 0.5, 0.0), (1.0, 0.5, 0.0), (0.5, 1.0, 0.0)]))
    assert centre == pytest.approx((320.0, 240.0))
    assert east[0] > centre[0] and east[1] == pytest.approx(centre[1])  # +x: right
    assert north[1] < centre[1] and north[0] == pytest.approx(centre[0])  # +y: up


def test_a_tag_as_printed_has_its_black_border_and_white_margin():
    b = tag_bitmap(5)
    n = TAG_CELLS + 2 * TAG_QUIET
    assert b.shape == (n, n)
    assert b[0].all() and b[:, 0].all()  # white margin
    assert not b[1, 1:-1].any() and not b[1:-1, 1].any()  # black border
    assert not np.array_equal(b, tag_bitmap(6))


def test_frames_are_deterministic_for_a_seed(renderer):
    bodies = [Body(0, 0.2, 0.3, 1.0, 0.3, 0.5)]
    again = Renderer(TILTED, seed=3)
    other = Renderer(TILTED, seed=4)  # the same view: only the noise differs
    a, b, c = renderer.render(1.0, bodies), again.render(1.0, bodies), other.render(1.0, bodies)
    assert a.shape == (480, 640) and a.dtype == np.uint8
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_the_robot_is_drawn_where_it_is(renderer):
    lens, mount = Lens.of(TILTED), Mount.of(TILTED)
    empty = renderer.render(0.0, []).astype(float)
    img = renderer.render(0.0, [Body(0, 0.8, 0.6, 0.0)]).astype(float)
    changed = np.argwhere(np.abs(img - empty) > 40)
    centre = changed.mean(axis=0)[::-1]  # (u, v)
    expect = project(lens, mount, np.array([(0.8, 0.6, TILTED.tag_height)]))[0]
    assert np.hypot(*(centre - expect)) < 3.0


def test_motion_blurs_the_tag(renderer):
    def sharpness(img: np.ndarray) -> float:
        return float(np.abs(np.diff(img.astype(float), axis=1)).max())

    still = msgspec.structs.replace(SMALL, noise=0.0, lighting=0.0, exposure=0.05)
    r = Renderer(still, seed=1)
    sharp = r.render(0.0, [Body(0, 0.5, 0.5, 0.0)])[40:80, 60:100]
    moving = r.render(0.0, [Body(0, 0.5, 0.5, 0.0, v=1.0)])[40:80, 60:100]
    assert len(r.poses(Body(0, 0.5, 0.5, 0.0, v=1.0))) > 4
    assert sharpness(moving) < 0.8 * sharpness(sharp)


def test_the_light_changes_over_time_and_noise_is_there(renderer):
    a, b = (renderer.render(t, []).astype(float) for t in (0.0, 5.5))
    assert abs(a.mean() - b.mean()) > 10.0  # the light swings (15 %)
    flat = Renderer(msgspec.structs.replace(SMALL, lighting=0.0, noise=0.0), seed=1)
    assert np.array_equal(flat.render(0.0, []), flat.render(2.0, []))
    noisy = Renderer(msgspec.structs.replace(SMALL, lighting=0.0, noise=5.0), seed=1)
    diff = noisy.render(0.0, []).astype(float) - noisy.render(1.0, []).astype(float)
    assert math.isclose(diff.std(), 5.0 * math.sqrt(2), rel_tol=0.2)


def test_a_frame_leaves_no_trace_on_the_next() -> None:
    r = Renderer(msgspec.structs.replace(SMALL, noise=0.0), seed=1)
    empty = r.render(0.0, [])
    robots = [Body(0, 0.5, 0.5, 0.0, v=0.5), Body(1, 0.55, 0.5, 1.0)]  # overlapping
    first = r.render(0.0, robots)
    kept = first.copy()
    assert not np.array_equal(first, empty)
    assert np.array_equal(r.render(0.0, []), empty)
    assert np.array_equal(first, kept)  # a frame is its own array, not drawn over by the next
    with pytest.raises(cv2.error):  # no such tag: the frame fails after the first robot is drawn
        r.render(0.0, [robots[0], Body(10**6, 0.0, 0.0, 0.0)])
    assert np.array_equal(r.render(0.0, []), empty)
    assert np.array_equal(r.render(0.0, robots), first)


def test_a_robot_standing_still_is_drawn_over_what_is_under_it_now() -> None:
    cfg = msgspec.structs.replace(SMALL, noise=0.0)
    r = Renderer(cfg, seed=1)
    still = Body(0, 0.5, 0.5, 0.3)
    for k in range(3):  # the other robot, drawn first, passes under the still one's edge
        bodies = [Body(1, 0.3 + 0.1 * k, 0.42, 0.0, v=0.2), still]
        assert np.array_equal(r.render(0.1 * k, bodies), Renderer(cfg, seed=1).render(0.1 * k, bodies))
    turned = Body(0, 0.5, 0.5, 1.2)  # the same box, over the same floor
    for b in (still, turned):
        assert np.array_equal(r.render(0.0, [b]), Renderer(cfg, seed=1).render(0.0, [b]))


def test_a_frame_is_the_floor_under_the_light() -> None:
    r = Renderer(msgspec.structs.replace(TILTED, noise=0.0), seed=1)
    for t in (0.0, 1.7, 5.5):
        lit = np.clip(r.background * r.light(t), 0.0, 255.0).astype(np.uint8)
        assert np.array_equal(r.render(t, []), lit)
