"""The vps service reading the field camera's frames (vps.source = "camera"), and the sim rendering them."""

import math
import resource
import threading

import pytest

from tests.support.images import huge_png
from tests.support.procs import niceness
from tests.support.rig import Rig
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import Camera, Settings
from zenav.common.runtime import Duplicate
from zenav.services.sim.camera import FieldCamera, Shutter
from zenav.services.sim.service import Sim
from zenav.services.vps import calibration, calibration_file, detect
from zenav.services.vps.calibration import CalibrationError
from zenav.services.vps.frames import encode
from zenav.services.vps.service import Vps
from zenav.world.render import Body, Renderer

FRAME = keys.field_key("camera/frame")
ROBOTS = {"r1": 0, "r2": 1}


@pytest.fixture(scope="module")
def renderer() -> Renderer:
    return Renderer(Camera(), seed=1)


@pytest.fixture(scope="module")
def cal_file(renderer, tmp_path_factory) -> str:
    tags = detect.make().detect(renderer.render(0.0, []))
    path = tmp_path_factory.mktemp("cal") / "camera.json"
    calibration_file.save(calibration.calibrate(tags, Camera()), path)
    return str(path)


IDEAL = {"model": "ideal", "clock_sync": False}  # frames rendered without a real camera's errors, on the stack's clock


def make(cal_file: str, **camera) -> Rig:
    return Rig(Vps, vps={"source": "camera"}, camera={"calibration": cal_file, "robots": ROBOTS, **IDEAL, **camera})


def frame(renderer, t: float, bodies) -> bytes:
    return codec.encode(encode(renderer.render(t, bodies), t, int(t * 10)))


def fixes(rig: Rig, robot: str) -> list[m.VpsPose]:
    return [codec.decode(d, m.VpsPose) for k, d in rig.bus.published if k == keys.key(robot, "vps/pose")]


def test_each_robot_gets_its_fix_after_the_link_delay(renderer, cal_file):
    rig = make(cal_file)
    rig.clock.t = 1.0
    rig.bus.publish(FRAME, frame(renderer, 1.0, [Body(0, 0.2, 0.3, 0.5), Body(1, 1.0, 0.8, -1.0)]))
    rig.drain()
    rig.advance(0.29)
    assert fixes(rig, "r1") == [] and fixes(rig, "r2") == []  # still on the link
    rig.advance(0.02)
    [a], [b] = fixes(rig, "r1"), fixes(rig, "r2")
    assert a.t == b.t == 1.0  # the capture time
    assert math.hypot(a.x - 0.2, a.y - 0.3) < 0.002 and abs(a.theta - 0.5) < 0.01
    assert math.hypot(b.x - 1.0, b.y - 0.8) < 0.002 and abs(b.theta + 1.0) < 0.01
    assert 0.0 < a.cov[0] < 1e-4 and 0.0 < a.cov[8] < 1e-3
    c = rig.svc.counters.values
    assert c["frames"] == 1 and c["fixes_captured"] == 2 and c["detect_ms_p50"] >= 0
    rig.close()


def test_bad_frames_are_refused_and_counted(renderer, cal_file):
    rig = make(cal_file)
    good = encode(renderer.render(0.0, [Body(0, 0.2, 0.3, 0.5)]), 0.0, 1)
    for data in (
        codec.encode(encode(renderer.render(0.0, [])[:240, :320], 0.0, 2)),  # wrong size
        codec.encode(m.CameraFrame(t=0.0, width=640, height=480, data=good.data[:1000])),  # corrupt
        b"\x93garbage",  # not a frame at all
    ):
        rig.bus.publish(FRAME, data)
        rig.drain()  # each read before the next comes (a newer frame supersedes a queued one)
    c = rig.svc.counters.values
    assert c["frames_refused"] == 2 and c["bad_input"] == 1 and c.get("frames", 0) == 0
    rig.close()


