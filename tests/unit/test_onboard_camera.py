"""A camera on the robot: its config checked at start, what it sees of the field's tags, and the pose solved from them."""

import math

import numpy as np
import pytest

from zenav.common.config import ConfigError, Settings
from zenav.common.field import polygon_shape
from zenav.common.onboardcam import OnboardCamera
from zenav.services.vps import detect, onboard
from zenav.world.onboard import OnboardRenderer, mount, sightings

FIELD = Settings.load(None).field  # the default field: three tags on each wall
LAYOUT = {t.id: t for t in FIELD.tags}
CFG = OnboardCamera(noise=0.0)


@pytest.fixture(scope="module")
def renderer():
    return OnboardRenderer(CFG, FIELD.tags, FIELD.shapes(), seed=1)


@pytest.fixture(scope="module")
def detector():
    return detect.make("opencv", 24.0)


@pytest.mark.parametrize(
    ("section", "error"),
    [
        ({"cx": 700.0}, "cx = 700 px lies outside the 640 x 480 frame"),
        ({"width": 320, "cy": 300.0, "height": 240}, "cy = 300 px lies outside the 320 x 240 frame"),
        ({"fx": 20.0}, "fx = 20 px on a 640 px side is a field of view over 170 deg"),
        ({"pitch": 2.0}, "pitch"),
    ],
)
def test_intrinsics_that_do_not_fit_the_frame_are_refused_at_start(section, error):
    with pytest.raises(ConfigError, match=error):
        Settings.load(None, onboard_camera=section).section("onboard_camera", OnboardCamera)


def test_the_camera_sees_the_tags_it_faces_and_none_behind_it_or_behind_an_obstacle():
    def seen(x, y, theta, shapes=()):
        return sorted(s.tag.id for s in sightings(CFG, mount(CFG, x, y, theta), FIELD.tags, shapes))

    assert seen(1.0, 1.0, 0.0) == [1, 2, 3]  # the east wall's
    assert seen(1.0, 1.0, math.pi) == [7, 8, 9]  # the west wall's
    wall = polygon_shape("wall", [[2.0, 0.8], [2.1, 0.8], [2.1, 1.2], [2.0, 1.2]])
    assert seen(1.0, 1.0, 0.0, [wall]) == [1, 3]  # tag 2 hides behind it
    assert seen(2.0, 0.3, -0.8) == []  # the wall's tags out of the frame's sides
    near = sightings(CFG, mount(CFG, 1.0, 1.0, 0.0), FIELD.tags, ())
    assert all(0.0 < s.distance < 3.0 for s in near)


def test_each_tag_in_a_frame_is_read_at_its_true_corners(renderer, detector):
    cam = mount(CFG, 0.4, 0.6, 0.2)
    truth = {s.tag.id: s.corners for s in sightings(CFG, cam, FIELD.tags, ())}
    found = detector.detect(renderer.render(0.4, 0.6, 0.2))
    assert sorted(t.id for t in found) == sorted(truth) and len(truth) >= 2
    for t in found:
        assert np.abs(t.corners - truth[t.id]).max() < 0.5  # [px]


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (1.0, 1.0, math.pi / 2), (1.0, 1.0, math.pi), (0.5, 0.5, 0.3)])
def test_several_tags_give_the_pose_within_a_centimetre(renderer, detector, pose):
    fix = onboard.solve(detector.detect(renderer.render(*pose)), LAYOUT, CFG)
    assert isinstance(fix, onboard.TagFix) and len(fix.tags) >= 2
    assert math.hypot(fix.x - pose[0], fix.y - pose[1]) < 0.01
    assert abs(math.remainder(fix.theta - pose[2], math.tau)) < math.radians(0.5)


def test_the_covariance_grows_with_distance_and_shrinks_with_the_tag_count(renderer, detector):
    def sigma(pose, keep=None):
        found = [t for t in detector.detect(renderer.render(*pose)) if keep is None or t.id in keep]
        fix = onboard.solve(found, LAYOUT, CFG)
        assert isinstance(fix, onboard.TagFix)
        return math.sqrt(fix.cov[0] + fix.cov[4])

    assert sigma((2.0, 1.0, 0.0), {2}) < sigma((1.0, 1.0, 0.0), {2}) < sigma((0.0, 1.0, 0.0), {2})
    assert sigma((1.0, 1.0, 0.0)) < sigma((1.0, 1.0, 0.0), {1, 2}) < sigma((1.0, 1.0, 0.0), {2})


def test_an_ambiguous_single_tag_is_refused_unless_the_estimate_picks_one_of_its_poses(renderer, detector):
    pose = (0.5, 0.5, 0.2)  # tag 2, 2.6 m off, seen about as well from either side of its normal
    tag = [t for t in detector.detect(renderer.render(*pose)) if t.id == 2]
    alone = onboard.solve(tag, LAYOUT, CFG)
    assert isinstance(alone, onboard.Refused) and alone.reason == "ambiguous" and "no estimate" in alone.detail
    picked = onboard.solve(tag, LAYOUT, CFG, estimate=(0.55, 0.47, 0.25))
    assert isinstance(picked, onboard.TagFix) and picked.chosen_by_estimate and picked.ambiguity > CFG.max_ambiguity
    assert math.hypot(picked.x - pose[0], picked.y - pose[1]) < 0.03
    far = onboard.solve(tag, LAYOUT, CFG, estimate=(2.0, 2.0, 2.0))
    assert isinstance(far, onboard.Refused) and far.reason == "ambiguous" and "near neither" in far.detail
    lax = onboard.solve(tag, LAYOUT, OnboardCamera(noise=0.0, max_ambiguity=0.9))
    assert isinstance(lax, onboard.TagFix) and not lax.chosen_by_estimate  # a looser bar keeps the better fit


def test_a_single_tag_beyond_max_distance_and_unknown_tags_give_no_fix(renderer, detector):
    found = detector.detect(renderer.render(0.0, 1.0, 0.0))  # the east wall's, 3 m off
    one = [t for t in found if t.id == 2]
    got = onboard.solve(one, LAYOUT, OnboardCamera(noise=0.0, max_distance=2.0))
    assert isinstance(got, onboard.Refused) and got.reason == "too_far"
    assert onboard.solve(one, {}, CFG) is None


def test_the_bench_tables_fix_errors_by_tag_count_and_distance():
    from zenav.bench.onboard import fix_errors

    lines = fix_errors(12, seed=2)
    rows = {line.split("|")[1].strip(): line.split("|")[2:-1] for line in lines if line.startswith("| ") and "fixes" not in line}
    assert {"1 tag", "2 tags", "3+ tags", "0-1 m", "3-4.5 m"} <= set(rows)
    assert sum(int(rows[k][0]) for k in ("1 tag", "2 tags", "3+ tags")) > 0
    assert all(rows[k][-1].strip() == "0" for k in ("2 tags", "3+ tags"))  # no wrong fix from several tags
