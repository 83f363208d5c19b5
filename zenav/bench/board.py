"""What the robot computer spends: the `robot` profile and the robot's own camera's vps on the emulated motor board.

The board (tools/arduino_emulator.py on a pseudo-terminal, in this process: its CPU is
the board's, not the robot computer's), the robot's camera (bench/camfeed.py: 640 x 480
frames of the field's tags at 10 Hz, raw as `zenav camera stream --onboard` sends them,
from a thread of this process) and the profile's services as `zenav up --profile robot
--services ...,vps --set vps.source=onboard` starts them (the wall clock, services as
Zenoh peers of one router), while a program drives a square at SPEED (its pose set at the
start, then the vps's fixes). The camera is the robot's own, not an overhead camera's: an
overhead camera's vps runs on the camera's host and serves every robot, the onboard one
runs on each robot. Each deployment in turn: every service its own process, the four
robot services in one, all six in one. Over the window: each process's CPU (/proc), and
the rate the odometry took the driver's encoder samples at (its diag: whether the driver
kept its sensor rate). Then, for half a window more, each `motors/wheels` command's age as
it reaches this process, from the driver's stamp of the encoder sample it was made from
(its `t`, on the wall clock): the control loop's latency on the robot computer, the serial
link's replies aside; and the vps's fixes the localizer took and refused. Not in the CPU
window: composed, the commands and fixes leave the process only for someone outside who
listens, and would cost it that.

`zenav bench cost` measures it with the rate and robot sweeps.
"""

from __future__ import annotations

import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from zenav import services
from zenav.bench import trials
from zenav.bench.camfeed import CameraFeed
from zenav.bench.latency import Stats
from zenav.common import messages as m
from zenav.common.client import ZenavError
from zenav.common.roles import ALL, ROBOT_SERVICES
from zenav.robot import Robot
from zenav.stack.launcher import ProcStack
from zenav.tools.arduino_emulator import Emulator

TICKS = 1440  # [ticks/rev] the emulated encoders, and [robot] ticks_per_rev
SPEED = 0.15  # [m/s] what the board's PID holds on the emulated motors
SQUARE = ((0.5, 0.0), (0.5, 0.5), (0.0, 0.5), (0.0, 0.0))  # [m] corners driven in a loop
TOLERANCE = 0.03  # [m] a corner reached
GOAL_WAIT = 20.0  # [s] for the program's goal to end after the stop
START_TIMEOUT = 30.0  # [s] for the services to come up and the navigator to take goals
SETTLE = 2.0  # [s] of driving before the window opens
DIAG_WAIT = 5.0  # [s] for the odometry's diag after the window (one a second)
NAMES = tuple(n for n in ALL if n in (*services.PROFILES["robot"].services, "vps"))  # the profile and the vps, in start order
SEPARATE, COMPOSED = "every service its own process", "all six in one process"
DEPLOYMENTS: dict[str, tuple[str, ...]] = {SEPARATE: (), "the four robot services in one process": ROBOT_SERVICES, COMPOSED: NAMES}
BUDGET = {SEPARATE: 0.15, COMPOSED: 0.08}  # [cores] the robot computer's goals, router aside


@dataclass(frozen=True)
class BoardRun:
    """One deployment of the robot profile over the window."""

    cores: dict[str, float]  # process ("composed" for the composed one, "router") -> [cores] over the window
    encoders_hz: float  # [1/s] encoder samples the odometry took, over the last second of the window
    latency: Stats  # [ms] encoder sample (the driver's stamp) to its wheel command, here (another process)
    goal_failures: list[str]
    fixes: tuple[int, int] = (0, 0)  # the vps's fixes the localizer took, refused, after the window (half as long)

    @property
    def robot(self) -> float:
        """[cores] every process but the router."""
        return sum(c for name, c in self.cores.items() if name != "router")


def args(link: str) -> list[str]:
    """The services' arguments: the robot profile's config, the emulated board's port and geometry, the onboard camera's vps."""
    sets = [*services.PROFILES["robot"].sets(), f'driver.port="{link}"', "driver.open_delay=0", f"robot.ticks_per_rev={TICKS}"]
    sets += ['vps.source="onboard"']
    sets += ['odometry.heading_source="encoders"', "localizer.calib_sigma=0.002"]  # a board with no IMU; a calibrated robot
    return ["--zenoh-mode", "peer", *(a for s in sets for a in ("--set", s))]


