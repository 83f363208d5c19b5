"""`zenav plot IN.mcap -o OUT.png`: trajectory and error-over-time plots of a recording.

IN may be a finished recording or the OUT.mcap.part of a recorder that died.
Exit codes: 0 plotted, 1 nothing to plot or the image could not be written,
2 bad arguments or input file.
"""

from __future__ import annotations

import argparse
import math
import sys

from zenav.cli.checks import Failed, check_recording, check_robot, fail, note_unfinished
from zenav.cli.main import EXIT_FAILED, EXIT_OK


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("plot", help="plot truth, odom, fused pose and VPS fixes of a recording to a PNG")
    p.add_argument("input", metavar="IN.mcap", help="a recording made by `zenav record` (or its .part if the recorder died)")
    p.add_argument("-o", "--out", metavar="OUT.png", required=True, help="image to write")
    p.add_argument("--robot", help="robot id to plot (default: the first in the file)")
    p.add_argument("--title", help="figure title (default: the input file name)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from zenav.tools.plot import errors, plot_file, rms  # optional dependencies: imported when used

    try:
        check_robot(args.robot)
        finished = check_recording(args.input)
    except Failed as e:
        return fail("plot", e)
    if not finished:
        note_unfinished("plot", args.input)
    try:
        run_ = plot_file(args.input, args.out, args.robot, args.title)
    except (OSError, ValueError) as e:
        print(f"zenav plot: {e}", file=sys.stderr)
        return EXIT_FAILED
    for name in ("odom", "pose", "fixes"):
        _, pos, th = errors(getattr(run_, name), run_.truth)
        if len(pos):
            heading = math.degrees(rms(th))
            print(f"{name:<6} rms {rms(pos) * 100:6.2f} cm  final {pos[-1] * 100:6.2f} cm  heading rms {heading:5.2f} deg")
    print(f"wrote {args.out}", file=sys.stderr)
    return EXIT_OK
