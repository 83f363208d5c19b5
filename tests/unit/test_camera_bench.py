"""The camera bench's measurements, on a few frames."""

import pytest

from zenav.bench import camera as bench
from zenav.common.config import Camera


@pytest.fixture(scope="module")
def pipeline() -> bench.Pipeline:
    return bench.Pipeline(Camera())


def test_two_robots_are_told_apart(pipeline):
    frames, both, wrong = bench.two_robots(pipeline, 4)
    assert (frames, both, wrong) == (4, 4, 0)


def test_every_stage_is_timed(pipeline):
    times = bench.timing(pipeline, 3)
    assert set(times) == set(bench.STAGES)
    assert all(0.0 < t.wall[0] <= t.wall[1] for t in times.values())


def test_accuracy_on_one_position(pipeline):
    acc = bench.accuracy(pipeline, xs=[0.5], ys=[0.5])
    assert acc.frames == acc.found == len(bench.HEADINGS) * len(bench.MOTIONS)
    assert acc.pos_mm[1] < 2.0 and acc.head_deg[1] < 0.5
