"""The vps reading the field's tags from the robot's own camera (vps.source = "onboard"), and the sim rendering it."""

import math

import pytest

from tests.support.rig import Rig
from zenav.common import messages as m
from zenav.common.config import ConfigError, Settings
from zenav.services.sim.onboard import OnboardFrames
from zenav.services.sim.service import Sim
from zenav.services.vps.frames import encode
from zenav.services.vps.service import Vps

pytest.importorskip("cv2")


@pytest.fixture(scope="module")
def camera():
    return OnboardFrames(Settings.load(None, onboard_camera={"drop_rate": 0.0}))  # the realistic camera, no frame lost


def truth(t: float, x: float, y: float, theta: float) -> m.Truth:
    return m.Truth(t=t, x=x, y=y, theta=theta, v=0.0, omega=0.0)


def fixes(rig: Rig) -> list[m.VpsPose]:
    return rig.got("vps/pose")


def test_the_sim_renders_the_robots_camera_on_its_own_key():
    rig = Rig(Sim, sim={"onboard_camera": True})
    assert rig.svc.onboard is not None
    for _ in range(15):
        rig.advance(0.01)
        assert rig.svc.onboard.idle(10.0)  # each frame drawn before the next step
    rig.close()
    shots = rig.got("camera/onboard/frame")
    assert [s.t for s in shots] == pytest.approx([0.01, 0.08, 0.15])  # 15 Hz on the 100 Hz step grid
    assert (shots[0].width, shots[0].height, shots[0].encoding, shots[0].exposure) == (640, 480, "jpeg", 0.008)  # realistic
    assert rig.svc.counters.values["onboard_frames_taken"] == 3


def test_a_frame_of_the_field_tags_gives_the_robots_pose_after_the_link_delay(camera):
    rig = Rig(Vps, vps={"source": "onboard"})
    rig.clock.t = 2.0
    rig.put("camera/onboard/frame", camera.frame(truth(2.0, 0.4, 0.6, 0.2)))
    rig.drain()
    rig.advance(0.04)
    assert fixes(rig) == []  # on the link: [onboard_camera] link_delay 0.05 s
    rig.advance(0.02)
    [fix] = fixes(rig)
    assert fix.t != 2.0 and abs(fix.t - 2.0) < 0.015  # the exposure of its tags' rows (a 0.03 s rolling shutter)
    # A realistic camera (its mount, lens and tags off the config): within 2 cm and 0.6 deg, and its covariance says so.
    assert math.hypot(fix.x - 0.4, fix.y - 0.6) < 0.02 and abs(fix.theta - 0.2) < 0.01
    assert (fix.x - 0.4) ** 2 / fix.cov[0] + (fix.y - 0.6) ** 2 / fix.cov[4] < 13.8 and (fix.theta - 0.2) ** 2 / fix.cov[8] < 10.8
    assert 0.0 < fix.cov[0] < 1e-3 and 0.0 < fix.cov[8] < 1e-3
    c = rig.svc.counters.values
    assert c["frames"] == 1 and c["fixes_captured"] == 1
    rig.close()


def test_bad_frames_are_refused_counted_and_the_service_goes_on(camera):
    rig = Rig(Vps, vps={"source": "onboard"})
    good = camera.frame(truth(0.0, 0.4, 0.6, 0.2))
    rig.put("camera/onboard/frame", encode(camera.renderer.render(0.4, 0.6, 0.2)[:240, :320], 0.0, 2))  # wrong size
    rig.put("camera/onboard/frame", m.CameraFrame(t=0.0, width=640, height=480, data=good.data[:1000]))  # corrupt
    rig.drain()
    assert rig.svc.counters.values["frames_refused"] == 2 and fixes(rig) == []
    rig.put("camera/onboard/frame", good)
    rig.drain()
    rig.advance(0.1)
    assert len(fixes(rig)) == 1
    rig.close()


def test_a_frame_without_the_layouts_tags_gives_no_fix_and_no_tags_at_all_is_an_error_at_start(camera):
    rig = Rig(Vps, vps={"source": "onboard"})
    rig.put("camera/onboard/frame", camera.frame(truth(0.0, 2.99, 1.0, -0.8)))  # facing into a corner: no tag in sight
    rig.drain()
    rig.advance(0.1)
    assert fixes(rig) == [] and rig.svc.counters.values["frames"] == 1
    rig.close()
    with pytest.raises(ConfigError, match="reads the \\[field\\] tags, and there are none"):
        Rig(Vps, vps={"source": "onboard"}, field={"tags": []})


def test_the_localizers_pose_resolves_ambiguity_only_while_it_is_sure():
    rig = Rig(Vps, vps={"source": "onboard"})
    sure = m.Pose(t=0.0, x=1.0, y=1.0, theta=0.0, v=0.0, omega=0.0, cov=(1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4))
    rig.put("pose", sure)
    rig.drain()
    assert rig.svc.estimate == (1.0, 1.0, 0.0)
    rig.put("pose", m.Pose(t=0.1, x=1.0, y=1.0, theta=0.0, v=0.0, omega=0.0, cov=(1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0)))
    rig.drain()
    assert rig.svc.estimate is None
    rig.close()
