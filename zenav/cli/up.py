"""`zenav up`: a router and every service as its own process, with a live status screen."""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import zenoh

from zenav import services
from zenav.cli.router import warn_if_open
from zenav.cli.screen import render
from zenav.common import extras, keys
from zenav.common import messages as m
from zenav.common.app import deployment_args, settings_from_args, stop_on_signals
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.common.client import Client, Latest, Sampled, ZenavError
from zenav.common.config import ConfigError, Settings
from zenav.common.contract import GoalResult, State
from zenav.common.roles import ESSENTIAL
from zenav.common.scenarios import SQUARE
from zenav.robot import Goal, Result, Robot
from zenav.services.sim.service import SimConfig
from zenav.services.vps.service import VpsConfig
from zenav.stack.launcher import CRASH_WINDOW, MAX_CRASHES, Launcher, service_argv
from zenav.stack.logs import LOG_BYTES, LOG_FILES
from zenav.stack.router import DEFAULT_LISTEN, exposed, open_router

READY_STEP = 2.0  # [s] the demo asks whether the navigator is ready, saying why not, this often
FIELD_LISTEN = 1.0  # [s] `zenav up --connect` listens this long for camera frames from another robot's sim
DEMO_QUIET = 5.0  # [s] wall after someone else's goal ended before the demo drives again
HANG_AFTER = 3.0  # [s] wall without a service's diag (at rtf >= 1) before it is restarted as hung
GAVE_UP_ESSENTIAL = 3  # exit status of `zenav up` that stopped because an essential service could not run


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("up", help="start a router and every service, show live status; Ctrl-C stops all")
    deployment_args(p)
    p.add_argument("--listen", default=DEFAULT_LISTEN, help=f"endpoint of the embedded router (default {DEFAULT_LISTEN})")
    p.add_argument(
        "--router-connect",
        metavar="ENDPOINTS",
        help="link the embedded router to another host's router (tcp/10.0.0.1:7447; comma-separated), retried while it is away",
    )
    p.add_argument(
        "--profile",
        choices=sorted(services.PROFILES),
        default=services.DEFAULT_PROFILE,
        help=f"sim: the simulated robot; robot: a real one through the driver, on the wall clock (default {services.DEFAULT_PROFILE})",
    )
    p.add_argument("--services", help="comma-separated services to run (default: the profile's)")
    p.add_argument(
        "--compose",
        help="comma-separated services to run together in one process, for small computers (default: [deployment] compose)",
    )
    p.add_argument("--demo", action="store_true", help="drive a 1 m square in a loop through the navigator")
    p.add_argument("--duration", type=float, help="stop by itself after this many wall seconds")
    p.add_argument("--log-dir", type=Path, help="service logs (default: $XDG_STATE_HOME/zenav/logs)")
    p.add_argument("--wait-timeout", type=float, default=60.0, help="seconds to wait for every service (default 60)")
    p.add_argument(
        "--max-crashes",
        type=int,
        default=MAX_CRASHES,
        help=f"give up on a service that exits more often than this within --crash-window (default {MAX_CRASHES})",
    )
    p.add_argument(
        "--crash-window", type=float, default=CRASH_WINDOW, help=f"seconds over which --max-crashes counts exits (default {CRASH_WINDOW:g})"
    )
    p.add_argument(
        "--hang-after",
        type=float,
        default=HANG_AFTER,
        help=f"restart a service whose diag stopped this many seconds, more at rtf < 1; 0: never (default {HANG_AFTER:g})",
    )
    p.add_argument(
        "--log-size", type=float, default=LOG_BYTES / 2**20, help=f"MB of a log file before it is rotated (default {LOG_BYTES / 2**20:g})"
    )
    p.add_argument("--log-files", type=int, default=LOG_FILES, help=f"files kept per log, the current one included (default {LOG_FILES})")
    p.set_defaults(func=run)


def hang_after(seconds: float, settings: Settings) -> float:
    """The diag silence [s wall] that makes a service hung: `seconds`, longer when the sim runs
    slower than real time (diag is once a second of the stack clock, so 1/rtf wall seconds)."""
    rtf = settings.section("sim", SimConfig).rtf
    return seconds / min(rtf, 1.0)


