"""The VPS reading the overhead camera: detection, calibration, fixes (frames rendered from known poses)."""

import math

import msgspec
import numpy as np
import pytest

from zenav.common.config import Camera
from zenav.common.geometry import wrap_angle
from zenav.services.vps import calibration, calibration_file, detect, locate
from zenav.services.vps.calibration import Calibration, CalibrationError
from zenav.world.camera import tag_pixels
from zenav.world.render import Body, Renderer

CFG = Camera(yaw=0.1, tilt=0.03)  # a mount a little off level, the default lens (barrel distortion)
POSITION_TOL = 0.002  # [m] the pose recovered within this
HEADING_TOL = math.radians(0.5)  # [rad]
ROBOTS = {"r1": 0, "r2": 1}
ANCHORS = {a.id for a in CFG.anchors}


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return Renderer(CFG, seed=5)


@pytest.fixture(scope="module", params=["apriltag", "opencv"])
def detector(request) -> detect.Detector:
    """Each backend, at the settings the vps picks: every test of the fixes holds for both, at the same tolerances."""
    return detect.make(request.param, tag_pixels(CFG))


@pytest.fixture(scope="module")
def cal(renderer, detector) -> Calibration:
    return calibration.calibrate(detector.detect(renderer.render(0.0, [])), CFG)


def fixes_of(cal, detector, img, h=CFG.tag_height, cfg=CFG):
    return locate.locate(detector.detect(img), cal, ROBOTS, ANCHORS, cfg.tag_size, h, cfg.corner_sigma)


def test_calibration_fits_the_fixed_tags_and_finds_the_camera(cal):
    assert cal.rms < 0.001  # [m]
    assert set(cal.anchors) >= {100, 101, 102, 104, 105}
    assert cal.camera_height() == pytest.approx(CFG.z, abs=0.01)


@pytest.mark.parametrize(
    "x, y, theta", [(0.0, 0.0, 0.0), (0.3, 0.4, 0.5), (0.6, 0.3, 1.6), (1.2, 0.9, -2.0), (-0.3, 1.0, 3.1), (1.4, 0.1, -1.2)]
)
@pytest.mark.parametrize("v, omega", [(0.0, 0.0), (0.3, 1.0)])
def test_the_pose_is_recovered(renderer, detector, cal, x, y, theta, v, omega):
    out = fixes_of(cal, detector, renderer.render(0.0, [Body(0, x, y, theta, v, omega)]))
    assert len(out.fixes) == 1 and out.unknown == out.duplicates == 0
    f = out.fixes[0]
    assert f.robot == "r1" and f.tag == 0
    assert math.hypot(f.x - x, f.y - y) < POSITION_TOL
    assert abs(wrap_angle(f.theta - theta)) < HEADING_TOL
    sx, sy, sth = math.sqrt(f.cov[0]), math.sqrt(f.cov[4]), math.sqrt(f.cov[8])
    assert 1e-4 < sx < 0.01 and 1e-4 < sy < 0.01 and 1e-3 < sth < 0.05  # [m], [rad]: from the geometry, not zero


def test_the_tag_height_is_accounted_for(renderer, detector, cal):
    img = renderer.render(0.0, [Body(0, 1.4, 1.0, 0.0)])  # far off the optical axis: height shows as parallax
    right = fixes_of(cal, detector, img).fixes[0]
    floor = fixes_of(cal, detector, img, h=0.0, cfg=msgspec.structs.replace(CFG, tag_height=0.0, tag_size=0.1 * 2.0 / 1.88)).fixes[0]
    assert math.hypot(right.x - 1.4, right.y - 1.0) < POSITION_TOL
    assert math.hypot(floor.x - 1.4, floor.y - 1.0) > 0.03  # ignoring the height misplaces it by ~5 cm


