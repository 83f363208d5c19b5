"""Where the vps looks for the robots' tags: windows round their predicted places, the whole frame when due or lost."""

from __future__ import annotations

import numpy as np

from zenav.services.vps import track
from zenav.services.vps.detect import Tag


def tag(tag_id: int, x: float, y: float, side: float = 40.0) -> Tag:
    h = side / 2.0
    return Tag(tag_id, np.array([[x - h, y - h], [x + h, y - h], [x + h, y + h], [x - h, y + h]]), 80.0)


def test_the_first_frame_is_searched_whole_then_windows_follow_the_tags():
    tr = track.Tracker(1280, 720, 0.1)
    assert tr.windows(0.1, [0, 1]) is None
    tr.update(0.1, [tag(0, 300.0, 200.0), tag(1, 900.0, 500.0), tag(7, 50.0, 50.0)], [0, 1], full=True)
    windows = tr.windows(0.2, [0, 1])
    assert windows is not None and len(windows) == 2
    for (x0, y0, x1, y1), (x, y) in zip(windows, ((300.0, 200.0), (900.0, 500.0))):
        assert x0 < x - 20.0 and x + 20.0 < x1 and y0 < y - 20.0 and y + 20.0 < y1  # the tag fits
        assert (x1 - x0) * (y1 - y0) < 0.05 * 1280 * 720  # and the window is a small part of the frame


def test_a_window_moves_with_the_tag_and_widens_with_the_gap():
    tr = track.Tracker(1280, 720, 0.1)
    tr.update(0.1, [tag(0, 300.0, 200.0)], [0], full=True)
    tr.update(0.2, [tag(0, 320.0, 200.0)], [0], full=False)  # 200 px/s to the right
    (x0, _, x1, _) = tr.windows(0.3, [0])[0]  # type: ignore[index]
    assert abs((x0 + x1) / 2.0 - 340.0) <= 1.0
    near, far = tr.windows(0.3, [0])[0], tr.windows(0.5, [0])[0]  # type: ignore[index]
    assert far[2] - far[0] > near[2] - near[0]


def test_a_tag_missing_from_its_window_is_lost_and_the_whole_search_forgets_it():
    tr = track.Tracker(1280, 720, 0.1)
    tr.update(0.1, [tag(0, 300.0, 200.0), tag(1, 900.0, 500.0)], [0, 1], full=True)
    assert not tr.lost([tag(0, 301.0, 200.0), tag(1, 900.0, 500.0)], [0, 1])
    assert tr.lost([tag(0, 301.0, 200.0)], [0, 1])
    tr.update(0.2, [tag(0, 301.0, 200.0)], [0, 1], full=True)
    assert set(tr.seen) == {0}
    assert tr.windows(0.3, [0, 1]) is None  # a robot out of view is looked for in every frame
    assert tr.windows(0.3, [0]) is not None


def test_a_whole_search_is_due_every_period_and_when_time_goes_back():
    tr = track.Tracker(1280, 720, 0.1)
    tr.update(1.0, [tag(0, 300.0, 200.0)], [0], full=True)
    assert not tr.due(1.0 + track.FULL_PERIOD / 2.0)
    assert tr.due(1.0 + track.FULL_PERIOD)
    assert tr.due(0.5)
