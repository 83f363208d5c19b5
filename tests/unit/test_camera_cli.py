"""`zenav camera calibrate` and `snapshot` on pictures of a rendered field; `detect` on real photos and on bad files."""

import json
import re
import subprocess
import sys
import threading
import time

import cv2
import msgspec
import numpy as np
import pytest

from tests.support import realtags
from zenav.cli import camera
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_USAGE, main
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.services.vps import frames
from zenav.services.vps.detect import Tag
from zenav.world.render import Body, Renderer


@pytest.fixture(scope="module")
def pictures(tmp_path_factory):
    d = tmp_path_factory.mktemp("field")
    r = Renderer(Camera(), seed=2)
    cv2.imwrite(str(d / "empty.png"), r.render(0.0, []))
    cv2.imwrite(str(d / "robot.png"), r.render(0.0, [Body(0, 0.3, 0.4, 0.5)]))
    small = Renderer(msgspec.structs.replace(Camera(), anchors=()), seed=2)
    cv2.imwrite(str(d / "bare.png"), small.render(0.0, []))
    return d


def test_calibrate_then_snapshot(pictures, tmp_path, capsys):
    cal = tmp_path / "cal.json"
    assert main(["camera", "calibrate", "--image", str(pictures / "empty.png"), "-o", str(cal)]) == EXIT_OK
    assert "camera 2.000 m above the floor" in capsys.readouterr().out
    assert json.loads(cal.read_text())["anchors"] == [100, 101, 102, 103, 104, 105]
    png = tmp_path / "snap.png"
    args = ["camera", "snapshot", "--image", str(pictures / "robot.png"), "-o", str(png), "--set", f'camera.calibration="{cal}"']
    assert main(args) == EXIT_OK
    found = re.search(r"fixes r1 \(([-.\d]+), ([-.\d]+), ([-.\d]+)\)", capsys.readouterr().out)
    assert found and [float(v) for v in found.groups()] == pytest.approx([0.3, 0.4, 0.5], abs=0.005)
    img = cv2.imread(str(png))
    assert img.shape == (480, 640, 3) and (img[..., 0] != img[..., 2]).any()  # drawn on in colour


def test_calibrate_without_fixed_tags_says_so(pictures, tmp_path, capsys):
    code = main(["camera", "calibrate", "--image", str(pictures / "bare.png"), "-o", str(tmp_path / "c.json")])
    assert code == EXIT_FAILED
    assert "needs 2 fixed tags in view, saw 0" in capsys.readouterr().err
    assert not (tmp_path / "c.json").exists()


def test_snapshot_without_calibration_draws_the_tags_and_names_what_to_run(pictures, tmp_path, capsys):
    png = tmp_path / "snap.png"
    missing = f'camera.calibration="{tmp_path}/none.json"'
    args = ["camera", "snapshot", "--image", str(pictures / "robot.png"), "-o", str(png), "--set", missing]
    assert main(args) == EXIT_OK
    out = capsys.readouterr()
    assert "run `zenav camera calibrate`" in out.err and "fixes none" in out.out
    assert png.is_file()


def test_stream_publishes_a_video_files_frames_at_its_pace(pictures, tmp_path):
    path = str(tmp_path / "field.avi")
    out = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (640, 480))
    frame = cv2.cvtColor(cv2.imread(str(pictures / "robot.png"), cv2.IMREAD_GRAYSCALE), cv2.COLOR_GRAY2BGR)
    for _ in range(4):
        out.write(frame)
    out.release()
    start = time.time()
    sent: list[bytes] = []
    assert camera.stream(frames.Capture(path, start=start), sent.append, threading.Event(), 0.008) == 4
    shots = [codec.decode(d, m.CameraFrame) for d in sent]
    assert [s.seq for s in shots] == [1, 2, 3, 4] and all((s.width, s.height) == (640, 480) for s in shots)
    assert [s.t - start for s in shots] == pytest.approx([0.0, 0.05, 0.1, 0.15], abs=1e-3)
    assert time.time() - start >= 0.15  # played at the file's pace


def test_calibrate_from_the_frame_the_sim_renders(tmp_path, capsys):
    cal = tmp_path / "cal.json"
    assert main(["camera", "calibrate", "--sim", "-o", str(cal)]) == EXIT_OK
    assert "fixed tags [100, 101, 102, 103, 104, 105]" in capsys.readouterr().out
    assert json.loads(cal.read_text())["camera_height_m"] == pytest.approx(2.0, abs=0.01)


def zenav(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "zenav", *argv], capture_output=True, text=True, timeout=120, check=False)


