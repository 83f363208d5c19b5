"""Optional packages: the extra that installs each, and the one error a feature gives when its package is missing.

The base install (the robot library, the CLI's driving and introspection, every service
but the camera VPS) imports none of them: each is imported where a feature needs it,
through `require`, or checked at start (`check`) where a config turns the feature on.
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

from zenav.common.config import ConfigError

# The module a feature imports -> (the package's name, the zenav extra that installs it).
PACKAGES: dict[str, tuple[str, str]] = {
    "cv2": ("OpenCV", "camera"),
    "pupil_apriltags": ("pupil-apriltags", "apriltag"),
    "serial": ("pyserial", "robot"),
    "mcap": ("mcap", "tools"),
    "foxglove": ("foxglove-sdk", "tools"),
    "matplotlib": ("matplotlib", "tools"),
    "rosbags": ("rosbags", "ros2"),
    "wpimath": ("robotpy-wpimath", "peers"),
}


class MissingExtra(ConfigError):
    """A feature's optional package is not installed; the message names the extra that installs it.

    A ConfigError: a service exits 2 with it as one line, as on any bad config, and the CLI prints it as one line."""


def missing(module: str, what: str, extra: str | None = None) -> MissingExtra:
    """The error for `what` (e.g. "the camera") needing `module`, installed by `extra` (default: the module's own)."""
    package, own = PACKAGES[module]
    return MissingExtra(f"{what} needs {package}: pip install 'zenav[{extra or own}]'")


def installed(module: str) -> bool:
    """Whether `module` can be found, without importing it."""
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a module blocked in sys.modules, or a parent that fails to import
        return False


def check(module: str, what: str, extra: str | None = None) -> None:
    """MissingExtra unless `module` is installed (a check at start, before the feature imports it)."""
    if not installed(module):
        raise missing(module, what, extra)


def require(module: str, what: str, extra: str | None = None) -> ModuleType:
    """`module`, imported; MissingExtra when it is not installed (an installed one that fails says why)."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        err = missing(module, what, extra)
        if e.name != module:  # installed but broken (a missing system library, say): show the cause too
            err = MissingExtra(f"{err} ({e})")
        raise err from None


def missing_of(e: ImportError, what: str) -> MissingExtra | None:
    """The MissingExtra an ImportError of an optional package means (None when it is not one of them)."""
    top = (e.name or "").split(".")[0]
    return missing(top, what) if top in PACKAGES else None
