"""The robot's camera with a real camera's errors: drawn as the overhead camera's are, rendered with the robot's own
motion and the field's obstacles, and a fix's covariance that holds its error."""

import math

import msgspec
import numpy as np
import pytest

from zenav.common import messages as m
from zenav.common.config import Settings
from zenav.common.field import polygon_shape
from zenav.common.onboardcam import OnboardCamera
from zenav.services.sim.onboard import OnboardFrames
from zenav.services.vps import detect, frames, onboard
from zenav.services.vps.onboard_reader import OnboardReader
from zenav.world.camera_errors import imperfect_onboard, jpeg, lens_error_px, shake, tags_as_placed
from zenav.world.onboard import WALL, OnboardRenderer, mount, sightings

pytest.importorskip("cv2")

SETTINGS = Settings.load(None)
FIELD = SETTINGS.field  # the default field: three tags on each wall
LAYOUT = {t.id: t for t in FIELD.tags}
REAL = OnboardCamera(noise=0.0)  # model "realistic", the default
IDEAL = OnboardCamera(noise=0.0, model="ideal")


@pytest.fixture(scope="module")
def detector():
    return detect.make("opencv", 24.0)


def test_the_realistic_camera_is_off_by_the_configured_sizes_and_the_ideal_one_is_not():
    e = imperfect_onboard(REAL, seed=3)
    assert lens_error_px(REAL, e.true) == pytest.approx(REAL.calibration_error, rel=0.05)
    tilt = math.hypot(e.true.pitch - REAL.pitch, e.true.yaw - REAL.yaw)
    assert tilt == pytest.approx(REAL.mount_tilt, rel=1e-6)
    assert imperfect_onboard(REAL, seed=3) == e and imperfect_onboard(REAL, seed=4) != e  # one camera a seed
    assert (e.vibration, e.jpeg_quality, e.drop_rate, e.readout) == (0.0005, 80, 0.02, 0.03)
    ideal = imperfect_onboard(IDEAL, seed=3)
    assert msgspec.structs.replace(ideal.true, readout=0.03, exposure=0.008) == IDEAL
    assert (ideal.true.readout, ideal.true.exposure, ideal.vibration, ideal.drop_rate) == (0.0, 0.0, 0.0, 0.0)


def test_the_tags_stand_off_their_layout_and_are_printed_at_one_scale():
    placed = tags_as_placed(REAL, FIELD.tags, seed=3)
    scales = {round(p.size / t.size, 12) for p, t in zip(placed, FIELD.tags)}
    assert len(scales) == 1 and scales != {1.0}
    off = np.array([[p.x - t.x, p.y - t.y, p.z - t.z] for p, t in zip(placed, FIELD.tags)])
    assert 0.0 < np.sqrt(np.mean(off**2)) < 3 * REAL.tag_position_error
    assert tags_as_placed(IDEAL, FIELD.tags, seed=3) == tuple(FIELD.tags)


def _corners(detector, img, tag_id):
    return next(t.corners for t in detector.detect(img) if t.id == tag_id)


def test_a_rolling_shutter_skews_what_a_turning_robot_sees(detector):
    pose, omega = (0.6, 1.0, 0.0), 2.0  # [m, m, rad], [rad/s] turning left: the scene runs right in the image
    rolled = OnboardRenderer(msgspec.structs.replace(REAL, exposure=0.0), FIELD.tags, (), 1)
    glob = OnboardRenderer(msgspec.structs.replace(REAL, exposure=0.0, readout=0.0), FIELD.tags, (), 1)
    a, b = (_corners(detector, r.render(*pose, 0.0, omega), 2) for r in (rolled, glob))
    # Lower rows are exposed later, when the camera has turned more: the tag's bottom edge lies farther right.
    skew = (a[3, 0] - a[0, 0]) - (b[3, 0] - b[0, 0])  # [px] bottom-left's shift from top-left's, rolled minus global
    rows = a[3, 1] - a[0, 1]
    expected = REAL.fx * omega * REAL.readout * rows / REAL.height  # [px]
    assert skew == pytest.approx(expected, rel=0.25) and expected > 1.0


def test_the_exposure_blurs_a_moving_robots_frame():
    r = OnboardRenderer(msgspec.structs.replace(REAL, readout=0.0, exposure=0.02), FIELD.tags, (), 1)

    def sharpness(img):
        return float(np.percentile(np.abs(np.diff(img.astype(float), axis=1)), 99.9))

    still, turning = r.render(0.6, 1.0, 0.0), r.render(0.6, 1.0, 0.0, 0.0, 3.0)
    assert sharpness(turning) < 0.7 * sharpness(still)


