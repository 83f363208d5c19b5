"""The driver service: a ROSArduinoBridge motor board as `sensors/encoders` and `motors/wheels`.

Wheel commands [rad/s] become the firmware's targets [ticks per PID frame] (`m L R`);
the counts are polled with `e` and published as the sim publishes them (cumulative,
signed 32-bit wrapping). The link is reopened when the cable is pulled; the counts
published go on from where they were (the board may restart at 0: the travel while
the link was down is not counted, so the odometry sees neither a jump nor a reset).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Annotated

from msgspec import Meta, Struct

from zenav.common import extras
from zenav.common import messages as m
from zenav.common.bus import Bus
from zenav.common.clock import Clock, WallClock
from zenav.common.config import Settings
from zenav.common.runtime import Service, on_liveliness, subscribe, timer
from zenav.services.driver import protocol as p
from zenav.services.driver.board import Board, LinkLost, NoReply

STOP = (0, 0)
JUMP_FACTOR = 3.0  # a count moving faster than this x the fastest target is not a wheel's doing [-]
JUMP_MARGIN = 10  # [ticks] jumps this small always pass (quantisation, a late reply)
JUMPS_TO_RESET = 3  # implausible jumps in a row, not back near 0: taken as a new baseline all the same
Gain = Annotated[int, Meta(ge=0, le=32767)]  # a PID gain of the firmware (a C int)


class DriverConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """[driver]: the motor board's serial port, its firmware's rates, the link's timeouts."""

    port: str = "/dev/ttyACM0"  # serial device of the board (/dev/serial/by-id/... survives re-plugging)
    baud: Annotated[int, Meta(ge=300, le=4_000_000)] = p.BAUD  # [baud] the firmware's BAUDRATE
    pid_rate: Annotated[float, Meta(gt=0.0, le=1000.0)] = p.PID_RATE  # [Hz] the firmware's PID_RATE
    sensor_rate: Annotated[float, Meta(gt=0.0, le=1000.0)] = 100.0  # [Hz] encoder reads (`e`) per second, at most
    reply_timeout: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.1  # [s] a reply not complete by then is missed
    max_missed: Annotated[int, Meta(ge=1, le=1000)] = 5  # replies missed in a row before the port is reopened
    open_delay: Annotated[float, Meta(ge=0.0, le=30.0)] = 2.0  # [s] after opening, before the first command (the board resets)
    reconnect_period: Annotated[float, Meta(gt=0.0, le=60.0)] = 1.0  # [s] between attempts to reopen a lost port
    command_timeout: Annotated[float, Meta(gt=0.0, le=1.5)] = 0.5  # [s] no motors/wheels this long: `m 0 0`
    resend_period: Annotated[float, Meta(gt=0.0, le=1.5)] = 0.5  # [s] a standing command is sent again this often
    reset_on_connect: bool = True  # send `r` (counts to 0) on every connect
    # [Kp, Kd, Ki, Ko] sent with `u` on connect; empty: the firmware's own
    pid_gains: Annotated[list[Gain], Meta(max_length=4)] = []

    def __post_init__(self) -> None:
        extras.check("serial", "the driver (the motor board's serial link)")  # at start, in one line
        if self.pid_gains and (len(self.pid_gains) != 4 or self.pid_gains[3] == 0):
            raise ValueError("pid_gains is [Kp, Kd, Ki, Ko] with Ko > 0, or empty")


