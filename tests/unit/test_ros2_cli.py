"""`zenav ros2`: arguments checked before connecting, a missing router, a missing extra."""

import subprocess
import sys

import pytest

from zenav.cli.main import EXIT_UNAVAILABLE, EXIT_USAGE, main
from zenav.stack.inprocess import free_port


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--node", "1bridge"], "not a ROS node name"),
        (["--namespace", "r1//a"], "not a ROS namespace"),
        (["--domain", "300"], "0..232"),
        (["--robot", "no robot!"], "robot"),
    ],
)
def test_bad_arguments_exit_2(argv, words, capsys):
    assert main(["ros2", *argv, "--connect", f"tcp/127.0.0.1:{free_port()}"]) == EXIT_USAGE
    assert words in capsys.readouterr().err


def test_no_router_exits_3(capsys):
    assert main(["ros2", "--connect", f"tcp/127.0.0.1:{free_port()}"]) == EXIT_UNAVAILABLE
    assert "no Zenoh router" in capsys.readouterr().err


def test_without_the_extra_it_says_which():
    code = "import sys; sys.modules['rosbags'] = None; from zenav.cli.main import main; sys.exit(main(['ros2']))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == EXIT_USAGE and "zenav[ros2]" in done.stderr and "Traceback" not in done.stderr


def test_image_without_opencv_names_the_camera_extra():
    code = "import sys; sys.modules['cv2'] = None; from zenav.cli.main import main; sys.exit(main(['ros2', '--image']))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == EXIT_USAGE and "Traceback" not in done.stderr
    assert done.stderr.strip() == "zenav ros2: --image needs OpenCV: pip install 'zenav[camera]'"


def test_distro_from_the_environment(monkeypatch, capsys):
    monkeypatch.setenv("ROS_DISTRO", "foxy")
    assert main(["ros2", "--connect", f"tcp/127.0.0.1:{free_port()}"]) == EXIT_USAGE
    assert "ROS_DISTRO) 'foxy': expected one of humble, jazzy, kilted" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "words"),
    [(["--all"], "leave out --all"), (["--distro", "iron"], "expected one of humble, jazzy, kilted")],
)
def test_record_ros2_bad_arguments_exit_2(argv, words, tmp_path, capsys):
    assert main(["record", str(tmp_path / "bag"), "--ros2", *argv, "--connect", f"tcp/127.0.0.1:{free_port()}"]) == EXIT_USAGE
    assert words in capsys.readouterr().err


def test_record_ros2_refuses_an_existing_directory(tmp_path, capsys):
    assert main(["record", str(tmp_path), "--ros2", "--connect", f"tcp/127.0.0.1:{free_port()}"]) == EXIT_USAGE
    assert "a new directory" in capsys.readouterr().err