@pytest.mark.parametrize("detector", ["apriltag", "opencv"])
def test_detect_prints_the_tags_of_a_real_photo(detector):
    photo = realtags.PHOTOS[0]
    got = zenav("camera", "detect", str(photo), "--detector", detector, "--json")
    assert got.returncode == EXIT_OK, got.stderr
    out = json.loads(got.stdout)
    assert out["detector"] == detector and (out["width"], out["height"]) == (799, 533)
    tags = [Tag(t["id"], np.array(t["corners"]), t["margin"]) for t in out["tags"]]
    ref = realtags.reference(photo.with_suffix(".txt"))
    assert realtags.matched(ref, tags) >= 0.9 * len(ref)
    assert all(t.margin > 0.0 for t in tags)
    text = zenav("camera", "detect", str(photo), "--detector", detector)
    assert text.returncode == EXIT_OK
    assert re.match(r"tag 0: corners \([-.\d]+, [-.\d]+\)( \([-.\d]+, [-.\d]+\)){3} margin [.\d]+$", text.stdout.splitlines()[0])
    assert text.stdout.splitlines()[-1].startswith(f"{len(tags)} tags in ")


def test_detect_says_when_a_picture_has_no_tag(tmp_path):
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((120, 160), 128, np.uint8))
    got = zenav("camera", "detect", str(blank))
    assert got.returncode == EXIT_FAILED and got.stdout == ""
    assert got.stderr.strip().splitlines() == [f"zenav camera detect: no tag36h11 tag found in {blank} (apriltag detector)"]


@pytest.mark.parametrize(
    "name, content, why",
    [
        ("missing.png", None, "No such file or directory"),
        ("empty.png", b"", "the file is empty"),
        ("notes.png", b"not a picture\n", "not a picture OpenCV can decode (PNG, JPEG, ...)"),
        ("cut.jpg", realtags.PHOTOS[0].read_bytes()[:2000], "not a picture OpenCV can decode (PNG, JPEG, ...)"),
    ],
)
def test_detect_refuses_a_file_that_is_no_picture_in_one_line(tmp_path, name, content, why):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    got = zenav("camera", "detect", str(path))
    assert got.returncode == EXIT_USAGE and got.stdout == ""
    assert got.stderr.strip().splitlines() == [f"zenav camera detect: cannot read {path}: {why}"]


def test_detect_documents_its_exit_codes():
    got = zenav("camera", "detect", "--help")
    assert "exit codes: 0 tags found, 1 no tag found, 2 the file cannot be read as an image" in got.stdout


def _parsed(*argv: str):
    import argparse

    parser = argparse.ArgumentParser()
    camera.add_arguments(parser.add_subparsers())
    return parser.parse_args(["camera", "stream", *argv])


def test_stream_onboard_publishes_on_the_robots_own_camera_key_at_its_sections_size():
    key, device, exposure, size = camera.stream_target(_parsed("--onboard", "--device", "0", "--robot", "r2"))
    assert (key, device, size) == ("zenav/r2/camera/onboard/frame", "0", (640, 480))
    key, device, _, size = camera.stream_target(_parsed("--onboard", "--device", "1", "--set", "onboard_camera.width=320"))
    assert key == "zenav/r1/camera/onboard/frame" and size == (320, 480)
    key, device, _, _ = camera.stream_target(_parsed("--set", 'camera.device="cam.mp4"'))
    assert (key, device) == ("zenav/field/camera/frame", "cam.mp4")
    # The robot's camera is not the field's: [camera] device is not its source.
    assert camera.stream_target(_parsed("--onboard", "--set", 'camera.device="cam.mp4"'))[1] == ""


def test_stream_onboard_without_a_device_says_so(capsys):
    assert main(["camera", "stream", "--onboard", "--set", 'camera.device="cam.mp4"']) == EXIT_FAILED
    assert "name a source: --device (a video file, a webcam index or a URL)\n" in capsys.readouterr().err


def test_stream_stops_on_frames_of_another_size_than_the_section_says(pictures, tmp_path):
    path = str(tmp_path / "field.avi")
    out = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (640, 480))
    frame = cv2.cvtColor(cv2.imread(str(pictures / "robot.png"), cv2.IMREAD_GRAYSCALE), cv2.COLOR_GRAY2BGR)
    for _ in range(2):
        out.write(frame)
    out.release()
    sent: list[bytes] = []
    with pytest.raises(frames.FrameError, match="the source gives 640x480 frames, the camera's section says 320x240"):
        camera.stream(frames.Capture(path, start=time.time()), sent.append, threading.Event(), 0.008, (320, 240))
    assert sent == []