def test_a_frame_stamped_far_behind_is_refused_and_pending_fixes_stay(renderer, cal_file):
    rig = make(cal_file)
    rig.clock.t = 100.0
    rig.bus.publish(FRAME, frame(renderer, 100.0, [Body(0, 0.2, 0.3, 0.5)]))
    rig.drain()
    rig.bus.publish(FRAME, frame(renderer, 0.0, [Body(0, 0.4, 0.3, 0.5)]))  # stamped on a video file's own timeline
    rig.drain()
    rig.advance(0.31)
    [fix] = fixes(rig, "r1")  # the pending fix went out; the old frame gave none
    assert fix.t == 100.0 and abs(fix.x - 0.2) < 0.002
    c = rig.svc.counters.values
    assert c["frames_refused"] == 1 and c["frames"] == 1
    rig.close()


def test_a_small_png_of_huge_pixels_is_refused_before_it_is_decoded(cal_file, caplog):
    rig = make(cal_file)
    data = huge_png(16384, 16384)  # 16384 x 16384 grey: 256 MiB decoded
    assert len(data) < 300_000
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # [KiB] the process's peak so far
    rig.bus.publish(FRAME, codec.encode(m.CameraFrame(t=0.0, width=640, height=480, encoding="png", data=data)))
    rig.drain()
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown < 100 * 1024, f"peak memory grew {grown / 1024:.0f} MiB"
    c = rig.svc.counters.values
    assert c["frames_refused"] == 1 and c.get("frames", 0) == 0
    assert "png header says 16384x16384, the camera is configured 640x480" in caplog.text
    rig.close()


def test_a_vps_slower_than_the_camera_reads_the_newest_frame(renderer, cal_file, caplog):
    rig = make(cal_file)
    rig.clock.t = 1.0
    for i, x in enumerate((0.2, 0.4, 0.6, 0.8)):  # four frames come while the vps is busy (none served yet)
        rig.bus.publish(FRAME, frame(renderer, 1.0 + i * 0.1, [Body(0, x, 0.3, 0.5)]))
    assert rig.svc._inbox.qsize() == 1  # one place in the queue, not four frames' worth
    rig.drain()
    rig.advance(0.31)
    [fix] = fixes(rig, "r1")  # only the newest was read
    assert fix.t == pytest.approx(1.3) and abs(fix.x - 0.8) < 0.002
    c = rig.svc.counters.values
    assert c["frames"] == 1 and c["dropped_superseded"] == 3 and c["msgs_in"] == 1
    assert "dropped a camera/frame sample for a newer one: vps is slower than its input" in caplog.text
    rig.bus.publish(FRAME, frame(renderer, 1.4, [Body(0, 1.0, 0.3, 0.5)]))  # one that finds the queue empty is read
    rig.drain()
    assert rig.svc.counters.values["frames"] == 2 and rig.svc.counters.values["dropped_superseded"] == 3
    rig.close()


def test_unknown_and_twice_seen_tags_are_counted_and_give_no_fix(renderer, cal_file):
    rig = make(cal_file)
    rig.bus.publish(FRAME, frame(renderer, 0.0, [Body(0, 0.0, 0.3, 0.0), Body(0, 1.0, 0.3, 0.0), Body(9, 0.5, 0.8, 0.0)]))
    rig.drain()
    rig.advance(0.5)
    assert fixes(rig, "r1") == []
    c = rig.svc.counters.values
    assert c["tags_duplicate"] == 2 and c["tags_unknown"] == 1
    rig.close()


def test_no_calibration_is_a_clear_error(tmp_path):
    with pytest.raises(CalibrationError, match="run `zenav camera calibrate`"):
        Rig(Vps, vps={"source": "camera"}, camera={"calibration": str(tmp_path / "none.json")})


def test_auto_calibration_fits_the_first_frame_then_fixes(renderer):
    rig = Rig(Vps, vps={"source": "camera"}, camera=IDEAL)  # [camera] calibration = "auto", the default
    rig.bus.publish(FRAME, frame(renderer, 1.0, [Body(0, 0.2, 0.3, 0.5)]))
    rig.drain()
    c = rig.svc.counters.values
    assert 0 < c["calibration_rms_um"] < 1000 and c["frames"] == 1  # fitted and used on the same frame
    rig.advance(0.31)
    [f] = fixes(rig, "r1")
    assert math.hypot(f.x - 0.2, f.y - 0.3) < 0.002 and abs(f.theta - 0.5) < 0.01
    rig.close()


