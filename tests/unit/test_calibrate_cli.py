"""`zenav calibrate` without a robot: end errors measured before, the [robot] section written."""

import pytest

from zenav.cli import calibrate
from zenav.cli.main import main
from zenav.services.driver import umbmark as u

NOMINAL_TRACK = 0.1156


def test_set_keys_replaces_adds_and_keeps_the_rest():
    text = (
        '# mine\n[deployment]\nclock = "wall"\n\n[robot]\ntrack_width = 0.1156  # old\nwheel_diameter = 0.07\n\n[driver]\nport = "/dev/x"\n'
    )
    out = calibrate.set_keys(text, "robot", {"track_width": 0.12139})
    assert "track_width = 0.12139\n" in out and "0.1156" not in out
    assert out.replace("track_width = 0.12139", "track_width = 0.1156  # old") == text
    added = calibrate.set_keys('[robot]\nwheel_diameter = 0.07\n\n[driver]\nport = "/dev/x"\n', "robot", {"track_width": 0.1})
    assert added == '[robot]\nwheel_diameter = 0.07\ntrack_width = 0.1\n\n[driver]\nport = "/dev/x"\n'
    assert calibrate.set_keys("", "robot", {"track_width": 0.1}) == "\n[robot]\ntrack_width = 0.1\n"


def test_start_frame():
    assert calibrate.start_frame((1.0, 2.0, 1.5707963267948966), (1.0, 3.0, 0.0)) == pytest.approx((1.0, 0.0))


def test_errors_given_are_fitted_and_written(tmp_path, capsys):
    cw, ccw = (u.end_error(u.square(1.0, c, NOMINAL_TRACK), 1.04, 1.0, NOMINAL_TRACK) for c in (True, False))
    config = tmp_path / "robot.toml"
    config.write_text('[deployment]\nclock = "wall"\n\n[robot]\ntrack_width = 0.1156\n')
    code = main(["calibrate", "--config", str(config), f"--cw={cw[0]},{cw[1]}", f"--ccw={ccw[0]},{ccw[1]}"])
    assert code == 0
    assert "track_width = 0.12022" in config.read_text()
    assert "x1.0400" in capsys.readouterr().out


def test_one_direction_alone_is_a_usage_error(capsys):
    assert main(["calibrate", "--cw=0.1,0.0"]) == 2
    assert "--ccw" in capsys.readouterr().err
