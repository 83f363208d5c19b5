"""`zenav calibrate`: UMBmark on the floor: squares both ways, then the wheel geometry into [robot].

The robot drives a square by its encoders alone (cmd_vel through the motor service;
the navigator must be idle), clockwise then counter-clockwise, `--runs` times each.
The end position comes from the VPS (`--measure vps`, the default) or is typed in
(`--measure manual`: measured from the start mark, x along the first leg, y to its
left). The fit gives the track width and the right/left wheel radius ratio; the track
width is written into the [robot] section of `--write` (default: `--config`).
`--cw X,Y --ccw X,Y` fit end errors measured before, without driving.

`--from-localizer` drives nothing: it reads the wheel geometry the running localizer has
learnt online (the calibration of its `localizer/pose` reply: the ekf learns it from the
gyro and the camera as the robot drives) and writes its track width and mean wheel
diameter into [robot], so that the next run starts calibrated.
"""

from __future__ import annotations

import argparse
import math
import queue
import sys
import time

from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE
from zenav.cli.nav import finite, point
from zenav.common import messages as m
from zenav.common.app import deployment_args, settings_from_args
from zenav.common.client import Client, ZenavError
from zenav.common.config import ConfigError, RobotConfig, set_keys
from zenav.services.driver import umbmark as u

CONNECT_TIMEOUT = 3.0  # [s]
SQUARE_TIMEOUT = 120.0  # [s] one square at most
SAMPLE_TIMEOUT = 1.0  # [s] no encoder sample this long: the square is abandoned
STILL_SAMPLES = 20  # encoder samples in a row without a tick: the wheels stand still
VPS_SAMPLES = 5  # VPS poses averaged at each end of a square
VPS_TIMEOUT = 5.0  # [s] for those


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("calibrate", help="UMBmark: drive squares both ways, fit the track width and wheel ratio into [robot]")
    deployment_args(p)
    p.add_argument("--side", type=finite, default=1.0, help="side of the square [m] (default 1.0)")
    p.add_argument("--runs", type=int, default=1, help="squares each way (UMBmark uses 5; default 1)")
    p.add_argument("--speed", type=finite, default=0.15, help="top speed of a leg [m/s] (default 0.15)")
    p.add_argument("--measure", choices=("vps", "manual"), default="vps", help="where the end positions come from (default vps)")
    p.add_argument("--write", metavar="TOML", help="config file to write [robot] track_width into (default: --config; none: print it)")
    p.add_argument(
        "--from-localizer", action="store_true", help="write the geometry the running localizer has learnt instead of driving squares"
    )
    p.add_argument("--cw", type=point, action="append", default=[], metavar="X,Y", help="a clockwise end error [m] measured before")
    p.add_argument("--ccw", type=point, action="append", default=[], metavar="X,Y", help="a counter-clockwise end error [m]")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        settings = settings_from_args(args)
    except ConfigError as e:
        print(f"zenav calibrate: {e}", file=sys.stderr)
        return EXIT_USAGE
    robot = settings.robot
    nominal = u.Geometry(robot.track_width, robot.wheel_radius, robot.wheel_radius)
    if args.side <= 0.0 or args.runs < 1:
        print("zenav calibrate: --side must be > 0 and --runs >= 1", file=sys.stderr)
        return EXIT_USAGE
    if bool(args.cw) != bool(args.ccw):
        print("zenav calibrate: give both --cw and --ccw errors, or neither (to drive)", file=sys.stderr)
        return EXIT_USAGE
    if args.from_localizer:
        if args.cw or args.ccw:
            print("zenav calibrate: --from-localizer drives no squares: give it no --cw or --ccw", file=sys.stderr)
            return EXIT_USAGE
        return from_localizer(args)
    runs = [u.Run(c, u.square(args.side, c, nominal.track), tuple(e)) for c in (True, False) for e in (args.cw if c else args.ccw)]
    if not runs:
        try:
            with Client(args.robot or "r1", args.connect, connect_timeout=CONNECT_TIMEOUT) as client:
                runs = drive_runs(client, args, robot, nominal)
        except ZenavError as e:
            print(f"zenav calibrate: {e}", file=sys.stderr)
            return EXIT_UNAVAILABLE
        except RuntimeError as e:
            print(f"zenav calibrate: {e}", file=sys.stderr)
            return EXIT_FAILED
    try:
        fit = u.fit(runs, nominal)
    except ValueError as e:
        print(f"zenav calibrate: {e}", file=sys.stderr)
        return EXIT_FAILED
    print(report(fit, nominal))
    write(args.write or args.config, {"track_width": round(fit.geometry.track, 5)})
    return EXIT_OK