def test_no_fixed_tags_in_view_is_an_error_and_gives_no_fix(renderer):
    anchors = [{"id": 200, "x": 0.0, "y": 0.0}, {"id": 201, "x": 1.0, "y": 0.0}]  # not on this field
    rig = Rig(Vps, vps={"source": "camera"}, camera={"anchors": anchors})
    rig.bus.publish(FRAME, frame(renderer, 0.0, [Body(0, 0.2, 0.3, 0.5)]))
    rig.drain()
    rig.advance(0.5)
    assert fixes(rig, "r1") == [] and rig.svc.counters.values["frames_uncalibrated"] == 1
    assert rig.svc.status == "error"
    assert "cannot calibrate the camera: calibration needs 2 fixed tags in view, saw 0 (missing ids [200, 201])" in rig.svc.status_message
    rig.close()


def test_no_frames_is_an_error_and_a_hidden_tag_degraded(renderer, cal_file):
    rig = make(cal_file)
    rig.advance(2.0)
    assert rig.svc.status == "ok"  # nothing heard yet: nothing is silent
    rig.bus.publish(FRAME, frame(renderer, rig.t, [Body(0, 0.2, 0.3, 0.5)]))
    rig.drain()
    rig.advance(0.5)
    assert rig.svc.status == "ok"
    rig.advance(1.0)  # the frames stop
    assert rig.svc.status == "error" and "no camera frame for 1.5 s" in rig.svc.status_message
    for _ in range(15):  # frames again, the robot's tag out of view
        rig.bus.publish(FRAME, frame(renderer, rig.t, []))
        rig.advance(0.1)
    assert rig.svc.status == "degraded" and "robot r1: tag 0 not seen for" in rig.svc.status_message
    rig.bus.publish(FRAME, frame(renderer, rig.t, [Body(0, 0.2, 0.3, 0.5)]))
    rig.drain()
    rig.advance(0.5)
    assert rig.svc.status == "ok"
    rig.close()


def test_the_sim_publishes_frames_the_vps_reads(cal_file):
    cam = FieldCamera(Camera(model="ideal"), seed=1, tag=0)
    assert [cam.due(t) for t in (0.0, 0.05, 0.1, 0.19, 0.2)] == [True, False, True, False, True]  # 10 Hz
    shot = cam.frame(m.Truth(t=0.0, x=0.4, y=0.6, theta=1.0, v=0.0, omega=0.0))
    assert (shot.width, shot.height, len(shot.data), shot.seq) == (640, 480, 640 * 480, 1)
    rig = make(cal_file)
    rig.bus.publish(FRAME, codec.encode(shot))
    rig.drain()
    rig.advance(0.31)
    [f] = fixes(rig, "r1")
    assert math.hypot(f.x - 0.4, f.y - 0.6) < 0.002
    rig.close()


def test_the_scenarios_vps_outage_hides_the_robot_from_the_camera(cal_file):
    rig = Rig(Sim, sim={"camera": True}, camera=IDEAL, scenario={"vps_outage_start": 0.1, "vps_outage_duration": 0.1})
    for _ in range(25):
        rig.advance(0.01)
        assert rig.svc.shutter is not None and rig.svc.shutter.idle(10.0)
    rig.close()
    vps = make(cal_file)
    for data in [d for k, d in rig.bus.published if k == FRAME]:  # frames at 0.01, 0.11 (in the outage), 0.21
        vps.bus.publish(FRAME, data)
        vps.drain()
    vps.advance(0.5)
    assert [round(f.t, 2) for f in fixes(vps, "r1")] == [0.01, 0.21]
    vps.close()


def test_the_sim_renders_frames_beside_its_steps():
    rig = Rig(Sim, sim={"camera": True}, camera=IDEAL)
    assert rig.svc.shutter is not None
    for _ in range(25):
        rig.advance(0.01)
        assert rig.svc.shutter.idle(10.0)  # each frame drawn before the next step (a slower host skips frames)
    rig.close()
    shots = [codec.decode(d, m.CameraFrame) for k, d in rig.bus.published if k == FRAME]
    assert [s.t for s in shots] == pytest.approx([0.01, 0.11, 0.21])
    c = rig.svc.counters.values
    assert c["frames_taken"] == 3 and "frames_skipped" not in c and "frames_failed" not in c


