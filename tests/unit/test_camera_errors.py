"""A real camera's errors (world/camera_errors.py), the vps's answer to them (placing.py), and the clock sync (timesync.py)."""

import math

import msgspec
import numpy as np
import pytest

from zenav.common.config import Camera
from zenav.services.vps import placing
from zenav.services.vps.locate import Sighting
from zenav.services.vps.timesync import Exchange, TimeSync
from zenav.world.camera_errors import dropped, imperfect, lens_error_px, shake
from zenav.world.camera_time import row_time
from zenav.world.render import Body, Renderer


def test_an_ideal_camera_is_the_configured_one():
    cfg = Camera(model="ideal", clock_offset=2.0)
    e = imperfect(cfg, seed=1)
    assert e.true == cfg and (e.readout, e.vibration, e.jpeg_quality, e.drop_rate) == (0.0, 0.0, 0, 0.0)
    assert e.host_time(10.0) == 12.0  # the host's clock is not the camera's error: kept


def test_the_real_lens_is_off_by_the_configured_residual_and_the_seed_decides():
    cfg = Camera()
    a, b, again = imperfect(cfg, 1), imperfect(cfg, 2), imperfect(cfg, 1)
    assert lens_error_px(cfg, a.true) == pytest.approx(cfg.calibration_error, rel=0.05)
    assert a == again and a.true != b.true
    assert abs(a.true.tag_height - cfg.tag_height) < 5 * cfg.tag_height_error
    assert math.hypot(a.true.tilt - cfg.tilt, a.true.yaw - cfg.yaw) == pytest.approx(cfg.mount_tilt)


def test_the_shaken_mount_moves_the_image_by_focal_length_times_angle():
    img = np.zeros((120, 160), np.uint8)
    img[50:70, 70:90] = 255
    e = imperfect(Camera(width=160, height=120, fx=133.25, fy=133.25, vibration=0.02, calibration_error=0.0), 1)
    moved = [shake(img, e, np.random.default_rng(k)) for k in range(20)]
    shifts = [abs(np.argwhere(m > 127).mean(axis=0) - (59.5, 79.5)).max() for m in moved]
    assert 0.3 < float(np.median(shifts)) < 6.0  # 2.7 px a sigma
    assert shake(img, imperfect(Camera(model="ideal"), 1), np.random.default_rng(0)) is img


def test_frames_are_lost_at_the_drop_rate():
    e = imperfect(Camera(drop_rate=0.1), 1)
    rng = np.random.default_rng(3)
    lost = sum(dropped(e, rng) for _ in range(2000))
    assert 140 < lost < 260


def test_a_rolling_shutter_draws_a_low_row_later():
    cfg = Camera(model="ideal", noise=0.0, lighting=0.0, exposure=0.0)
    body = Body(0, 0.5, 0.0, 0.0, v=1.0)  # low in the image (map -y is image down), moving along +x
    still, rolling = Renderer(cfg, seed=1).render(0.0, [body]), Renderer(cfg, seed=1, readout=0.03).render(0.0, [body])
    cols = [np.argwhere(img[355:405] < 60)[:, 1].mean() for img in (still, rolling)]  # the tag's black cells, no fixed tag's
    assert cols[1] - cols[0] > 1.0  # later, so further along +x (image right)
    assert row_time(479.0, 480, 0.03) == pytest.approx(0.015, abs=1e-4) and row_time(239.5, 480, 0.03) == 0.0


def sighting(row: float, x: float = 0.5, y: float = 0.5) -> Sighting:
    return Sighting("r1", 0, x, y, 0.0, (1e-6, 0.0, 0.0, 0.0, 1e-6, 0.0, 0.0, 0.0, 1e-4), 27.0, row)


def test_a_fix_is_stamped_at_its_rows_time_and_widened_by_the_cameras_errors():
    cfg = Camera()
    assert placing.stamp(5.0, sighting(row=479.0), cfg) == pytest.approx(5.0 + 0.015, abs=1e-4)
    assert placing.stamp(5.0, sighting(row=479.0), Camera(model="ideal")) == 5.0
    near, far = placing.widen(sighting(240.0), cfg), placing.widen(sighting(240.0, x=1.5, y=0.5), cfg)
    assert near[0] > 1e-6 and near[4] > 1e-6 and near[8] > 1e-4
    assert far[0] > near[0] and far[4] == pytest.approx(near[4])  # the tag height's parallax: radial, from under the camera
    assert placing.widen(sighting(240.0), Camera(model="ideal")) == sighting(240.0).cov


def exchanges(offset: float, drift_ppm: float, n: int, seed: int = 1) -> list[Exchange]:
    """Round trips once a second to a stack whose clock is the host's + offset + drift; each way 1-20 ms, at random."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        sent = 100.0 + k
        there, back = rng.uniform(0.001, 0.02, 2)
        at = sent + there  # [s] host clock when the stack reads its own
        out.append(Exchange(sent, at - offset - drift_ppm * 1e-6 * at, at + back))
    return out


@pytest.mark.parametrize("offset, drift", [(1.0, 100.0), (-1.0, -100.0), (0.4, 0.0)])
def test_the_offset_and_drift_are_found_from_the_quickest_round_trips(offset, drift):
    sync = TimeSync()
    for ex in exchanges(offset, drift, 30):
        assert sync.add(ex) == ""
    truth = exchanges(offset, drift, 31)[-1]  # the stack's clock one round further on
    t_host = truth.sent + 0.5
    expected = t_host - offset - drift * 1e-6 * t_host
    assert abs(sync.to_stack(t_host) - expected) < 2e-3  # within a few ms round trip's half
    assert abs(sync.drift * 1e6 + drift) < 60.0


def test_a_round_trip_too_long_or_backwards_is_refused():
    sync = TimeSync()
    assert "round trip" in sync.add(Exchange(10.0, 5.0, 11.0))
    assert "round trip" in sync.add(Exchange(10.0, 5.0, 9.9))
    assert not sync.ready
    cfg = msgspec.structs.replace(Camera(), clock_sync=False)
    assert cfg.clock_sync is False
