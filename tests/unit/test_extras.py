"""The base install: no optional package is imported on its paths, and a feature whose package is missing says,
in one line, which extra installs it. Each check runs in a fresh Python where the optional packages cannot be imported."""

import subprocess
import sys
import textwrap

import cv2
import pytest

from zenav import services
from zenav.common import extras, roles
from zenav.common.config import ConfigError

OPTIONAL = tuple(extras.PACKAGES)  # cv2, pupil_apriltags, serial, mcap, foxglove, matplotlib, rosbags
TIMEOUT = 120  # [s] for one fresh interpreter
# The CLI's driving and introspection, the stack that `zenav up` runs, the robot library.
BASE_MODULES = (
    "zenav.aio",
    "zenav.cli.main",
    "zenav.cli.nav",
    "zenav.cli.status",
    "zenav.cli.introspect",
    "zenav.cli.teleop",
    "zenav.cli.up",
    "zenav.cli.router",
    "zenav.cli.watch",
    "zenav.stack.launcher",
    "zenav.stack.composed",
    "zenav.stack.inprocess",
    "zenav.services.vps.detect",
    "zenav.services.vps.frames",
)


def without_optional(code: str, *args: str, blocked: tuple[str, ...] = OPTIONAL) -> subprocess.CompletedProcess:
    """Run `code` in a fresh Python in which importing any `blocked` package fails as if it were not installed."""
    block = f"import sys\nfor name in {blocked!r}:\n    sys.modules[name] = None  # importing it raises ImportError\n"
    return subprocess.run(
        [sys.executable, "-c", block + textwrap.dedent(code), *args], capture_output=True, text=True, timeout=TIMEOUT, check=False
    )


def test_the_base_paths_import_no_optional_package():
    services_ = [r.target.split(":")[0] for r in roles.TABLE]
    got = without_optional(
        f"""
        import importlib
        import zenav
        from zenav import Robot
        for name in {[*services_, *BASE_MODULES]!r}:
            importlib.import_module(name)
        from zenav.cli.main import build_parser
        build_parser()  # imports every command's module
        print("imported", Robot.__name__)
        """
    )
    assert got.returncode == 0, got.stderr
    assert got.stdout.strip() == "imported Robot"


def test_a_blocked_package_does_fail_to_import():
    """The check above could fail: an import of any of them in that interpreter raises."""
    got = without_optional("import cv2")
    assert got.returncode != 0 and "import of cv2 halted" in got.stderr


@pytest.mark.parametrize(
    "service, setting, extra",
    [
        ("sim", "sim.camera=true", "zenav[camera]"),
        ("vps", 'vps.source="camera"', "zenav[camera]"),
        ("driver", 'driver.port="/dev/null"', "zenav[robot]"),
    ],
)
def test_a_service_whose_feature_lacks_its_package_exits_in_one_line(service, setting, extra):
    """At start, before connecting: exit 2 (bad config) with one line naming the extra, no traceback."""
    got = without_optional(f"import runpy\nrunpy.run_module('zenav.services.{service}', run_name='__main__')", "--set", setting)
    assert got.returncode == 2, got.stderr
    lines = got.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"zenav-{service}: ") and f"pip install '{extra}'" in lines[0], got.stderr


def test_the_camera_vps_without_the_apriltag_library_needs_it_only_when_asked_for():
    got = without_optional(
        """
        from zenav.common.config import ConfigError, Settings
        from zenav.services.vps import detect
        from zenav.services.vps.service import VpsConfig
        print(detect.resolve("auto"), type(detect.make("auto", 30.0)).__name__)
        Settings.load(None, vps={"source": "camera"}).section("vps", VpsConfig)  # auto: fine
        try:
            Settings.load(None, vps={"source": "camera", "detector": "apriltag"}).section("vps", VpsConfig)
        except ConfigError as e:
            print(e)
        """,
        blocked=("pupil_apriltags",),
    )
    assert got.returncode == 0, got.stderr
    resolved, error = got.stdout.strip().splitlines()
    assert resolved == "opencv OpenCVDetector"  # auto: OpenCV's detector where the AprilTag library is not installed
    assert "needs pupil-apriltags: pip install 'zenav[apriltag]'" in error


@pytest.mark.parametrize(
    "argv, extra",
    [
        (["camera", "detect", "x.png"], "zenav[camera]"),
        (["up", "--set", "sim.camera=true"], "zenav[camera]"),
        (["up", "--profile", "robot"], "zenav[robot]"),
        (["bench", "--quick"], "zenav[bench]"),
        (["record", "x.mcap"], "zenav[tools]"),
        (["ros2"], "zenav[ros2]"),
    ],
)
def test_a_command_whose_package_is_missing_says_which_extra_in_one_line(argv, extra, tmp_path):
    got = without_optional(f"import os; os.chdir({str(tmp_path)!r})\nfrom zenav.cli.main import main\nsys.exit(main(sys.argv[1:]))", *argv)
    assert got.returncode == 2, got.stderr
    lines = [line for line in got.stderr.strip().splitlines() if "no OpenCV here" not in line]
    assert len(lines) == 1 and lines[0].startswith(f"zenav {argv[0]}: ") and f"pip install '{extra}'" in lines[0], got.stderr


def test_the_sim_profile_leaves_its_camera_out_where_opencv_is_missing():
    """`zenav up` on the base install runs the synthetic VPS (the profile's camera settings need OpenCV)."""
    got = without_optional("from zenav.common import extras\nprint(extras.installed('cv2'), extras.installed('numpy'))")
    assert got.stdout.split() == ["False", "True"]
    assert services.PROFILES["sim"].sets(camera=False) == []


def test_the_error_names_the_package_and_the_extra():
    assert str(extras.missing("serial", "the driver")) == "the driver needs pyserial: pip install 'zenav[robot]'"
    assert str(extras.missing("cv2", "the benchmark", extra="bench")) == "the benchmark needs OpenCV: pip install 'zenav[bench]'"
    assert isinstance(extras.missing("cv2", "x"), ConfigError)  # a service exits 2 on it, as on any bad config
    assert extras.require("cv2", "the camera") is cv2