def default_log_dir() -> Path:
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state")
    return Path(base) / "zenav" / "logs"


def child_args(args: argparse.Namespace, endpoint: str) -> list[str]:
    """What every service process is started with.

    With the embedded router alone everything runs on this host, so the services are Zenoh
    peers (they also link directly: lower latency and router CPU, see docs/running.md) unless
    --zenoh-mode says otherwise; with --connect they stay clients of that router, and so they do
    when the stack spans hosts (the router listens where other hosts reach it, or links to
    another's): a host's only link to the others is then its router's.
    """
    one_host = not (args.connect or args.router_connect or exposed(args.listen))
    mode = args.zenoh_mode or ("peer" if one_host else "client")
    out = ["--connect", endpoint, "--zenoh-mode", mode]
    for flag in ("robot", "config", "scenario", "seed"):  # --connect is the endpoint above
        value = getattr(args, flag)
        if value is not None:
            out += [f"--{flag}", str(value)]
    for item in args.set:
        out += ["--set", item]
    return out


def navigator_ready(bot: Robot, done: threading.Event, say: Callable[[str], None] = lambda line: None) -> bool:
    """Wait until the navigator would take a goal (False if stopped first); says why it
    waits whenever the reason changes (services not alive, no pose yet, too uncertain...)."""
    why = ""
    while not done.is_set():
        try:
            bot.wait_ready(timeout=READY_STEP)
            return True
        except TimeoutError as e:
            reason = str(e).split(": ", 1)[-1]
            if reason.split(":")[0] != why.split(":")[0]:
                say(f"demo: waiting for the navigator: {reason}")
            why = reason
        except ZenavError as e:
            say(f"demo: {e}")
            done.wait(1.0)
    return False


class DemoGate:
    """Whether the demo may send its next goal: not while a goal it did not send runs, nor
    while someone drives by cmd_vel (teleop, calibrate), nor until DEMO_QUIET after either
    (or after one of the demo's goals was cancelled) ended."""

    def __init__(self, quiet: float = DEMO_QUIET) -> None:
        self.quiet = quiet  # [s]
        self.mine: set[int] = set()  # goal ids the demo sent
        self.other: int | None = None  # id of the newest goal seen that the demo did not send
        self.busy_at: float | None = None  # [s] when someone else was last seen driving
        self.who = ""  # how they drive: "goal N", "cmd_vel"

    def interrupted(self, now: float) -> None:
        """One of the demo's goals was cancelled: someone else acted."""
        self.busy_at, self.who = now, ""

    def commanded(self, cmd: m.CmdVel, nav: m.NavState | None, now: float) -> None:
        """A cmd_vel was heard (on Zenoh's thread): one that moves while the navigator runs no goal is someone driving by hand."""
        if (cmd.v or cmd.omega) and (nav is None or nav.state == State.STOPPED):
            self.busy_at, self.who = now, "cmd_vel"

    def update(self, nav: m.NavState | None, now: float) -> bool:
        """Take the newest nav/state; True if the demo may drive now."""
        if nav is not None and nav.goal_id and nav.goal_id not in self.mine:
            if nav.result is None or nav.goal_id != self.other:  # running, or ended before it was ever seen
                self.busy_at, self.who = now, f"goal {nav.goal_id}"
            self.other = nav.goal_id
        return self.busy_at is None or now - self.busy_at >= self.quiet


def demo_loop(bot: Robot, done: threading.Event, say: Callable[[str], None], now: Callable[[], float] = time.monotonic) -> None:
    """Drive the square corner by corner until `done`, each goal to its end; while someone
    else drives (a goal the demo did not send, or cmd_vel by hand), pause, and resume
    DEMO_QUIET after they stopped."""
    if not navigator_ready(bot, done, say):
        return
    say("demo: driving a 1 m square, corner by corner")
    gate, state = DemoGate(), bot.client.latest("nav/state")
    i = 0
    while not done.is_set():
        if not gate.update(state.msg, now()):
            _pause(bot.client, gate, state, done, say, now)
            continue
        x, y = SQUARE[i % len(SQUARE)]
        try:
            goal = bot.move_to_point(x, y)
            gate.mine.add(goal.id)
            end = _wait(goal, done)
        except ZenavError as e:
            say(f"demo: {e}")
            done.wait(1.0)
            end = None
        if end is not None and end.result == GoalResult.CANCELLED:
            gate.interrupted(now())
            continue  # the same corner again, once the other goal is done
        if end is not None and not end.succeeded:
            say(f"demo goal ({x}, {y}) {end.result}: {end.message}")
            done.wait(1.0)
        i += 1


