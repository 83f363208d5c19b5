"""`zenav camera intrinsics`: calibrate a real camera's lens from a chessboard or ChArUco video (or pictures) with
OpenCV, and write the result into a config file's [onboard_camera] (or [camera]) section.

    zenav camera intrinsics board.mp4 --board chessboard --cols 9 --rows 6 --square 0.025 --write zenav.toml
    zenav camera intrinsics 0 --board charuco --cols 7 --rows 5 --square 0.04 --marker 0.03     # a webcam, printed

Move the board through the whole frame, near and far, tilted up to ~45 deg; every `--every`-th frame is tried, up to
`--max-views` views that show the board. Prints fx, fy, cx, cy, k1, k2, p1, p2, k3 and the reprojection error (a good
calibration: under 0.5 px). OpenCV is imported when the verb runs.
"""

from __future__ import annotations

import argparse
import glob
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from zenav.common import extras

MAX_FRAMES = 100_000  # frames read from a video or webcam at most


def add_verb(verbs: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """The `intrinsics` verb under `zenav camera`."""
    v = verbs.add_parser(
        "intrinsics",
        help="calibrate a camera's lens from a chessboard or ChArUco video; write [onboard_camera] fx ... k3",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    v.add_argument("source", nargs="+", help="a video file, a webcam index, or picture files (globs too)")
    v.add_argument("--board", choices=("chessboard", "charuco"), default="chessboard")
    v.add_argument("--cols", type=int, required=True, help="chessboard: inner corners across; charuco: squares across")
    v.add_argument("--rows", type=int, required=True, help="chessboard: inner corners down; charuco: squares down")
    v.add_argument("--square", type=float, required=True, help="edge of a square [m]")
    v.add_argument("--marker", type=float, default=0.0, help="charuco: edge of a marker [m]")
    v.add_argument("--dictionary", default="DICT_5X5_100", help="charuco: the ArUco dictionary (default DICT_5X5_100)")
    v.add_argument("--every", type=int, default=10, help="try every N-th frame of a video (default 10)")
    v.add_argument("--max-views", type=int, default=40, help="views of the board used at most (default 40)")
    v.add_argument("--k3", action="store_true", help="fit k3 too (wide lenses; default: held at 0)")
    v.add_argument("--section", choices=("onboard_camera", "camera"), default="onboard_camera", help="the section written")
    v.add_argument("--write", metavar="CONFIG", help="the config file to write the section into (else: printed)")
    v.set_defaults(func=run)


def frames_of(sources: list[str], every: int) -> Iterator[np.ndarray]:
    """Grey images: each picture file, or every `every`-th frame of one video or webcam."""
    import cv2

    from zenav.services.vps.frames import open_capture

    files = [f for s in sources for f in (sorted(glob.glob(s)) or [s])]
    if len(files) > 1 or Path(files[0]).suffix.lower() in (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"):
        for f in files:
            img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
            if img is None:
                raise ValueError(f"{f}: not a picture OpenCV reads")
            yield img
        return
    cap = open_capture(files[0])
    try:
        for n in range(MAX_FRAMES):
            ok, img = cap.read()
            if not ok:
                return
            if n % max(every, 1) == 0:
                yield img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    finally:
        cap.release()


def check(values: dict[str, float | int], section: str) -> None:
    """ValueError when the section would refuse the values (a calibration fitted to too few views)."""
    import msgspec

    from zenav.common.config import Camera
    from zenav.common.onboardcam import OnboardCamera

    try:
        msgspec.convert(values, OnboardCamera if section == "onboard_camera" else Camera)
    except msgspec.ValidationError as e:
        raise ValueError(f"[{section}] would refuse this calibration ({e}): take more views, over the whole frame") from None


def run(args: argparse.Namespace) -> int:
    if not extras.installed("cv2"):
        print("zenav camera intrinsics: needs OpenCV: pip install 'zenav[camera]'", file=sys.stderr)
        return EXIT_USAGE
    from zenav.tools.intrinsics import Board, IntrinsicsError, calibrate, write_section

    board = Board(args.board, args.cols, args.rows, args.square, args.marker, args.dictionary)
    if board.kind == "charuco" and not 0.0 < args.marker < args.square:
        print("zenav camera intrinsics: a ChArUco board needs 0 < --marker < --square", file=sys.stderr)
        return EXIT_USAGE
    try:
        got = calibrate(frames_of(args.source, args.every), board, args.max_views, args.k3)
        check(got.values(), args.section)
    except (IntrinsicsError, ValueError) as e:
        print(f"zenav camera intrinsics: {e}", file=sys.stderr)
        return EXIT_FAILED
    print(f"# {got.views} views of the board, reprojection error {got.rms:.3f} px rms ({got.width} x {got.height})")
    if args.write:
        path = Path(args.write)
        text = path.read_text() if path.exists() else ""
        path.write_text(write_section(text, args.section, got.values()))
        print(f"# written to [{args.section}] of {path}")
    else:
        print(write_section("", args.section, got.values()).strip())
    return EXIT_OK
