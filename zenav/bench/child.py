"""The bench's helper processes: a relay, an observer, a publisher, a flood, ... each a function of a bench module.

`argv(fn, *args)` is the command line that runs `fn(*args)` in a process of its own (the arguments as JSON);
what the function returns, if anything, is printed as JSON on its stdout after the lines it prints itself.
Only the functions in ROLES run this way: the bench's one entry point for users is `zenav bench`.
"""

from __future__ import annotations

import importlib
import json
import sys
from collections.abc import Callable, Sequence

ROLES = {
    "arm": ("relay",),
    "chain": ("relay", "publish"),
    "latency": ("observe",),
    "fleet": ("play", "sink", "watch", "router"),
    "safety_rig": ("operator", "flood", "big"),
}
PACKAGE = "zenav.bench."


def argv(fn: Callable[..., object], *args: object) -> list[str]:
    """The command line that runs `fn(*args)` as a process of its own."""
    module = fn.__module__.removeprefix(PACKAGE)
    if fn.__name__ not in ROLES.get(module, ()):
        raise ValueError(f"{fn.__module__}.{fn.__name__} is not a role of the bench's helper processes")
    return [sys.executable, "-m", __name__, module, fn.__name__, json.dumps(args)]


def main(args: Sequence[str]) -> int:
    """Run one role: `MODULE FUNCTION ARGS-JSON`."""
    if len(args) != 3 or args[1] not in ROLES.get(args[0], ()):
        print(f"usage: python -m {__name__} MODULE FUNCTION ARGS-JSON, one of {ROLES}", file=sys.stderr)
        return 2
    fn = getattr(importlib.import_module(PACKAGE + args[0]), args[1])
    result = fn(*json.loads(args[2]))
    if result is not None:
        print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