def _wait(goal: Goal, done: threading.Event) -> Result | None:
    """The goal's end, or None if `done` came first."""
    while not done.is_set():
        try:
            return goal.wait(timeout=1.0)
        except TimeoutError:
            pass
    return None


def _pause(
    client: Client, gate: DemoGate, state: Latest, done: threading.Event, say: Callable[[str], None], now: Callable[[], float]
) -> None:
    """Wait until the gate lets the demo drive again, saying so; meanwhile cmd_vel by hand keeps it waiting
    (followed only here: while a goal runs, the navigator's own 100 Hz cmd_vel would be decoded for nothing)."""
    who = f" ({gate.who})" if gate.who else ""
    say(f"demo: paused: someone else is driving{who}; the square resumes {gate.quiet:g} s after they stop")
    hand = client.subscribe("cmd_vel", lambda cmd: gate.commanded(cmd, state.msg, now()))
    try:
        while not done.is_set() and not gate.update(state.msg, now()):
            done.wait(0.2)
    finally:
        hand.undeclare()
    if not done.is_set():
        say("demo: resuming the square")


def more_vps(settings: Settings, names: Sequence[str]) -> dict[str, list[str]]:
    """The cameras' vps that [vps] also starts beside the robot's (when it runs): process name -> its own --set."""
    if "vps" not in names:
        return {}
    also = settings.section("vps", VpsConfig).also
    return {f"vps_{s}": ["--set", f'vps.source="{s}"', "--set", f'vps.name="{s}"', "--set", "vps.also=[]"] for s in also}


def frames_elsewhere(session: zenoh.Session, robot: str, wait: float = FIELD_LISTEN) -> bool:
    """Whether the field's camera frames already come from another robot's sim (frames heard within `wait`
    seconds while this robot's own sim is not up: a second instance of it is refused by its own check)."""
    if list(session.liveliness().get(keys.alive(robot, "sim"), timeout=wait)):
        return False
    heard = threading.Event()
    sub = session.declare_subscriber(keys.field_key("camera/frame"), lambda sample: heard.set())
    try:
        return heard.wait(wait)
    finally:
        sub.undeclare()


