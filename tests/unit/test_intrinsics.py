"""`zenav camera intrinsics`: a lens calibrated from views of a chessboard, written into a config's camera section."""

import math

import numpy as np
import pytest

from zenav.common.config import Settings
from zenav.common.onboardcam import OnboardCamera

cv2 = pytest.importorskip("cv2")
from zenav.tools.intrinsics import Board, IntrinsicsError, calibrate, write_section  # noqa: E402

K = np.array([[510.0, 0.0, 322.0], [0.0, 505.0, 236.0], [0.0, 0.0, 1.0]])
SQUARE_PX = 40  # [px] a square in the board's texture
COLS, ROWS, SQUARE = 9, 6, 0.03  # inner corners, [m]


def chessboard() -> tuple[np.ndarray, float]:
    """The chessboard's texture, and the board coordinate [m] of its top-left pixel's edge (first inner corner at 0)."""
    squares = (COLS + 1, ROWS + 1)
    texture = np.kron((np.indices(squares[::-1]).sum(axis=0) % 2) * 200 + 30, np.ones((SQUARE_PX, SQUARE_PX)))
    return np.pad(texture, SQUARE_PX, constant_values=230).astype(np.uint8), -2 * SQUARE


def charuco() -> tuple[np.ndarray, float]:
    """A 7 x 5 ChArUco board (0.03 m squares, 0.022 m markers) with a white margin, as chessboard() gives it."""
    board = Board("charuco", 7, 5, SQUARE, 0.022).charuco()
    inner = board.generateImage((7 * SQUARE_PX, 5 * SQUARE_PX), marginSize=0)
    return np.pad(inner, SQUARE_PX, constant_values=255), -SQUARE


def view(rx: float, ry: float, distance: float, shift=(0.0, 0.0), board=chessboard) -> np.ndarray:
    """A 640 x 480 grey picture of the board, turned rx, ry [rad] about its centre, `distance` [m] off."""
    texture, origin = board()
    r, _ = cv2.Rodrigues(np.array([rx, ry, 0.0]))
    m_per_px = SQUARE / SQUARE_PX
    centre = np.array([origin + texture.shape[1] / 2 * m_per_px, origin + texture.shape[0] / 2 * m_per_px, 0.0])
    t = np.array([shift[0], shift[1], distance]) - r @ centre
    to_board = np.array([[m_per_px, 0.0, origin], [0.0, m_per_px, origin], [0.0, 0.0, 1.0]])  # texture px -> board [m]
    hom = K @ np.column_stack([r[:, 0], r[:, 1], t]) @ to_board
    return cv2.warpPerspective(texture, hom, (640, 480), flags=cv2.INTER_AREA, borderValue=128)


VIEWS = [
    view(0.0, 0.0, 0.5),
    view(0.4, 0.0, 0.55),
    view(-0.4, 0.1, 0.5),
    view(0.0, 0.45, 0.6, (0.05, 0.0)),
    view(0.1, -0.45, 0.6, (-0.05, 0.02)),
    view(0.3, 0.3, 0.5, (0.0, -0.03)),
    view(-0.3, -0.3, 0.65),
]


def test_a_chessboard_seen_from_several_sides_gives_the_lens_back():
    got = calibrate(VIEWS, Board("chessboard", COLS, ROWS, SQUARE))
    assert got.views == len(VIEWS) and (got.width, got.height) == (640, 480)
    assert got.fx == pytest.approx(510.0, rel=0.01) and got.fy == pytest.approx(505.0, rel=0.01)
    assert got.cx == pytest.approx(322.0, abs=3.0) and got.cy == pytest.approx(236.0, abs=3.0)
    assert abs(got.k1) < 0.05 and got.rms < 0.5


def test_a_charuco_board_gives_the_lens_back_too():
    poses = [(0.0, 0.0, 0.45), (0.4, 0.0, 0.5), (-0.4, 0.1, 0.45), (0.0, 0.45, 0.5), (0.1, -0.45, 0.5), (0.3, 0.3, 0.45)]
    views = [view(*p, board=charuco) for p in poses]
    got = calibrate(views, Board("charuco", 7, 5, SQUARE, 0.022))
    assert got.views == len(poses) and got.fx == pytest.approx(510.0, rel=0.02) and got.rms < 0.5


def test_too_few_views_of_the_board_are_refused_saying_so():
    blank = np.full((480, 640), 128, np.uint8)
    with pytest.raises(IntrinsicsError, match="found in 2 views; a calibration needs 5"):
        calibrate([VIEWS[0], blank, VIEWS[1], blank], Board("chessboard", COLS, ROWS, SQUARE))


def test_the_intrinsics_are_written_into_the_section_keeping_the_rest(tmp_path):
    got = calibrate(VIEWS, Board("chessboard", COLS, ROWS, SQUARE))
    text = "# my robot\n[robot]\nradius = 0.12\n\n[onboard_camera]\n# measured on the robot\nz = 0.31\nfx = 400.0\n"
    path = tmp_path / "zenav.toml"
    path.write_text(write_section(text, "onboard_camera", got.values()))
    cam = Settings.load(str(path)).section("onboard_camera", OnboardCamera)
    assert (cam.fx, cam.cy, cam.z) == (pytest.approx(got.fx), pytest.approx(got.cy), 0.31)
    assert "# measured on the robot" in path.read_text() and Settings.load(str(path)).robot.radius == 0.12
    fresh = write_section("", "camera", {"fx": 1.5, "width": 320})
    assert fresh.strip() == "[camera]\nfx = 1.5\nwidth = 320"


def test_the_command_calibrates_pictures_and_writes_the_config(tmp_path, capsys):
    from zenav.cli.main import main

    for i, img in enumerate(VIEWS):
        cv2.imwrite(str(tmp_path / f"view{i}.png"), img)
    config = tmp_path / "zenav.toml"
    argv = ["camera", "intrinsics", str(tmp_path / "view*.png"), "--cols", "9", "--rows", "6", "--square", "0.03"]
    assert main([*argv, "--write", str(config)]) == 0
    assert f"{len(VIEWS)} views of the board" in capsys.readouterr().out
    cam = Settings.load(str(config)).section("onboard_camera", OnboardCamera)
    assert math.isclose(cam.fx, 510.0, rel_tol=0.01)