def test_two_robots_each_get_their_own_fix(renderer, detector, cal):
    img = renderer.render(0.0, [Body(0, 0.1, 0.2, 0.4), Body(1, 1.1, 0.8, -1.5)])
    got = {f.robot: f for f in fixes_of(cal, detector, img).fixes}
    assert set(got) == {"r1", "r2"}
    assert math.hypot(got["r1"].x - 0.1, got["r1"].y - 0.2) < POSITION_TOL
    assert math.hypot(got["r2"].x - 1.1, got["r2"].y - 0.8) < POSITION_TOL


def test_unknown_tags_are_ignored_and_counted(renderer, detector, cal):
    out = fixes_of(cal, detector, renderer.render(0.0, [Body(7, 0.5, 0.5, 0.0), Body(0, 1.0, 0.2, 0.0)]))
    assert out.unknown == 1 and [f.robot for f in out.fixes] == ["r1"]


def test_a_tag_seen_twice_is_refused(renderer, detector, cal):
    out = fixes_of(cal, detector, renderer.render(0.0, [Body(0, 0.0, 0.5, 0.0), Body(0, 1.0, 0.5, 0.0), Body(1, 0.5, 0.0, 0.0)]))
    assert out.duplicates == 2
    assert [f.robot for f in out.fixes] == ["r2"]


def test_a_tag_of_the_wrong_size_is_refused(renderer, detector, cal):
    img = renderer.render(0.0, [Body(0, 0.5, 0.5, 0.0)])
    out = fixes_of(cal, detector, img, cfg=msgspec.structs.replace(CFG, tag_size=0.15))  # config says 15 cm, the tag is 10 cm
    assert out.wrong_size == 1 and out.fixes == []


def test_calibration_needs_fixed_tags(renderer, detector):
    with pytest.raises(CalibrationError, match="needs 2 fixed tags in view, saw 0"):
        calibration.calibrate([], CFG)
    tags = detector.detect(renderer.render(0.0, []))
    with pytest.raises(CalibrationError, match="seen twice"):
        calibration.calibrate([*tags, tags[0]], CFG)


def test_no_calibration_names_what_to_run(tmp_path):
    with pytest.raises(CalibrationError, match="run `zenav camera calibrate`"):
        calibration_file.load(tmp_path / "none.json")
    bad = tmp_path / "bad.json"
    for text in ("{not json", "[1, 2]", '{"version": 1}'):
        bad.write_text(text)
        with pytest.raises(CalibrationError, match="unreadable"):
            calibration_file.load(bad)


def test_a_calibration_file_round_trips(cal, tmp_path):
    path = tmp_path / "cal.json"
    calibration_file.save(cal, path)
    back = calibration_file.load(path)
    assert np.allclose(back.floor, cal.floor) and np.allclose(back.lens.K, cal.lens.K) and back.anchors == cal.anchors
    px = np.array([(100.0, 100.0), (500.0, 400.0)])
    assert np.allclose(back.to_plane(px, 0.12), cal.to_plane(px, 0.12))


@pytest.mark.parametrize("theta", [0.2, 1.8, 3.0, -1.4])  # the tag seen turned by each quarter
def test_both_backends_find_the_same_tags_and_corners(renderer, theta):
    img = renderer.render(0.0, [Body(0, 0.5, 0.5, theta), Body(1, 1.1, 0.2, -theta)])
    april = {t.id: t for t in detect.make("apriltag", tag_pixels(CFG)).detect(img)}
    opencv = {t.id: t for t in detect.make("opencv", tag_pixels(CFG)).detect(img)}
    assert sorted(opencv) == sorted(april) and {0, 1, 100, 101, 102, 104, 105} <= set(april)  # 103 is out of view
    for i in april:
        assert np.abs(april[i].corners - opencv[i].corners).max() < 0.5  # [px] the same corners in the same order
        assert opencv[i].margin > 5.0  # [grey levels] every code cell clear of the threshold


def test_the_apriltag_detector_frees_itself_before_its_families():
    """pupil-apriltags frees the tag families before the detector that uses them (a segfault now and then)."""
    det = detect.AprilTagDetector()
    inner = det._det
    assert inner.tag_detector_ptr is not None
    del det
    assert inner.tag_detector_ptr is None  # freed in order here: the library's own __del__ does nothing
