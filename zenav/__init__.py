"""zenav: localization and navigation for differential-drive robots, over Eclipse Zenoh.

`from zenav import Robot` is the robot library (`zenav.robot`; `zenav.aio` for asyncio),
imported on first use so that `import zenav` alone loads no Zenoh.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.2.0"
__all__ = ["Goal", "Internal", "InvalidArgument", "Result", "Robot", "Unavailable", "ZenavError", "__version__"]

if TYPE_CHECKING:
    from zenav.robot import Goal, Internal, InvalidArgument, Result, Robot, Unavailable, ZenavError


def __getattr__(name: str) -> Any:
    """The robot library's names, imported on first use."""
    if name in __all__:
        from zenav import robot

        return getattr(robot, name)
    raise AttributeError(f"module 'zenav' has no attribute {name!r}")