class Driver(Service):
    """A ROSArduinoBridge board on a serial port: encoder counts out, wheel speed commands in."""

    name = "driver"
    config_type = DriverConfig
    blocking = True  # every poll and command waits on the serial link
    cfg: DriverConfig

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        super().__init__(settings, bus, clock)
        c, robot = self.cfg, settings.robot
        self.ticks_per_rev = robot.ticks_per_rev or 1  # set by Settings.load
        # [ticks/frame] the fastest target sent: [robot] max_wheel_speed, rounded up
        self.limit = max(1, math.ceil(robot.max_wheel_speed / p.wheel_speed(1, self.ticks_per_rev, c.pid_rate)))
        self.poll_period = 1.0 / c.sensor_rate  # read by @timer
        self.board = Board(c.port, c.baud, c.reply_timeout)
        self.ready_at: float | None = None  # [s] clock time the opened board takes commands; None: not open
        self.synced = False  # the connect handshake is done
        self.next_open = 0.0  # [s] clock time of the next attempt to open
        self.missed = 0  # replies missed in a row
        self.target = STOP  # [ticks/frame] (left, right) the board should run
        self.sent: tuple[int, int] | None = None  # the last target the board acknowledged; None: unknown
        self.sent_t = 0.0  # [s] clock time of that
        self.cmd_t = 0.0  # [s] clock time of the last motors/wheels
        self.board_prev = (0, 0)  # [ticks] the board's counts at the last read
        self.read_t = 0.0  # [s] clock time of that read
        self.jumps = 0  # implausible jumps in a row
        self.out = (0, 0)  # [ticks] the counts published last (continuous across reconnects)
        self.was_lost = False  # the link was up once and went down: the next handshake is a reconnect
        counters = ("reconnects", "disconnects", "bad_replies", "timeouts", "garbage_bytes", "watchdog_stops", "resends", "board_resets")
        for name in counters:
            self.count(name, 0)
        self.status, self.status_message = "error", f"disconnected: {c.port} not opened yet"

    @classmethod
    def make_clock(cls, settings: Settings) -> Clock:
        """Real hardware: the host's clock, whatever the deployment's."""
        return WallClock(future=settings.limits.future_stamp)

    def on_start(self) -> None:
        self._try_open(self.clock.now())

    # ------------------------------------------------------------ inputs
    # The newest only: a board behind a slow serial link must not run commands late, one after another.
    @subscribe("motors/wheels", latest=True)
    def on_wheels(self, msg: m.Wheels) -> None:
        """A wheel speed command [rad/s]: sent at once when it changes the board's target (with the next read if one is due)."""
        rate = self.cfg.pid_rate
        self.target = (
            p.ticks_per_frame(msg.left, self.ticks_per_rev, rate, self.limit),
            p.ticks_per_frame(msg.right, self.ticks_per_rev, rate, self.limit),
        )
        self.cmd_t = self.clock.now()
        # A read that is due goes first: the poll sends the target, then reads. On a link slower
        # than the commands come (a Bluetooth serial module), sending each at once would leave
        # no time for the counts.
        if self.synced and self.target != self.sent and self.cmd_t - self.read_t < self.poll_period:
            self._link(self._send, self.cmd_t)

    @on_liveliness("motor")
    def motor_presence(self, alive: bool) -> None:
        """The motor service's process is gone (its token went with it): stop now, not at the watchdog."""
        if alive or self.target == STOP:
            return
        self.target = STOP
        self.count("motor_lost_stops")
        self.warn("motor_lost", "motor service gone: board stopped")
        if self.synced:
            self._link(self._send, self.clock.now())

    @timer("poll_period")
    def poll(self, now: float) -> None:
        """Keep the link: open it, handshake, watchdog, resend, then read and publish the counts."""
        if self.ready_at is None:
            if now >= self.next_open:
                self._try_open(now)
            return
        if now < self.ready_at:
            return
        if not self.synced:
            self._link(self._handshake, now)
            return
        if self.target != STOP and now - self.cmd_t > self.cfg.command_timeout:
            self.target = STOP
            self.count("watchdog_stops")
            self.warn("watchdog", f"no motors/wheels for {now - self.cmd_t:.2f} s: board stopped")
        if self.target != self.sent or (self.target != STOP and now - self.sent_t >= self.cfg.resend_period):
            if self.target == self.sent:
                self.count("resends")
            if not self._link(self._send, now):
                return
        self._link(self._read, now)

    def on_stop(self) -> None:
        if self.board.is_open and self.synced:
            self.target = STOP
            self._link(self._send, self.clock.now())
        self.board.close()

    # ------------------------------------------------------------ link steps
    def _send(self, now: float) -> None:
        self.board.speeds(*self.target)
        self.sent, self.sent_t = self.target, now

    def _read(self, now: float) -> None:
        t0 = self.clock.now()
        left, right = self.board.encoders()
        t = (t0 + self.clock.now()) / 2.0  # the board read its counts between the command and the reply
        dl, dr = p.wrap32(left - self.board_prev[0]), p.wrap32(right - self.board_prev[1])
        bound = JUMP_FACTOR * self.limit * self.cfg.pid_rate * (t - self.read_t) + JUMP_MARGIN  # [ticks]
        if max(abs(dl), abs(dr)) > bound:
            if max(abs(left), abs(right)) <= bound:  # back near 0: the board restarted (power, reset) on the same link
                dl, dr = left, right
            else:
                self.jumps += 1
                if self.jumps < JUMPS_TO_RESET:
                    raise p.BadReply(f"counts {left} {right} jumped by {dl}, {dr} ticks since the last read")
                dl = dr = 0
            self.count("board_resets")
            self.warn("board_reset", f"the board's counts jumped to {left} {right}: new baseline, the counts published go on")
        self.jumps = 0
        self.board_prev, self.read_t = (left, right), t
        self.out = (p.wrap32(self.out[0] + dl), p.wrap32(self.out[1] + dr))
        # The target the board ran while it counted: a commanded wheel whose count stays still is found by the odometry.
        run, rate, tpr = self.sent or STOP, self.cfg.pid_rate, self.ticks_per_rev
        cmd = (p.wheel_speed(run[0], tpr, rate), p.wheel_speed(run[1], tpr, rate))
        self.publish("sensors/encoders", m.Encoders(t=t, left=self.out[0], right=self.out[1], cmd_left=cmd[0], cmd_right=cmd[1]))

    def _handshake(self, now: float) -> None:
        """A fresh link: clear the board's parser, check it answers, reset, take the counts' baseline."""
        self.board.resync()
        baud = self.board.get_baud()
        if baud != self.cfg.baud:
            self.warn("baud", f"the board says it runs at {baud} baud; [driver] baud is {self.cfg.baud}")
        self.board.speeds(*STOP)
        self.sent, self.sent_t = STOP, now
        if self.cfg.pid_gains:
            self.board.set_pid(*self.cfg.pid_gains)
        if self.cfg.reset_on_connect:
            self.board.reset()
        self.board_prev, self.read_t, self.jumps = self.board.encoders(), self.clock.now(), 0
        self.synced = True
        if self.was_lost:
            self.count("reconnects")
        self.log.info("board on %s ready (%d baud, counts %d %d)", self.cfg.port, baud, *self.board_prev)

    def _link(self, step: Callable[[float], None], now: float) -> bool:
        """Run one exchange; count and recover from what goes wrong. True if it went through."""
        try:
            step(now)
        except NoReply as e:
            self.count("timeouts")
            self._trouble(now, f"{self.cfg.port}: {e}")
            return False
        except p.BadReply as e:
            self.count("bad_replies")
            self._trouble(now, f"{self.cfg.port}: bad reply: {e}")
            return False
        except LinkLost as e:
            self._lost(now, str(e))
            return False
        finally:
            self._count_garbage()
        self.missed = 0
        if self.status != "ok" and self.synced:
            self.set_status("ok")
        return True

    def _trouble(self, now: float, why: str) -> None:
        """A missed or bad reply: resync; too many in a row and the port is reopened."""
        self.missed += 1
        self.warn("link", why)
        if self.missed >= self.cfg.max_missed:
            self.board.close()
            self._lost(now, f"{why} ({self.missed} in a row)")
            return
        self.set_status("degraded" if self.synced else "error", why)
        try:
            self.board.resync()
        except LinkLost as e:
            self._lost(now, str(e))

    def _lost(self, now: float, why: str) -> None:
        if self.synced:
            self.count("disconnects")
            self.was_lost = True
        self.board.close()
        self.ready_at, self.synced, self.sent, self.missed = None, False, None, 0
        self.next_open = now + self.cfg.reconnect_period
        self.set_status("error", f"disconnected: {why}")
        self.publish(f"diag/{self.name}", self.diag(now))  # now, not at the next diag: a running goal aborts on it

    def _try_open(self, now: float) -> None:
        try:
            self.board.open()
        except LinkLost as e:
            self.next_open = now + self.cfg.reconnect_period
            self.set_status("error", f"disconnected: {e}")
            return
        self.ready_at = now + self.cfg.open_delay
        self.log.info("opened %s at %d baud", self.cfg.port, self.cfg.baud)

    def _count_garbage(self) -> None:
        if self.board.garbage:
            self.count("garbage_bytes", self.board.garbage)
            self.board.garbage = 0
