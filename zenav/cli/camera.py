"""`zenav camera`: calibrate the overhead camera, save an annotated snapshot, stream a real camera's frames.

A frame comes from --image (a picture file), --device (a video file, a webcam index or
a URL; default [camera] device), --sim (calibrate: rendered here as the sim renders it) or,
when none is set, the field's frame topic
(zenav/field/camera/frame: the sim with `--set sim.camera=true`, or `zenav camera stream`).
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from collections.abc import Callable

import cv2
import numpy as np

from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE
from zenav.cli.nav import open_client
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import deployment_args, settings_from_args, stop_on_signals
from zenav.common.client import Unavailable
from zenav.common.config import AUTO_CALIBRATION, CALIBRATION_FILE, Camera
from zenav.services.vps import calibration, detect, frames, locate, overlay
from zenav.services.vps.calibration import Calibration, CalibrationError
from zenav.world.camera import tag_pixels
from zenav.world.render import Renderer

FRAME_KEY = keys.field_key("camera/frame")
SETTLE_FRAMES = 5  # frames read from a live source before the one used (exposure settles)


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("camera", help="the overhead camera: calibrate, snapshot, stream")
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    for name, text in (
        ("calibrate", "fit the floor homography to the fixed tags in one frame; write [camera] calibration"),
        ("snapshot", "save a PNG of one frame with the field grid, the tags and the fixes drawn"),
        ("stream", "publish frames of a video file, webcam or URL on zenav/field/camera/frame"),
    ):
        v = verbs.add_parser(name, help=text)
        deployment_args(v)
        v.add_argument("--device", help="video file, webcam index or URL (default [camera] device)")
        if name == "calibrate":
            v.add_argument("--sim", action="store_true", help="use the frame the sim renders from [camera] (no bus needed)")
        if name != "stream":
            v.add_argument("--image", help="read the frame from this picture file")
            v.add_argument("--timeout", type=float, default=5.0, help="wait this long for a frame on the bus [s] (default 5)")
        v.add_argument(
            "--output",
            "-o",
            help={"calibrate": f"file to write (default [camera] calibration; {CALIBRATION_FILE} when that is auto)"}.get(
                name, "PNG to write"
            ),
        )
        v.set_defaults(func={"calibrate": run_calibrate, "snapshot": run_snapshot, "stream": run_stream}[name])
        if name == "snapshot":
            v.set_defaults(output="snapshot.png")


def _config(args: argparse.Namespace) -> Camera:
    return settings_from_args(args).section("camera", Camera)


def settings_seed(args: argparse.Namespace) -> int:
    """The deployment's seed (the sim renders its frames with it)."""
    return settings_from_args(args).deployment.seed


