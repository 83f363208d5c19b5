"""The ROSArduinoBridge protocol: every command's bytes, every reply's parse, the speed conversion."""

import math

import pytest

from zenav.services.driver import protocol as p


def test_commands_are_a_letter_then_integers_ended_by_cr():
    assert p.read_encoders() == b"e\r"
    assert p.motor_speeds(10, -3) == b"m 10 -3\r"
    assert p.motor_speeds(0, 0) == b"m 0 0\r"
    assert p.raw_pwm(-255, 255) == b"o -255 255\r"
    assert p.reset_encoders() == b"r\r"
    assert p.get_baud() == b"b\r"
    assert p.update_pid(20, 12, 0, 50) == b"u 20:12:0:50\r"
    assert p.command("x", 3, 7) == b"x 3 7\r"


@pytest.mark.parametrize("letter", ["", "mm", "1", " "])
def test_a_command_is_one_letter(letter):
    with pytest.raises(ValueError):
        p.command(letter)


def test_raw_pwm_is_bounded():
    with pytest.raises(ValueError, match="255"):
        p.raw_pwm(256, 0)


@pytest.mark.parametrize(
    "line, counts",
    [("0 0", (0, 0)), ("123 -45\r\n", (123, -45)), (b"2147483647 -2147483648\r\n", (2**31 - 1, -(2**31)))],
)
def test_encoder_replies(line, counts):
    assert p.parse_encoders(line) == counts


@pytest.mark.parametrize(
    "line, words",
    [
        ("Invalid Command", "USE_BASE"),
        ("12", "left right"),
        ("1 2 3", "left right"),
        ("12  4", "left right"),
        ("1x 2", "integer"),
        ("--1 2", "integer"),
        ("\u0661 2", "integer"),
        ("OK", "left right"),
        ("2147483648 0", "32-bit"),
        (b"\xff\x00 12", "integer"),
        ("", "left right"),
    ],
)
def test_malformed_encoder_replies_are_bad_replies(line, words):
    with pytest.raises(p.BadReply, match=words):
        p.parse_encoders(line)


def test_ok_and_integer_replies():
    p.parse_ok("OK\r\n")
    assert p.parse_int("57600\r\n") == 57600
    for bad in ("Invalid Command", "ok", "OK OK", "0 0"):
        with pytest.raises(p.BadReply):
            p.parse_ok(bad)
    for bad in ("Invalid Command", "576OO", ""):
        with pytest.raises(p.BadReply):
            p.parse_int(bad)


def test_wrap32():
    assert p.wrap32(2**31) == -(2**31)
    assert p.wrap32(-(2**31) - 1) == 2**31 - 1
    assert p.wrap32(5) == 5


def test_wheel_speed_to_ticks_per_frame_rounds_and_clamps():
    # 360 ticks/rev at 30 Hz: one tick per frame is 2 pi 30 / 360 = 0.524 rad/s
    assert p.ticks_per_frame(10.0, 360, 30.0, 100) == 19  # 19.099
    assert p.ticks_per_frame(-5.0, 360, 30.0, 100) == -10  # -9.549
    assert p.ticks_per_frame(0.2, 360, 30.0, 100) == 0
    assert p.ticks_per_frame(1e3, 360, 30.0, 20) == 20
    assert p.ticks_per_frame(-1e3, 360, 30.0, 20) == -20
    assert p.wheel_speed(1, 360, 30.0) == pytest.approx(math.pi / 6.0)
    assert p.ticks_per_frame(p.wheel_speed(37, 3436, 30.0), 3436, 30.0, 1000) == 37


def test_lines_split_replies_and_skip_the_empty_ones():
    lines = p.Lines()
    assert lines.feed(b"12 3") == []
    assert lines.feed(b"4\r\n\n") == ["12 34"]  # the firmware's extra LF after the counts
    assert lines.feed(b"OK\r\nInvalid Command\r\n") == ["OK", "Invalid Command"]
    assert lines.feed(b"x" * (p.MAX_LINE + 1)) == [] and lines.dropped == p.MAX_LINE + 1
    lines.feed(b"half")
    lines.clear()
    assert lines.dropped == p.MAX_LINE + 5 and lines.feed(b"OK\r\n") == ["OK"]
