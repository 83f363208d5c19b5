"""`zenav teleop`: keys read from a terminal, the command they give, the dead-man timeout, and no TTY."""

import pytest

from tests.support.navigator import World
from zenav.cli import teleop
from zenav.cli.keymap import Drive, command, press, split_keys
from zenav.cli.main import EXIT_USAGE, build_parser
from zenav.common.client import Client


@pytest.mark.parametrize(
    "data, keys",
    [
        (b"\x1b[A\x1b[B\x1b[C\x1b[D", ["up", "down", "right", "left"]),
        (b"\x1bOA\x1bOD", ["up", "left"]),  # application cursor mode
        (b"wasdWASD", ["up", "left", "down", "right"] * 2),
        (b" q\x04", ["stop", "quit", "quit"]),
        (b"x\x1b[5~w", ["up"]),  # an unknown key and PageUp's sequence are skipped whole
        (b"\x1b[1;5Aw", ["up"]),  # Ctrl-Up: a sequence with parameters
        (b"\x1b[", []),  # a cut sequence
        (b"", []),
    ],
)
def test_split_keys(data, keys):
    assert split_keys(data) == keys


DRIVE = Drive(speed=0.2, turn=1.0, deadman=0.5)


def test_keys_drive_and_space_stops():
    d = press(DRIVE, "up", 10.0)
    assert command(d, 10.0) == (0.2, 0.0)
    assert command(press(d, "down", 10.1), 10.1) == (-0.2, 0.0)
    assert command(press(d, "left", 10.1), 10.1) == (0.0, 1.0)
    assert command(press(d, "right", 10.1), 10.1) == (0.0, -1.0)
    assert command(press(d, "stop", 10.1), 10.1) == (0.0, 0.0)
    assert press(d, "quit", 10.2) == d  # not a driving key: nothing changes


def test_deadman_zeroes_the_command_when_no_key_comes():
    d = press(DRIVE, "up", 10.0)
    assert command(d, 10.5) == (0.2, 0.0)  # within the dead-man time
    assert command(d, 10.51) == (0.0, 0.0)
    d = press(d, "up", 10.4)  # a repeat keeps it alive
    assert command(d, 10.8) == (0.2, 0.0)
    assert command(DRIVE, 0.0) == (0.0, 0.0)  # no key yet


def test_teleop_needs_a_terminal(capsys):
    args = build_parser().parse_args(["teleop", "--connect", "tcp/127.0.0.1:1"])  # pytest's stdin is no TTY
    assert teleop.run(args) == EXIT_USAGE
    err = capsys.readouterr().err
    assert err == "zenav teleop: needs a terminal (stdin and stdout must be a TTY)\n"


def test_teleop_options():
    args = build_parser().parse_args(["teleop", "--speed", "0.3", "--turn", "2", "--deadman", "250"])
    assert (args.speed, args.turn, args.deadman) == (0.3, 2.0, 250.0)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["teleop", "--deadman", "0"])


def test_a_key_that_drives_stops_the_running_goal_once():
    world = World()
    world.pose()
    client = Client("r1", bus=world)
    override = teleop.Override(client)
    assert override.take() is None  # no nav/state yet: nothing to stop
    client.query("nav/move_straight", {"speed": 0.2})
    world.step(3)
    assert world.nav.machine.state == "MOVING_STRAIGHT"
    assert override.take() == 1 and world.nav.machine.state == "STOPPED" and world.sent[-1][0] == "nav/stop"
    world.step(3)
    assert override.take() is None and len(world.sent) == 2  # stopped: nothing more to stop
    client.query("nav/turn_to_heading", {"heading": 1.0})
    world.step(3)
    assert override.take() == 2 and world.nav.machine.state == "STOPPED"
    client.close()
