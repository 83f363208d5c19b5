"""The driver on a slow serial link (bench/link.py): the emulated board on a real pty."""

from __future__ import annotations

from zenav.bench import link


def test_targets_differ_from_one_command_to_the_next_and_are_unique_over_722():
    targets = [link.target(i) for i in range(722)]
    assert len(set(targets)) == 722 and all(a != b for a, b in zip(targets, targets[1:]))
    assert all(1 <= left <= 19 and 1 <= abs(right) <= 19 for left, right in targets)  # within the driver's limit of 20


def test_a_link_slower_than_the_commands_runs_the_newest_and_keeps_reading():
    x = link.run(4800, 1.0)
    assert x.commands == 100 and x.superseded >= 1 and x.sent + x.superseded + x.queued <= x.commands
    # Sent in turn, the commands ran later and later (0.25 s late after 1 s) and the counts were read once a second.
    assert x.age_max < 0.1 and x.reads >= 5.0
    out = link.table([link.run(57600, 0.2)])
    assert out.splitlines()[0].startswith("| baud |") and out.splitlines()[2].startswith("| 57600 | 20 |")