def run(args: argparse.Namespace) -> int:
    checked = _checked(args)
    if isinstance(checked, int):
        return checked
    names, settings, hang = checked
    robot = settings.robot_id
    more = more_vps(settings, names)
    # --connect: join a router that runs elsewhere; otherwise embed one (linked to --router-connect's).
    endpoint = args.connect or args.listen
    session = _session(args, settings, names)
    if session is None:
        return 2
    log_dir = args.log_dir or default_log_dir()
    events: list[str] = []
    tty = sys.stdout.isatty()

    def show(line: str) -> None:
        stamped = f"{time.strftime('%H:%M:%S')} {line}"
        events.append(stamped)
        del events[:-5]
        if not tty:
            print(stamped, flush=True)

    sup = Launcher(
        log_dir,
        events=show,
        max_crashes=args.max_crashes,
        crash_window=args.crash_window,
        hang_after=hang,
        log_bytes=int(args.log_size * 2**20),
        log_files=args.log_files,
    )
    say = sup.say  # on the screen and in launcher.log
    composed = [n for n in names if n in settings.deployment.compose]
    child_of = {n: "composed" if n in composed else n for n in names}  # service -> the child process running it
    for name in names:
        if name not in composed:
            sup.add(name, service_argv(name, child_args(args, endpoint)))
    for name, sets in more.items():
        sup.add(name, service_argv("vps", [*child_args(args, endpoint), *sets]))
    names = [*names, *more]
    child_of.update((n, n) for n in more)
    if composed:
        argv = [sys.executable, "-m", "zenav.stack.composed", "--services", ",".join(composed), *child_args(args, endpoint)]
        sup.add("composed", argv)
    bot = Robot(robot, bus=ZenohBus(session))  # closes the session when it closes
    client = bot.client
    for name in names:
        client.subscribe(f"diag/{name}", _beater(sup, child_of[name]))
    done = stop_on_signals()
    together = f"; {', '.join(composed)} in one process" if composed else ""
    linked = f", linked to {args.router_connect}" if args.router_connect else ""
    say(f"{'router at' if args.connect else 'router on'} {endpoint}{linked}; starting {', '.join(names)}{together} (logs in {log_dir})")
    t0 = time.monotonic()
    sup.start_all()
    status = 0
    try:
        if _wait_alive(client, sup, names, args.wait_timeout, done) is None:
            return 1
        say(f"all {len(names)} services alive in {time.monotonic() - t0:.1f} s")
        alive: set[str] = set()
        client.bus.watch_tokens(client.key("alive/*"), lambda key, up: (alive.add if up else alive.discard)(key.rsplit("/", 1)[-1]))
        topics = {s: client.newest(s) for s in ("sim/truth", "odom", "pose", "nav/state")}  # read as the screen is drawn
        diags = {n: client.latest(f"diag/{n}") for n in names}
        if args.demo:
            threading.Thread(target=demo_loop, args=(bot, done, say), daemon=True).start()
        deadline = None if args.duration is None else time.monotonic() + args.duration
        last_line = last_screen = 0.0
        while not done.is_set() and (deadline is None or time.monotonic() < deadline):
            lost = sup.poll()
            essential = [c for c in lost if any(child_of.get(n) == c for n in ESSENTIAL)]
            if essential:
                client.publish("cmd_vel", m.CmdVel(t=0.0, v=0.0, omega=0.0))
                say(f"{', '.join(essential)} cannot run: stopping the robot (zero command) and every service")
                status = GAVE_UP_ESSENTIAL
                break
            if lost:
                say(f"running degraded without {', '.join(lost)}")
            if tty and time.monotonic() - last_screen >= 0.5:
                screen = render(robot, endpoint, settings.deployment.scenario, sup, topics, diags, set(alive), events)
                screen += "".join(f"\nDEGRADED: {c.name} gave up: {c.gave_up}" for c in sup.children.values() if c.gave_up)
                sys.stdout.write("\x1b[H\x1b[2J" + screen + "\n")
                sys.stdout.flush()
                last_screen = time.monotonic()
            elif not tty and time.monotonic() - last_line >= 5.0:
                print(_summary(topics), flush=True)
                last_line = time.monotonic()
            done.wait(0.2)
    finally:
        done.set()
        _shutdown(client, sup, say, composed)
        sup.close()
        bot.close()
    return status


def _checked(args: argparse.Namespace) -> tuple[list[str], Settings, float | None] | int:
    """The services to start, their settings and the time after which a silent one is hung, all checked before
    anything starts; or the exit status (2) of a refusal, told on stderr."""
    profile = services.PROFILES[args.profile]
    names = [n.strip() for n in args.services.split(",") if n.strip()] if args.services else list(profile.services)
    unknown = set(names) - set(services.ALL)
    if unknown:
        print(f"zenav up: unknown service(s): {', '.join(sorted(unknown))} (the services: {', '.join(services.ALL)})", file=sys.stderr)
        return 2
    if args.demo and not profile.demo:
        print(
            f"zenav up: --demo drives the sim's square; on the {args.profile} profile drive with `zenav goto` or a program", file=sys.stderr
        )
        return 2
    camera = extras.installed("cv2")  # the base install has no OpenCV: the profile's camera settings are left out
    args.set = [*profile.sets(camera), *args.set]  # the profile's config, under the user's --set (children get both)
    flag = {} if args.compose is None else {"deployment": {"compose": [n.strip() for n in args.compose.split(",") if n.strip()]}}
    try:
        settings = settings_from_args(args, **flag)  # fail fast here rather than in six children
        for name in names:
            cls = services.load(name)
            if cls.config_type is not None:
                settings.section(name, cls.config_type)
        hang = hang_after(args.hang_after, settings) if args.hang_after > 0 else None
    except ConfigError as e:  # a feature's missing package too (extras.MissingExtra): [sim] camera, the driver...
        print(f"zenav up: {e}", file=sys.stderr)
        return 2
    if profile.camera and not camera:
        print("zenav up: no OpenCV here (pip install 'zenav[camera]'): the VPS is the synthetic one, no camera", file=sys.stderr)
    not_run = [n for n in settings.deployment.compose if n not in names] if args.compose is not None else []
    if not_run:  # a config's compose applies to whichever of its services run; the flag names this run's
        print(f"zenav up: --compose {', '.join(not_run)}: not started by this run (it starts {', '.join(names)})", file=sys.stderr)
        return 2
    if args.connect and args.router_connect:
        print("zenav up: --router-connect links the router zenav up embeds; with --connect it embeds none", file=sys.stderr)
        return 2
    return names, settings, hang


