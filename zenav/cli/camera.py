"""`zenav camera`: calibrate the overhead camera, save an annotated snapshot, stream a real camera's frames,
detect the tags in a picture.

A frame comes from --image (a picture file), --device (a video file, a webcam index or
a URL; default [camera] device), --sim (calibrate: rendered here as the sim renders it) or,
when none is set, the field's frame topic
(zenav/field/camera/frame: the sim with `--set sim.camera=true`, or `zenav camera stream`).
Every verb needs OpenCV (zenav[camera]); its modules are imported when a verb runs.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from zenav.cli import intrinsics
from zenav.cli.checks import Failed
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE
from zenav.cli.nav import open_client
from zenav.cli.session import robot_id
from zenav.common import codec, extras, keys
from zenav.common import messages as m
from zenav.common.app import deployment_args, settings_from_args, stop_on_signals
from zenav.common.client import Unavailable
from zenav.common.config import AUTO_CALIBRATION, CALIBRATION_FILE, Camera
from zenav.services.vps import frames

if TYPE_CHECKING:
    from zenav.services.vps.calibration import Calibration
    from zenav.services.vps.detect import Tag

FRAME_KEY = keys.field_key("camera/frame")
SETTLE_FRAMES = 5  # frames read from a live source before the one used (exposure settles)


DETECT_EPILOG = """exit codes: 0 tags found, 1 no tag found, 2 the file cannot be read as an image
(missing, empty, not a picture), bad arguments or OpenCV not installed"""


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("camera", help="the overhead camera: calibrate, snapshot, stream, detect; a lens's intrinsics")
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    d = verbs.add_parser(
        "detect",
        help="print the tag36h11 tags found in a picture: id, corners [px], decision margin",
        epilog=DETECT_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    d.add_argument("image", help="the picture (any format OpenCV reads: PNG, JPEG, ...)")
    d.add_argument(
        "--detector",
        choices=("auto", "apriltag", "opencv"),
        default="auto",
        help="apriltag (pupil-apriltags), opencv (OpenCV alone) or auto: apriltag if installed (default auto)",
    )
    d.add_argument(
        "--tag-px",
        type=float,
        default=0.0,
        metavar="N",
        help="edge of the smallest tag to find [px]: from 24 the picture is searched at half size (faster);"
        " default: any size, the full picture",
    )
    d.add_argument("--json", action="store_true", help="print one JSON object: the picture, the detector, the tags")
    d.set_defaults(func=run_detect)
    intrinsics.add_verb(verbs)
    for name, text in (
        ("calibrate", "fit the floor homography to the fixed tags in one frame; write [camera] calibration"),
        ("snapshot", "save a PNG of one frame with the field grid, the tags and the fixes drawn"),
        ("stream", "publish frames of a video file, webcam or URL on zenav/field/camera/frame (--onboard: the robot's)"),
    ):
        v = verbs.add_parser(name, help=text)
        deployment_args(v)
        v.add_argument("--device", help="video file, webcam index or URL (default [camera] device)")
        if name == "stream":
            v.add_argument(
                "--onboard",
                action="store_true",
                help="a camera on the robot: [onboard_camera]'s frames on zenav/<robot>/camera/onboard/frame (--device required)",
            )
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


def opencv() -> Any:
    """cv2; MissingExtra (printed by `zenav` as one line) when OpenCV is not installed."""
    return extras.require("cv2", "the camera")


def read_picture(path: str) -> np.ndarray:
    """A picture file as a grey image; RuntimeError says why it cannot be read (missing, empty, not a picture)."""
    cv2 = opencv()
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise RuntimeError(f"cannot read {path}: {e.strerror or e}") from None
    if not data:
        raise RuntimeError(f"cannot read {path}: the file is empty")
    img = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise RuntimeError(f"cannot read {path}: not a picture OpenCV can decode (PNG, JPEG, ...)")
    return cast(np.ndarray, img)


def grab(args: argparse.Namespace, cfg: Camera) -> np.ndarray:
    """One grey frame from --image, the device, or the bus; RuntimeError says what was missing."""
    opencv()
    if getattr(args, "sim", False):
        from zenav.world.render import Renderer

        return Renderer(cfg, settings_seed(args)).render(0.0, [])
    if args.image:
        return read_picture(args.image)
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


def detector_of(args: argparse.Namespace, cfg: Camera) -> Any:
    """The detector the vps would use: [vps] detector, for the robots' tags' size in this camera's frames."""
    from zenav.services.vps import detect
    from zenav.services.vps.service import VpsConfig
    from zenav.world.camera import tag_pixels

    return detect.make(settings_from_args(args).section("vps", VpsConfig).detector, tag_pixels(cfg))