def test_a_frame_due_while_the_last_is_drawn_is_skipped_and_failures_are_told():
    small = Camera(width=160, height=120, fx=133.25, fy=133.25, model="ideal")
    release, sent = threading.Event(), []

    def slow_send(frame: m.CameraFrame) -> None:
        assert release.wait(10.0)
        sent.append(frame.t)

    shutter = Shutter(FieldCamera(small, seed=1, tag=0), slow_send)
    truth = [m.Truth(t=0.1 * k, x=0.5, y=0.5, theta=0.0, v=0.0, omega=0.0) for k in range(3)]
    assert shutter.take(truth[0]) == "taken"
    assert shutter.take(truth[1]) == "skipped"  # the first is still being sent
    release.set()
    assert shutter.idle(10.0)
    assert shutter.take(m.Truth(t=0.15, x=0.5, y=0.5, theta=0.0, v=0.0, omega=0.0)) is None  # not due
    shutter.send = lambda frame: 1 / 0
    assert shutter.take(truth[2]) == "taken" and shutter.idle(10.0)
    assert sent == [0.0] and shutter.error == "ZeroDivisionError: division by zero"
    shutter.close()


def test_frames_are_drawn_at_a_lower_priority_than_the_steps():
    small = Camera(width=160, height=120, fx=133.25, fy=133.25, model="ideal")
    drawn_at = []
    shutter = Shutter(FieldCamera(small, seed=1, tag=0), lambda frame: drawn_at.append(niceness()))
    assert shutter.take(m.Truth(t=0.0, x=0.5, y=0.5, theta=0.0, v=0.0, omega=0.0)) == "taken" and shutter.idle(10.0)
    shutter.close()
    assert drawn_at == [min(niceness() + 10, 19)]  # the physics' thread keeps its own


def test_the_camera_vps_detects_at_a_lower_priority_than_the_control_loop(renderer, cal_file):
    rig = make(cal_file)
    assert rig.svc.background and rig.svc.blocking
    served_at, served = [], threading.Event()
    read = rig.svc.reader.read

    def reading(msg):
        served_at.append(niceness())
        served.set()
        return read(msg)

    rig.svc.reader.read = reading
    worker = threading.Thread(target=rig.svc.run)  # as its process runs it
    worker.start()
    rig.bus.publish(FRAME, frame(renderer, 0.0, [Body(0, 0.5, 0.5, 0.0, 0.0, 0.0)]))
    served.wait(10.0)
    rig.svc.stop()
    worker.join(10.0)
    rig.close()
    assert served_at == [min(niceness() + 10, 19)]  # its worker's; this thread keeps its own


def test_a_robot_the_camera_serves_gets_no_second_vps(cal_file):
    """r1's camera vps serves r1 and r2 ([camera] robots): r2 must run no vps of its own, in either order."""
    rig = make(cal_file)  # serves r2 too: r2's vps finds it and refuses, as a second vps of its own robot
    r2 = Vps(Settings.load(None, deployment={"robot": "r2"}), rig.bus, ManualClock(0.0))
    with pytest.raises(Duplicate, match=f"another vps already runs for robot r2 \\({rig.svc.instance}\\)"):
        r2.start()
    r2.close()
    bus = MemoryBus()  # r2's vps up first: the camera vps refuses to start, naming it
    first = Vps(Settings.load(None, deployment={"robot": "r2"}), bus, ManualClock(0.0))
    first.start()
    camera = Vps(Settings.load(None, vps={"source": "camera"}, camera={"calibration": cal_file, "robots": ROBOTS}), bus, ManualClock(0.0))
    with pytest.raises(Duplicate, match=f"\\[camera\\] robots has r2, for which another vps already runs \\({first.instance}\\)"):
        camera.start()
    camera.close()
    assert bus.tokens(keys.key("r2", "instance/vps/*")) == [keys.key("r2", f"instance/vps/{first.instance}")]
    first.close()


def test_a_camera_serving_only_its_own_robot_claims_no_other(cal_file):
    rig = make(cal_file, robots={"r1": 0})
    assert rig.bus.tokens("zenav/*/instance/vps/*") == [keys.key("r1", f"instance/vps/{rig.svc.instance}")]
