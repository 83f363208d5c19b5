"""Reading recordings whose recorder died: up to the last complete chunk; damage and non-MCAP files refused."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.writer import Writer

from zenav.common import keys
from zenav.common import messages as m
from zenav.tools import mcap_format as fmt

KEY = keys.key("r1", "clock")


def write(path: Path, chunks: list[int], finish: bool) -> list[int]:
    """Clock messages in chunks of the given sizes (one flush each); the file size after each chunk."""
    with open(path, "wb") as f:
        return _write(Writer(f), path, chunks, finish)


def _write(w: Writer, path: Path, chunks: list[int], finish: bool) -> list[int]:
    w.start()
    schema = w.register_schema(fmt.schema_name(m.Clock), fmt.SCHEMA_ENCODING, fmt.schema_bytes(m.Clock))
    channel = w.register_channel(fmt.topic_of(KEY), fmt.MESSAGE_ENCODING, schema)
    sizes, t = [], 0
    for n in chunks:
        for _ in range(n):
            w.add_message(channel, log_time=t, data=fmt.to_json(m.Clock(t=t * 0.01)), publish_time=t)
            t += 1
        w.flush()
        sizes.append(path.stat().st_size)
    if finish:
        w.finish()
    return sizes


def test_an_unfinished_file_reads_up_to_its_last_complete_chunk(tmp_path):
    full = tmp_path / "run.mcap.part"
    sizes = write(full, [50, 40, 30], finish=False)
    data = full.read_bytes()
    assert not fmt.finished(str(full))
    assert [r.msg.t for r in fmt.read(str(full))] == [i * 0.01 for i in range(120)]
    torn = tmp_path / "torn.mcap.part"
    torn.write_bytes(data[: sizes[1] + 20])  # died while writing the third chunk
    assert [r.msg.t for r in fmt.read(str(torn))] == [i * 0.01 for i in range(90)]
    assert fmt.robots(str(torn)) == ["r1"]
    header_only = tmp_path / "empty.mcap.part"
    header_only.write_bytes(data[:40])
    assert list(fmt.read(str(header_only))) == [] and fmt.robots(str(header_only)) == []


def test_a_finished_file_is_read_whole_and_damage_is_reported(tmp_path):
    path = tmp_path / "run.mcap"
    sizes = write(path, [50, 40], finish=True)
    assert fmt.finished(str(path))
    assert len(list(fmt.read(str(path)))) == 90 and fmt.robots(str(path)) == ["r1"]
    data = bytearray(path.read_bytes())
    data[sizes[0] + 1 : sizes[0] + 9] = b"\xff" * 8  # the second chunk's length, garbage
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    assert fmt.finished(str(damaged))
    with pytest.raises(fmt.BadRecording, match="damaged"):
        list(fmt.read(str(damaged)))


def test_what_is_no_recording(tmp_path):
    text = tmp_path / "notes.mcap"
    text.write_text("not an mcap file\n")
    with pytest.raises(fmt.BadRecording, match="not an MCAP file"):
        fmt.finished(str(text))
    with pytest.raises(fmt.BadRecording, match="not an MCAP file"):
        list(fmt.read(str(text)))
    with pytest.raises(fmt.BadRecording, match="directory"):
        fmt.finished(str(tmp_path))


def test_an_unfinished_file_is_read_through_for_its_robots_once_while_it_stays_as_it_was(tmp_path, monkeypatch):
    part = tmp_path / "run.mcap.part"
    with open(part, "wb") as f:
        w = Writer(f)
        _write(w, part, [20], finish=False)
        reads = []
        messages = fmt._messages
        monkeypatch.setattr(fmt, "_messages", lambda path: reads.append(path) or messages(path))
        assert fmt.robots(str(part)) == ["r1"] and fmt.topics(str(part)) == {"r1": {"clock"}}  # a replay's check, then its clocks
        assert len(reads) == 1
        fmt.topics(str(part))["r1"].add("odom")  # the caller's own copy
        assert fmt.topics(str(part)) == {"r1": {"clock"}} and len(reads) == 1
        _write_more(w, part)  # the recorder goes on: read again
        assert fmt.topics(str(part)) == {"r1": {"clock", "odom"}} and len(reads) == 2


def _write_more(w: Writer, path: Path) -> None:
    """An odom message on a channel of its own, flushed."""
    schema = w.register_schema(fmt.schema_name(m.Odom), fmt.SCHEMA_ENCODING, fmt.schema_bytes(m.Odom))
    channel = w.register_channel(fmt.topic_of(keys.key("r1", "odom")), fmt.MESSAGE_ENCODING, schema)
    w.add_message(channel, log_time=1000, data=fmt.to_json(m.Odom(t=1.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)), publish_time=1000)
    w.flush()