def run_calibrate(args: argparse.Namespace) -> int:
    cfg = _config(args)
    opencv()
    from zenav.services.vps import calibration, calibration_file
    from zenav.services.vps.calibration import CalibrationError

    try:
        img = grab(args, cfg)
        if img.shape != (cfg.height, cfg.width):
            raise RuntimeError(f"frame is {img.shape[1]}x{img.shape[0]}, [camera] says {cfg.width}x{cfg.height}")
        tags = detector_of(args, cfg).detect(img)
        cal = calibration.calibrate(tags, cfg)
    except (RuntimeError, frames.FrameError, CalibrationError) as e:
        print(f"zenav camera calibrate: {e}", file=sys.stderr)
        return EXIT_FAILED
    except Unavailable as e:
        print(f"zenav camera calibrate: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    path = args.output or (CALIBRATION_FILE if cfg.calibration == AUTO_CALIBRATION else cfg.calibration)
    calibration_file.save(cal, path)
    residual = f"corner residual {cal.rms * 1000:.2f} mm rms"
    print(f"wrote {path}: fixed tags {list(cal.anchors)}, {residual}, camera {cal.camera_height():.3f} m above the floor")
    return EXIT_OK


def run_snapshot(args: argparse.Namespace) -> int:
    cfg = _config(args)
    cv2 = opencv()
    from zenav.services.vps import calibration, calibration_file, locate, overlay
    from zenav.services.vps.calibration import CalibrationError

    try:
        img = grab(args, cfg)
    except (RuntimeError, frames.FrameError) as e:
        print(f"zenav camera snapshot: {e}", file=sys.stderr)
        return EXIT_FAILED
    except Unavailable as e:
        print(f"zenav camera snapshot: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    tags = detector_of(args, cfg).detect(img)
    cal: Calibration | None = None
    found = None
    try:
        cal = calibration_file.configured(cfg) or calibration.calibrate(tags, cfg)
        found = locate.locate(tags, cal, cfg.robots, {a.id for a in cfg.anchors}, cfg.tag_size, cfg.tag_height, cfg.corner_sigma)
    except CalibrationError as e:
        print(f"zenav camera snapshot: no grid or fixes drawn: {e}", file=sys.stderr)
    cv2.imwrite(args.output, overlay.draw(img, tags, cfg, cal, found))
    fixes = ", ".join(f"{f.robot} ({f.x:.3f}, {f.y:.3f}, {f.theta:.3f})" for f in found.fixes) if found else "none"
    print(f"wrote {args.output}: tags {sorted(t.id for t in tags)}; fixes {fixes}")
    return EXIT_OK


def stream(
    cap: frames.Capture, publish: Callable[[bytes], None], done: threading.Event, exposure: float, size: tuple[int, int] | None = None
) -> int:
    """Publish every frame of a source as a CameraFrame until it ends or `done` is set (a file plays at its own pace); frames sent.
    `size` (width, height) [px]: the camera section's; a frame of another size stops it (FrameError: the vps would refuse them all)."""
    seq = 0
    while not done.is_set():
        shot = cap.read()
        if shot is None:
            break
        h, w = shot.img.shape
        if size is not None and (w, h) != size:
            raise frames.FrameError(
                f"the source gives {w}x{h} frames, the camera's section says {size[0]}x{size[1]}: set its width and height"
            )
        if not cap.live:
            done.wait(max(shot.t - time.time(), 0.0))
        seq += 1
        publish(codec.encode(frames.encode(shot.img, shot.t, seq, exposure)))
    return seq


def stream_target(args: argparse.Namespace) -> tuple[str, str, float, tuple[int, int]]:
    """Where `zenav camera stream` publishes: (key, source, exposure [s], frame size [px]); --onboard: the robot's own
    camera ([onboard_camera], --device only), else the field's overhead one ([camera], --device or its device)."""
    settings = settings_from_args(args)
    if args.onboard:
        from zenav.common.onboardcam import OnboardCamera

        onb = settings.section("onboard_camera", OnboardCamera)
        key = keys.key(robot_id(args), "camera/onboard/frame")
        return key, args.device or "", onb.exposure, (onb.width, onb.height)
    cfg = settings.section("camera", Camera)
    return FRAME_KEY, args.device or cfg.device, cfg.exposure, (cfg.width, cfg.height)


def run_stream(args: argparse.Namespace) -> int:
    """Publish a source's frames, stamped on the host's wall clock (the stack's clock with deployment.clock = "wall")."""
    try:
        key, device, exposure, size = stream_target(args)
    except Failed as e:
        print(f"zenav camera stream: {e.message}", file=sys.stderr)
        return e.code
    opencv()
    if not device:
        where = "--device (a video file, a webcam index or a URL)" + ("" if args.onboard else " or [camera] device")
        print(f"zenav camera stream: name a source: {where}", file=sys.stderr)
        return EXIT_FAILED
    try:
        cap = frames.Capture(device, now=time.time, start=time.time(), delay=exposure / 2.0)
    except frames.FrameError as e:
        print(f"zenav camera stream: {e}", file=sys.stderr)
        return EXIT_FAILED
    try:
        with open_client(args) as client:
            sent = stream(cap, lambda data: client.bus.publish(key, data), stop_on_signals(), exposure, size)
    except Unavailable as e:
        print(f"zenav camera stream: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    except frames.FrameError as e:
        print(f"zenav camera stream: {e}", file=sys.stderr)
        return EXIT_FAILED
    finally:
        cap.close()
    print(f"published {sent} frames on {key}")
    return EXIT_OK


def tag_line(tag: Tag) -> str:
    """One tag as `zenav camera detect` prints it."""
    corners = " ".join(f"({x:.2f}, {y:.2f})" for x, y in tag.corners)
    return f"tag {tag.id}: corners {corners} margin {tag.margin:.1f}"


def run_detect(args: argparse.Namespace) -> int:
    """Print the tags in a picture; exit 1 when there is none, 2 when the file is no picture."""
    from zenav.services.vps import detect

    try:
        img = read_picture(args.image)
    except RuntimeError as e:
        print(f"zenav camera detect: {e}", file=sys.stderr)
        return EXIT_USAGE
    backend = detect.resolve(args.detector)
    tags = sorted(detect.make(backend, args.tag_px).detect(img), key=lambda t: (t.id, t.corners[0, 1], t.corners[0, 0]))
    if args.json:
        found = [{"id": t.id, "corners": np.round(t.corners, 3).tolist(), "margin": round(t.margin, 2)} for t in tags]
        print(json.dumps({"image": args.image, "width": img.shape[1], "height": img.shape[0], "detector": backend, "tags": found}))
    else:
        for t in tags:
            print(tag_line(t))
    if not tags:
        print(f"zenav camera detect: no tag36h11 tag found in {args.image} ({backend} detector)", file=sys.stderr)
        return EXIT_FAILED
    if not args.json:
        print(f"{len(tags)} tags in {args.image} ({img.shape[1]}x{img.shape[0]}, {backend} detector)")
    return EXIT_OK