def write(target: str | None, values: dict[str, float]) -> None:
    """Set [robot] `values` in the config file `target` (None: print them as its lines)."""
    lines = "\n".join(f"{k} = {v!r}" for k, v in values.items())
    if not target:
        print(f"[robot]\n{lines}")
        return
    with open(target, encoding="utf-8") as f:
        text = f.read()
    with open(target, "w", encoding="utf-8") as f:
        f.write(set_keys(text, "robot", values))
    print(f"wrote [robot] {', '.join(f'{k} = {v}' for k, v in values.items())} into {target}")


LEARNT = ("track_width", "wheel_diameter", "wheel_radius_left", "wheel_radius_right")  # the calibration's geometry [m]


def _sigma(cal: dict[str, float], key: str) -> str:
    """ ", +- the estimate's 1-sigma [%]" when the localizer gives it."""
    sigma = cal.get(f"{key}_sigma")
    return "" if sigma is None else f", +- {sigma * 100:.2f} %"


def from_localizer(args: argparse.Namespace) -> int:
    """Read the running localizer's learnt geometry and write it into [robot]."""
    try:
        with Client(args.robot or "r1", args.connect, connect_timeout=CONNECT_TIMEOUT) as client:
            reply = client.query("localizer/pose")
    except ZenavError as e:
        print(f"zenav calibrate: the localizer: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    cal = reply.calibration
    if not all(k in cal for k in LEARNT):
        print('zenav calibrate: the localizer learns no geometry in its mode (only [localizer] mode = "ekf" does)', file=sys.stderr)
        return EXIT_FAILED
    if cal["distance_scale"] == 1.0 and cal["track_width_scale"] == 1.0:
        print("zenav calibrate: the localizer has learnt nothing yet: drive the robot where the camera sees it first", file=sys.stderr)
        return EXIT_FAILED
    track, wheels = _sigma(cal, "track_width_scale"), _sigma(cal, "distance_scale")
    print(
        f"track width  {cal['track_width'] * 1e3:.2f} mm (x{cal['track_width_scale']:.4f} of the running config's{track})\n"
        f"wheels       {cal['wheel_diameter'] * 1e3:.3f} mm diameter (x{cal['distance_scale']:.4f}{wheels}); radii left / right "
        f"{cal['wheel_radius_left'] * 1e3:.3f} / {cal['wheel_radius_right'] * 1e3:.3f} mm ([robot] takes their mean)"
    )
    write(args.write or args.config, {"wheel_diameter": round(cal["wheel_diameter"], 6), "track_width": round(cal["track_width"], 6)})
    return EXIT_OK


def report(fit: u.Fit, nominal: u.Geometry) -> str:
    """The fit as the user reads it."""
    g = fit.geometry
    return "\n".join(
        [
            f"track width  {g.track * 1e3:.2f} mm (nominal {nominal.track * 1e3:.2f} mm, x{fit.track_scale:.4f})",
            f"wheel ratio  right/left {fit.ratio:.5f}: radii {g.radius_left * 1e3:.3f} / {g.radius_right * 1e3:.3f} mm (mean kept)",
            f"unexplained  {fit.rms * 1e3:.1f} mm rms (slip, noise, measuring: more runs average it out)",
        ]
    )


def drive_runs(client: Client, args: argparse.Namespace, robot: RobotConfig, nominal: u.Geometry) -> list[u.Run]:
    """Drive the squares clockwise, then counter-clockwise; measure each end."""
    runs: list[u.Run] = []
    vps: queue.Queue[m.VpsPose] = queue.Queue()
    if args.measure == "vps":
        client.subscribe("vps/pose", vps.put)
    for clockwise in (True, False):
        for i in range(args.runs):
            way = "clockwise" if clockwise else "counter-clockwise"
            ask(f"run {i + 1}/{args.runs} {way}: put the robot on the start mark, facing along the first leg; Enter to drive ")
            if "navigator" in client.alive():
                client.query("nav/stop")  # the robot is calibrate's alone: a goal running now would fight the square
            with Encoders(client) as encoders:
                rest = encoders.still(time.monotonic() + SQUARE_TIMEOUT)
                start = mean_pose(vps, since=rest) if args.measure == "vps" else (0.0, 0.0, 0.0)
                sq = u.Square(args.side, clockwise, nominal, robot.ticks_per_rev or 1, speed=args.speed)
                rest = drive_square(client, encoders, sq)
            end = mean_pose(vps, since=rest) if args.measure == "vps" else typed_end()
            x, y = start_frame(start, end)
            runs.append(u.Run(clockwise, sq.trace, (x - sq.pose[0], y - sq.pose[1])))
            print(f"  end error {runs[-1].error[0] * 1e3:+.1f}, {runs[-1].error[1] * 1e3:+.1f} mm")
    return runs


class Encoders:
    """The robot's encoder samples, queued from the subscription on, while in a `with` block."""

    def __init__(self, client: Client) -> None:
        self.samples: queue.Queue[m.Encoders] = queue.Queue()
        self._handle = client.subscribe("sensors/encoders", self.samples.put)

    def __enter__(self) -> Encoders:
        return self

    def __exit__(self, *exc: object) -> None:
        self._handle.undeclare()

    def next(self) -> m.Encoders:
        try:
            return self.samples.get(timeout=SAMPLE_TIMEOUT)
        except queue.Empty:
            raise RuntimeError(f"no sensors/encoders for {SAMPLE_TIMEOUT:g} s: is the driver up?") from None

    def still(self, deadline: float, sq: u.Square | None = None) -> float:
        """Follow the counts (into `sq`, so its pose includes any coasting) until STILL_SAMPLES samples in a row
        show no tick; the stack time [s] the wheels stood still from."""
        still, last, since = -1, None, 0.0
        while still < STILL_SAMPLES:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the wheels did not stop within {SQUARE_TIMEOUT:g} s: is something else driving?")
            e = self.next()
            if sq is not None:
                sq.step(e.left, e.right)
            if (e.left, e.right) == last:
                still += 1
            else:
                still, last, since = 0, (e.left, e.right), e.t
        return since


def drive_square(client: Client, encoders: Encoders, sq: u.Square) -> float:
    """Drive `sq` on the encoders' samples through cmd_vel; stop at the end (or on any failure), and
    follow the counts until the wheels stand still, so `sq.pose` includes the coasting.
    Returns the stack time [s] the wheels stood still from."""

    def send(v: float, omega: float) -> None:
        client.publish("cmd_vel", m.CmdVel(t=0.0, v=v, omega=omega))

    deadline = time.monotonic() + SQUARE_TIMEOUT
    try:
        while not sq.done:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the square took over {SQUARE_TIMEOUT:g} s: stopped")
            e = encoders.next()
            send(*sq.step(e.left, e.right))
        send(0.0, 0.0)
        return encoders.still(deadline, sq)
    finally:
        send(0.0, 0.0)


def mean_pose(vps: queue.Queue[m.VpsPose], since: float) -> tuple[float, float, float]:
    """The mean of the next VPS_SAMPLES poses captured at stack time `since` [s] or later (the robot standing still)."""
    got: list[m.VpsPose] = []
    deadline = time.monotonic() + VPS_TIMEOUT
    while len(got) < VPS_SAMPLES:
        try:
            pose = vps.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            raise RuntimeError(f"only {len(got)} vps/pose in {VPS_TIMEOUT:g} s: is the VPS up and the robot in view?") from None
        if pose.t >= since:
            got.append(pose)
    c = sum(math.cos(p.theta) for p in got)
    s = sum(math.sin(p.theta) for p in got)
    return sum(p.x for p in got) / len(got), sum(p.y for p in got) / len(got), math.atan2(s, c)


def ask(prompt: str) -> str:
    """A line the user typed; RuntimeError when there is no one to type it (stdin closed)."""
    try:
        return input(prompt)
    except EOFError:
        raise RuntimeError(
            "\nstdin is closed: calibrate waits for Enter before each square (and asks for the end position with"
            " --measure manual); run it in a terminal, or give errors measured before with --cw and --ccw"
        ) from None


def typed_end() -> tuple[float, float, float]:
    """The end position the user measured from the start mark (x along the first leg, y to its left) [m]."""
    while True:
        text = ask("  end position from the start mark, along the first leg and to its left [m], e.g. 0.031,-0.120: ")
        try:
            x, y = point(text)
            return x, y, 0.0
        except argparse.ArgumentTypeError as e:
            print(f"  {e}")


def start_frame(start: tuple[float, float, float], end: tuple[float, float, float]) -> tuple[float, float]:
    """`end` (map frame) in the frame of the `start` pose [m]."""
    dx, dy, th = end[0] - start[0], end[1] - start[1], start[2]
    return math.cos(th) * dx + math.sin(th) * dy, -math.sin(th) * dx + math.cos(th) * dy
