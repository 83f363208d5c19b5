"""Bounded logs: rotation by size keeping N files, long lines cut with a note, a pipe pumped by a thread."""

from __future__ import annotations

import os

from zenav.stack.logs import RotatingLog, cut_note, pump, start_pump


def lines_of(path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


def test_a_log_rotates_by_size_and_keeps_its_newest_files(tmp_path):
    path = tmp_path / "motor.log"
    log = RotatingLog(path, max_bytes=100, files=3)
    for i in range(40):
        log.write(f"line {i:03d} ".encode() + b"x" * 10)  # 19 bytes with the newline: 5 lines a file
    log.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["motor.log", "motor.log.1", "motor.log.2"]
    assert all(p.stat().st_size <= 100 for p in tmp_path.iterdir())
    kept = [ln.split()[1] for p in ("motor.log.2", "motor.log.1", "motor.log") for ln in lines_of(tmp_path / p)]
    assert kept == [f"{i:03d}" for i in range(25, 40)]  # the newest 15 lines, in order
    assert log.last.startswith("line 039")
    log.write(b"after close")  # dropped, not raised
    assert "after close" not in path.read_text()


def test_a_log_keeps_appending_to_an_existing_file(tmp_path):
    path = tmp_path / "sim.log"
    path.write_bytes(b"before\n")
    log = RotatingLog(path)
    log.write(b"after\r\n")
    log.close()
    assert lines_of(path) == ["before", "after"]


def test_a_long_line_is_cut_with_a_note_of_the_rest(tmp_path):
    log = RotatingLog(tmp_path / "nav.log", line_max=50)
    log.write(b"y" * 80)
    log.write(b"z" * 10, cut=5)  # the reader already dropped 5 bytes of it
    log.close()
    assert lines_of(tmp_path / "nav.log") == ["y" * 50 + cut_note(30).decode(), "z" * 10 + cut_note(5).decode()]
    assert cut_note(30) == b"... (30 more bytes cut)"


def test_the_pump_cuts_a_430_kb_line_without_holding_it_and_keeps_the_next_lines(tmp_path):
    log = RotatingLog(tmp_path / "navigator.log")  # 2000 bytes a line
    r, w = os.pipe()
    with os.fdopen(r, "rb") as reader, os.fdopen(w, "wb") as writer:
        thread = start_pump(reader, log, "navigator")
        writer.write(b"start\n" + b"g" * 430_000 + b"\nend\n")
        writer.close()  # end of file: the pump returns
        thread.join(20)
        assert not thread.is_alive()
    log.close()
    start, big, end = lines_of(tmp_path / "navigator.log")
    assert (start, end) == ("start", "end")
    assert big == "g" * 2000 + "... (428000 more bytes cut)"


def test_the_pump_writes_a_last_line_without_a_newline(tmp_path):
    log = RotatingLog(tmp_path / "vps.log")
    r, w = os.pipe()
    os.write(w, b"one\ntwo")
    os.close(w)
    with os.fdopen(r, "rb") as reader:
        pump(reader, log)
    log.close()
    assert lines_of(tmp_path / "vps.log") == ["one", "two"]
    assert log.last == "two"