def grab(args: argparse.Namespace, cfg: Camera) -> np.ndarray:
    """One grey frame from --image, the device, or the bus; RuntimeError says what was missing."""
    if getattr(args, "sim", False):
        return Renderer(cfg, settings_seed(args)).render(0.0, [])
    if args.image:
        img = cv2.imread(args.image, cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise RuntimeError(f"cannot read picture {args.image}")
        return img
    device = args.device or cfg.device
    if device:
        cap = frames.Capture(device)
        try:
            shots = [cap.read() for _ in range(1 if not cap.live else SETTLE_FRAMES)]
        finally:
            cap.close()
        if shots[-1] is None:
            raise RuntimeError(f"no frame from {device}")
        return shots[-1].img
    got: list[m.CameraFrame] = []
    arrived = threading.Event()

    def on_frame(key: str, data: bytes) -> None:
        if not arrived.is_set():
            got.append(codec.decode(data, m.CameraFrame))
            arrived.set()

    with open_client(args) as client:
        handle = client.bus.subscribe(FRAME_KEY, on_frame)
        try:
            if not arrived.wait(args.timeout):
                raise RuntimeError(
                    f"no frame on {FRAME_KEY} within {args.timeout:g} s: start the sim with `--set sim.camera=true`, "
                    "run `zenav camera stream --device ...`, or pass --device / --image"
                )
        finally:
            handle.undeclare()
    return frames.decode(got[0], cfg.width, cfg.height)


def run_calibrate(args: argparse.Namespace) -> int:
    cfg = _config(args)
    try:
        img = grab(args, cfg)
        if img.shape != (cfg.height, cfg.width):
            raise RuntimeError(f"frame is {img.shape[1]}x{img.shape[0]}, [camera] says {cfg.width}x{cfg.height}")
        tags = detect.make("apriltag", tag_pixels(cfg)).detect(img)
        cal = calibration.calibrate(tags, cfg)
    except (RuntimeError, frames.FrameError, CalibrationError) as e:
        print(f"zenav camera calibrate: {e}", file=sys.stderr)
        return EXIT_FAILED
    except Unavailable as e:
        print(f"zenav camera calibrate: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    path = args.output or (CALIBRATION_FILE if cfg.calibration == AUTO_CALIBRATION else cfg.calibration)
    cal.save(path)
    residual = f"corner residual {cal.rms * 1000:.2f} mm rms"
    print(f"wrote {path}: fixed tags {list(cal.anchors)}, {residual}, camera {cal.camera_height():.3f} m above the floor")
    return EXIT_OK


def run_snapshot(args: argparse.Namespace) -> int:
    cfg = _config(args)
    try:
        img = grab(args, cfg)
    except (RuntimeError, frames.FrameError) as e:
        print(f"zenav camera snapshot: {e}", file=sys.stderr)
        return EXIT_FAILED
    except Unavailable as e:
        print(f"zenav camera snapshot: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    tags = detect.make("apriltag", tag_pixels(cfg)).detect(img)
    cal: Calibration | None = None
    found = None
    try:
        cal = calibration.configured(cfg) or calibration.calibrate(tags, cfg)
        found = locate.locate(tags, cal, cfg.robots, {a.id for a in cfg.anchors}, cfg.tag_size, cfg.tag_height, cfg.corner_sigma)
    except CalibrationError as e:
        print(f"zenav camera snapshot: no grid or fixes drawn: {e}", file=sys.stderr)
    cv2.imwrite(args.output, overlay.draw(img, tags, cfg, cal, found))
    fixes = ", ".join(f"{f.robot} ({f.x:.3f}, {f.y:.3f}, {f.theta:.3f})" for f in found.fixes) if found else "none"
    print(f"wrote {args.output}: tags {sorted(t.id for t in tags)}; fixes {fixes}")
    return EXIT_OK


def stream(cap: frames.Capture, publish: Callable[[bytes], None], done: threading.Event, exposure: float) -> int:
    """Publish every frame of a source as a CameraFrame until it ends or `done` is set (a file plays at its own pace); frames sent."""
    seq = 0
    while not done.is_set():
        shot = cap.read()
        if shot is None:
            break
        if not cap.live:
            done.wait(max(shot.t - time.time(), 0.0))
        seq += 1
        publish(codec.encode(frames.encode(shot.img, shot.t, seq, exposure)))
    return seq


def run_stream(args: argparse.Namespace) -> int:
    """Publish a source's frames, stamped on the host's wall clock (the stack's clock with deployment.clock = "wall")."""
    cfg = _config(args)
    device = args.device or cfg.device
    if not device:
        print("zenav camera stream: name a source: --device (a video file, a webcam index or a URL) or [camera] device", file=sys.stderr)
        return EXIT_FAILED
    try:
        cap = frames.Capture(device, now=time.time, start=time.time(), delay=cfg.exposure / 2.0)
    except frames.FrameError as e:
        print(f"zenav camera stream: {e}", file=sys.stderr)
        return EXIT_FAILED
    try:
        with open_client(args) as client:
            sent = stream(cap, lambda data: client.bus.publish(FRAME_KEY, data), stop_on_signals(), cfg.exposure)
    except Unavailable as e:
        print(f"zenav camera stream: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    finally:
        cap.close()
    print(f"published {sent} frames on {FRAME_KEY}")
    return EXIT_OK
