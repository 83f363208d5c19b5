"""The vps's windowed search at 1280x720 against the whole-frame search, on the same frames: no fix lost."""

from __future__ import annotations

import pytest

pytest.importorskip("cv2")

from zenav.bench import window  # noqa: E402
from zenav.services.vps import track  # noqa: E402


def test_the_windowed_search_loses_no_fix_of_the_whole_frame_search():
    cfg = window.camera_720p()
    frames = int(1.5 * track.FULL_PERIOD / window.FRAME_PERIOD)  # a periodic whole search among them
    got = window.compare(cfg, window.messages(cfg, frames))
    assert got.fixes == 2 * frames  # both robots in every frame
    assert got.lost == 0
    assert got.moved_mm < 1.0  # the same tags, read from a window
    assert 1 < got.whole < frames // 2  # most frames were read in windows
