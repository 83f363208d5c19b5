"""Camera frames: the message, refused frames, and the video sources."""

import cv2
import msgspec
import numpy as np
import pytest

from tests.support.images import huge_png
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.config import Camera, ConfigError, Limits
from zenav.services.vps import frames
from zenav.services.vps.frames import FrameError


def image(h=48, w=64, seed=0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (h, w), dtype=np.uint8)


def test_the_frame_key_is_field_level():
    assert keys.field_key("camera/frame") == "zenav/field/camera/frame"
    assert keys.FIELD_TOPICS["camera/frame"] is m.CameraFrame


@pytest.mark.parametrize("encoding", ["mono8", "png"])
def test_a_frame_survives_the_wire(encoding):
    img = image()
    msg = codec.decode(codec.encode(frames.encode(img, 1.5, 7, 0.008, encoding)), m.CameraFrame)
    assert (msg.t, msg.seq, msg.width, msg.height, msg.encoding) == (1.5, 7, 64, 48, encoding)
    assert np.array_equal(frames.decode(msg, 64, 48), img)


def test_a_jpeg_frame_is_close():
    img = np.full((48, 64), 120, np.uint8)
    back = frames.decode(frames.encode(img, 0.0, 0, encoding="jpeg"), 64, 48)
    assert np.abs(back.astype(int) - 120).max() <= 2


def test_a_frame_of_the_wrong_size_is_refused():
    with pytest.raises(FrameError, match="64x48, the camera is configured 640x480"):
        frames.decode(frames.encode(image(), 0.0, 0), 640, 480)


def test_corrupt_frames_are_refused():
    good = frames.encode(image(), 0.0, 0)
    short = msgspec.structs.replace(good, data=good.data[:-1])
    with pytest.raises(FrameError, match="3071 bytes"):
        frames.decode(short, 64, 48)
    png = frames.encode(image(), 0.0, 0, encoding="png")
    with pytest.raises(FrameError, match="does not decode"):
        frames.decode(msgspec.structs.replace(png, data=png.data[:40]), 64, 48)
    lying = msgspec.structs.replace(frames.encode(image(24, 32), 0.0, 0, encoding="png"), width=64, height=48)
    with pytest.raises(FrameError, match="png header says 32x24"):
        frames.decode(lying, 64, 48)


@pytest.fixture(scope="module")
def bomb() -> bytes:
    return huge_png(16384, 16384)


@pytest.mark.parametrize("encoding", ["png", "jpeg"])
def test_the_header_size_is_checked_before_decoding(monkeypatch, bomb, encoding):
    if encoding == "png":
        data = bomb
    else:
        data = frames.encode(np.zeros((96, 128), np.uint8), 0.0, 0, encoding="jpeg").data
    lying = m.CameraFrame(t=0.0, width=64, height=48, encoding=encoding, data=data)  # the message claims the configured size

    def never(*args):
        raise AssertionError("decoded before its size was checked")

    monkeypatch.setattr(cv2, "imdecode", never)
    size = "16384x16384" if encoding == "png" else "128x96"
    with pytest.raises(FrameError, match=f"{encoding} header says {size}, the camera is configured 64x48"):
        frames.decode(lying, 64, 48)


@pytest.mark.parametrize("data", [b"", b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff\xd9", b"not an image at all"])
def test_a_frame_without_a_readable_header_is_refused_undecoded(monkeypatch, data):
    monkeypatch.setattr(cv2, "imdecode", lambda *a: pytest.fail("decoded"))
    for encoding in ("png", "jpeg"):
        with pytest.raises(FrameError, match="header"):
            frames.decode(m.CameraFrame(t=0.0, width=64, height=48, encoding=encoding, data=data), 64, 48)


def test_bad_frame_messages_fail_decoding():
    raw = msgspec.msgpack.encode({"t": 1.0, "width": 0, "height": 48, "data": b""})
    with pytest.raises(codec.BadInput, match="width"):
        codec.decode(raw, m.CameraFrame)
    raw = msgspec.msgpack.encode({"t": 1.0, "width": 64, "height": 48, "encoding": "bmp", "data": b""})
    with pytest.raises(codec.BadInput, match="encoding"):
        codec.decode(raw, m.CameraFrame)


def test_a_video_file_gives_grey_frames_on_its_own_timeline(tmp_path):
    path = str(tmp_path / "field.avi")
    out = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (64, 48))
    assert out.isOpened()
    for k in range(5):
        out.write(cv2.cvtColor(np.full((48, 64), 40 * k, np.uint8), cv2.COLOR_GRAY2BGR))
    out.release()
    cap = frames.Capture(path, start=100.0)
    got = [cap.read() for _ in range(6)]
    cap.close()
    assert got[5] is None  # the end of the file
    shots = [g for g in got if g is not None]
    assert [g.img.shape for g in shots] == [(48, 64)] * 5
    assert [round(float(g.img.mean()) / 40) for g in shots] == [0, 1, 2, 3, 4]
    assert np.diff([g.t for g in shots]) == pytest.approx([0.1] * 4, abs=1e-3) and shots[0].t >= 100.0


def test_a_source_that_does_not_open_names_the_setting(tmp_path):
    with pytest.raises(FrameError, match=r"\[camera\] device"):
        frames.Capture(str(tmp_path / "missing.mp4"))


def test_a_frame_larger_than_the_payload_limit_is_a_config_error():
    frames.check_fits(Camera(), Limits())  # 640 x 480 fits in 1 MiB
    with pytest.raises(ConfigError, match=r"raise \[limits\] max_payload"):
        frames.check_fits(Camera(width=1280, height=960), Limits())
    frames.check_fits(Camera(width=1280, height=960), Limits(max_payload=2 << 20))


class FakeWebcam:
    """A live source whose driver reports each buffer's time on the monotonic clock (as V4L2 does)."""

    def __init__(self, buffer_time: float) -> None:
        self.buffer_time = buffer_time  # [s]

    def grab(self) -> bool:
        return True

    def get(self, prop: int) -> float:
        assert prop == cv2.CAP_PROP_POS_MSEC
        return self.buffer_time * 1000.0

    def retrieve(self) -> tuple[bool, np.ndarray]:
        return True, np.zeros((48, 64, 3), np.uint8)

    def release(self) -> None:
        pass


@pytest.mark.parametrize(
    "buffer_time, expect",
    [
        (49.96, 1000.0 - 0.04 - 0.004),  # the driver's capture time, 40 ms before grab() returned
        (5.0, 1000.0 - 0.004),  # 45 s old: not a time on this clock (an RTSP stream's position): grab()'s
        (50.5, 1000.0 - 0.004),  # in the future: likewise
    ],
)
def test_a_live_frame_is_stamped_at_its_capture_when_the_driver_knows_it(buffer_time, expect):
    cap = frames.Capture("0", now=lambda: 1000.0, delay=0.004, monotonic=lambda: 50.0, cap=FakeWebcam(buffer_time))
    shot = cap.read()
    assert shot is not None and shot.img.shape == (48, 64)
    assert shot.t == pytest.approx(expect)