def _session(args: argparse.Namespace, settings: Settings, names: list[str]) -> zenoh.Session | None:
    """The session of `zenav up`: on the router it embeds, or (--connect) on one that runs elsewhere; None (told on
    stderr) if this robot's sim would be a second camera on the field's frames."""
    robot = settings.robot_id
    if not args.connect:
        warn_if_open("zenav up", args.listen)
    session = (
        zenoh.open(zenoh_config("client", connect=args.connect))
        if args.connect
        else open_router(
            args.listen, priority=settings.deployment.realtime, connect=args.router_connect, max_message=settings.limits.max_message()
        )
    )
    if args.connect and "sim" in names and settings.section("sim", SimConfig).camera and frames_elsewhere(session, robot):
        session.close()
        print(
            "zenav up: frames already come on zenav/field/camera/frame (another robot's sim renders the field's camera):"
            f" {robot}'s sim would be a second camera on that key, on a clock of its own, and spoil every robot's"
            " fixes. Run this robot with its own synthetic camera: --set sim.camera=false --set vps.source=synthetic",
            file=sys.stderr,
        )
        return None
    return session


def _beater(sup: Launcher, child: str) -> Callable[[m.Diag], None]:
    """A diag callback: a heartbeat of `child`."""
    return lambda msg: sup.beat(child)


def _wait_alive(client: Client, sup: Launcher, names: list[str], timeout: float, done: threading.Event) -> set[str] | None:
    deadline = time.monotonic() + timeout
    while not done.is_set():
        if sup.poll():
            print(f"zenav up: a service could not start; see the logs in {sup.log_dir}", file=sys.stderr)
            return None
        try:
            return client.wait_alive(names, timeout=min(1.0, max(deadline - time.monotonic(), 0.01)))
        except TimeoutError as e:
            if time.monotonic() >= deadline:
                print(f"zenav up: {e}; see the logs in {sup.log_dir}", file=sys.stderr)
                return None
    return None


def _summary(topics: dict[str, Sampled]) -> str:
    truth, pose, nav = topics["sim/truth"].msg, topics["pose"].msg, topics["nav/state"].msg
    parts = []
    if truth is not None:
        parts.append(f"t={truth.t:7.2f}s truth=({truth.x:+.3f},{truth.y:+.3f})")
    if pose is not None:
        parts.append(f"pose=({pose.x:+.3f},{pose.y:+.3f})")
    if nav is not None:
        parts.append(nav.state)
    return "  ".join(parts) or "waiting for data"


def _shutdown(client: Client, sup: Launcher, say: Callable[[str], None], composed: Sequence[str] = ()) -> None:
    """Navigator first, then a zero command, then the motor (zero wheels), the world last.

    The composed process stops at the place of its first service (it stops its own in order)."""
    say("stopping: wheels to zero first")
    child = {name: "composed" if name in composed else name for name in [*composed, *sup.children] if name != "composed"}
    base = {name: "vps" if name.startswith("vps_") else name for name in child}  # a camera's vps stops as the vps does
    order = list(dict.fromkeys(child[name] for name in sorted(child, key=lambda n: services.stop_order(base.values()).index(base[n]))))

    def after(group: Sequence[str]) -> None:
        if "navigator" in group or ("composed" in group and "navigator" in composed):
            client.publish("cmd_vel", m.CmdVel(t=0.0, v=0.0, omega=0.0))

    sup.stop([[name] for name in order], between=after)
    say("all services stopped")