def test_an_obstacle_hides_the_part_of_a_tag_behind_it(detector):
    cam = mount(REAL, 1.0, 1.0, 0.0)
    tag = LAYOUT[2]  # on the east wall at (3, 1), seen straight ahead
    post = polygon_shape("post", [[2.0, 0.99], [2.1, 0.99], [2.1, 1.2], [2.0, 1.2]])  # covers its left half (y > 1)
    assert [s.tag.id for s in sightings(REAL, cam, [tag], [post])] == [2]  # partly in sight: drawn
    clear = OnboardRenderer(REAL, [tag], (), 1).render(1.0, 1.0, 0.0)
    hidden = OnboardRenderer(REAL, [tag], [post], 1).render(1.0, 1.0, 0.0)
    outline = next(s.corners for s in sightings(REAL, cam, [tag], ()))
    (u0, v0), (u1, v1) = outline.min(axis=0).astype(int) + 2, outline.max(axis=0).astype(int) - 2
    third = (u1 - u0) // 3  # the sight lines' grid draws the boundary to a ninth of the printed square
    assert np.all(hidden[v0:v1, u0 : u0 + third] == round(WALL))  # the left third: the obstacle's face
    assert np.array_equal(hidden[v0:v1, u1 - third : u1], clear[v0:v1, u1 - third : u1])  # the right third: the tag
    assert [t.id for t in detector.detect(clear)] == [2] and detector.detect(hidden) == []


def test_realistic_fixes_lie_within_their_own_covariance(detector):
    e = imperfect_onboard(REAL, seed=1)
    renderer = OnboardRenderer(e.true, tags_as_placed(REAL, FIELD.tags, 1), FIELD.shapes(), 1)
    rng = np.random.default_rng(7)
    d2, n = [], 0
    for _ in range(40):  # bounded: 40 poses
        truth = (float(rng.uniform(-0.7, 2.7)), float(rng.uniform(-0.7, 2.7)), float(rng.uniform(-math.pi, math.pi)))
        img = shake(renderer.render(*truth), e, rng)
        img = frames.decode(m.CameraFrame(t=0.0, seq=1, width=640, height=480, encoding="jpeg", data=jpeg(img, 80)), 640, 480)
        got = onboard.solve(detector.detect(img), LAYOUT, REAL, truth)
        if isinstance(got, onboard.TagFix):
            d = np.array([got.x - truth[0], got.y - truth[1]])
            d2.append(float(d @ np.linalg.solve(np.array(got.cov).reshape(3, 3)[:2, :2], d)))
            n += 1
    assert n >= 20
    assert max(d2) < 13.8  # none outside its 99.9 % ellipse (chi-square, 2 dof)
    assert np.mean(d2) > 0.3  # and the covariance is not so wide it says nothing (2 for an exact one)


def test_the_covariance_grows_by_the_lens_error_and_the_mounts_turn():
    cov = tuple(np.diag([1e-4, 2e-4, 1e-5]).ravel())
    assert onboard.widen(IDEAL, cov) == cov
    wide = np.array(onboard.widen(REAL, cov)).reshape(3, 3)
    assert np.all(np.diag(wide)[:2] > np.diag(np.array(cov).reshape(3, 3))[:2] * 1.9)  # (0.3 + 0.3 px) / 0.3 px
    assert wide[2, 2] > 1e-5 * 1.9 + REAL.mount_tilt**2


def test_a_fix_is_stamped_at_its_tags_rows():
    settings = Settings.load(None)
    reader = OnboardReader(settings, "opencv")
    fix = onboard.TagFix(1.0, 1.0, 0.0, (0.0,) * 9, (2,), 1.5, 0.1, row=479.5)
    assert reader.stamp(10.0, fix) == pytest.approx(10.0 + 0.5 * REAL.readout)
    reader.cfg = IDEAL
    assert reader.stamp(10.0, fix) == 10.0


def test_the_sims_frames_are_jpeg_some_lost_and_say_their_exposure():
    sim = OnboardFrames(Settings.load(None, onboard_camera={"drop_rate": 0.5}))
    got = [sim.frame(m.Truth(t=0.1 * i, x=0.5, y=1.0, theta=0.0, v=0.2, omega=0.5)) for i in range(20)]
    sent = [f for f in got if f is not None]
    assert sim.lost == 20 - len(sent) and 0 < sim.lost < 20
    assert all(f.encoding == "jpeg" and f.exposure == REAL.exposure for f in sent)
    ideal = OnboardFrames(Settings.load(None, onboard_camera={"model": "ideal"}))
    raw = ideal.frame(m.Truth(t=0.0, x=0.5, y=1.0, theta=0.0, v=0.0, omega=0.0))
    assert raw is not None and raw.encoding == "mono8" and raw.exposure == 0.0
