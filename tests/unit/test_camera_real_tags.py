"""Both tag detectors on real photos (tests/data/real-tags): at the settings zenav picks, each finds at least 90 %
of the reference tags (the AprilTag 3 library's), every corner within 2 px."""

import cv2
import numpy as np
import pytest

from tests.support import realtags
from zenav.services.vps import detect

SHARE = 0.9  # of the reference tags each detector must find


def test_the_reference_corners_parse():
    ref = realtags.parse("0, (7.5 367.5), (8.5 387.0), (21.5 388.5), (22.5 369.5)\n\n12, (1 2), (3 4), (5 6), (7 8)\n")
    assert [i for i, _ in ref] == [0, 12]
    assert ref[0][1].tolist() == [[8.0, 386.5], [7.0, 367.0], [22.0, 369.0], [21.0, 388.0]]  # zenav's order, centres at 0
    with pytest.raises(ValueError, match="line 2 is not"):
        realtags.parse("0, (1 2), (3 4), (5 6), (7 8)\n0, (1 2), (3 4), (5 6)\n")
    with pytest.raises(ValueError, match="line 1"):
        realtags.parse("x, (1 2), (3 4), (5 6), (7 8)\n")


def test_the_photos_come_with_their_licence_and_references():
    assert [p.name for p in realtags.PHOTOS] == ["34085369442_304b6bafd9_c.jpg", "34139872896_defdb2f8d9_c.jpg"]
    assert "CC BY-SA 2.0" in (realtags.DATA / "README.md").read_text()
    assert [len(realtags.reference(p.with_suffix(".txt"))) for p in realtags.PHOTOS] == [25, 10]


@pytest.fixture(scope="module", params=realtags.PHOTOS, ids=lambda p: p.stem)
def photo(request):
    return cv2.imread(str(request.param), cv2.IMREAD_GRAYSCALE), realtags.reference(request.param.with_suffix(".txt"))


@pytest.mark.parametrize("backend", ["apriltag", "opencv"])
@pytest.mark.parametrize("sized", [True, False], ids=["tag-px", "any-size"])
def test_each_detector_finds_nine_in_ten_reference_tags(photo, backend, sized):
    """Sized: told the smallest tag's edge (as --tag-px or [camera] would); else any size (`zenav camera detect`'s default)."""
    img, ref = photo
    tag_px = np.floor(realtags.smallest_edge(ref)) if sized else 0.0
    tags = detect.make(backend, tag_px).detect(img)
    assert realtags.matched(ref, tags) >= SHARE * len(ref)


def test_the_size_picks_the_settings():
    """Tags of 24 px and more are looked for on the frame halved; the AprilTag library reads tags under 16 px enlarged."""
    assert [detect.decimation(px) for px in (0.0, 23.0, 24.0, 40.0)] == [1.0, 1.0, 2.0, 2.0]
    assert [detect.enlargement(px) for px in (0.0, 15.0, 16.0, 40.0)] == [1.5, 1.5, 1.0, 1.0]


def test_a_frame_halved_misses_the_small_real_tags():
    """Why the size matters: told the tags are large (24 px), both detectors miss most of the first photo's 10 to 20 px ones."""
    first = realtags.PHOTOS[0]
    img, ref = cv2.imread(str(first), cv2.IMREAD_GRAYSCALE), realtags.reference(first.with_suffix(".txt"))
    assert realtags.smallest_edge(ref) < 12.0
    for backend in ("apriltag", "opencv"):
        assert realtags.matched(ref, detect.make(backend, 24.0).detect(img)) < len(ref) / 2