def run(window: float, log_dir: Path, compose: tuple[str, ...] = ()) -> BoardRun:
    """Start the board and the services (`compose` in one process), film and drive: CPU over `window` wall seconds,
    then the commands' ages and the fixes over half as long."""
    with tempfile.TemporaryDirectory(prefix="zenav-board-") as tmp, Emulator(f"{tmp}/board", ticks_per_rev=TICKS) as emu:
        stack = ProcStack(("r1",), NAMES, log_dir, args(emu.link), compose=compose).start()
        try:
            with Robot("r1", stack.endpoint, lease=False) as bot:
                bot.client.wait_alive(NAMES, timeout=START_TIMEOUT)
                bot.set_pose(0.0, 0.0, 0.0)
                trials.wait_ready(bot, 1.0, START_TIMEOUT, NAMES)
                with CameraFeed(bot.client, emu.counts, TICKS):
                    return _drive(bot, stack, window)
        finally:
            stack.stop()


def _drive(bot: Robot, stack: ProcStack, window: float) -> BoardRun:
    """Drive the square: each process's CPU over the window, then the commands' ages and the fixes."""
    stop, goals = threading.Event(), list[trials.TrialGoal]()
    diag = bot.client.latest("diag/odometry")
    program = trials.drive(bot, goals, stop, 1.0, SQUARE, speed=SPEED, tolerance=TOLERANCE)
    try:
        stop.wait(SETTLE)
        stack.check()
        p0, w0 = stack.sample(), time.monotonic()
        stop.wait(window)  # the window: the program drives, the board turns the wheels, the camera films
        p1, w1, end = stack.sample(), time.monotonic(), time.time()
        stack.check()
        rate = diag.wait(lambda d: d.t >= end, timeout=DIAG_WAIT).rates.get("sensors/encoders", 0.0)
        ages: list[float] = []  # [ms] of each command made from a sample as it comes (on Zenoh's thread)
        fixes = [0, 0]  # taken, refused
        bot.client.subscribe("motors/wheels", lambda msg: _age(msg, ages))
        bot.client.subscribe("localizer/fixes", lambda fix: _fix(fix, fixes))
        stop.wait(window / 2.0)  # commands' ages and fixes, after the CPU window
        stack.check()
        taken, fixed = ages[:], (fixes[0], fixes[1])  # before the stop's zero, which comes from no sample
        if not program.is_alive():
            raise RuntimeError("the program driving the square ended before the window did: see its traceback")
        stop.set()
        try:
            bot.stop()  # ends the running goal at once, and with it the program's loop
        except ZenavError:
            pass  # a navigator that does not answer: its goal ends when the stack stops
        program.join(timeout=GOAL_WAIT)
    finally:
        stop.set()
    cores = {key[1]: (p1[key].cpu - p0[key].cpu) / (w1 - w0) for key in p1 if key in p0}
    return BoardRun(cores, rate, Stats.of(taken), trials.failed(goals), fixed)


def _age(msg: m.Wheels, ages: list[float]) -> None:
    """Note a wheel command's age [ms] from the encoder sample it was made from; one stamped t = 0 ("now": a stop,
    a goal's end) was made from none."""
    if msg.t > 0.0:
        ages.append(1e3 * (time.time() - msg.t))


def _fix(fix: m.Fix, fixes: list[int]) -> None:
    """Count a fix the localizer took (fixes[0]) or refused (fixes[1])."""
    fixes[0 if fix.accepted else 1] += 1


def budget(runs: dict[str, BoardRun]) -> list[tuple[str, float, float]]:
    """(deployment, its cores router aside, the goal) for each of BUDGET's deployments among `runs`."""
    return [(name, runs[name].robot, goal) for name, goal in BUDGET.items() if name in runs]


def measure(window: float, log_dir: Path) -> dict[str, BoardRun]:
    """Every deployment of DEPLOYMENTS in turn."""
    return {name: run(window, log_dir / f"board-{i}", compose) for i, (name, compose) in enumerate(DEPLOYMENTS.items())}
