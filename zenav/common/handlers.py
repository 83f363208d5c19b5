"""The decorators that declare a service's handlers: what each method is run for, and where its result goes.

Each leaves its declaration on the function (a named tuple), which `Service.start` reads."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from zenav.common import keys


class Subscription(NamedTuple):
    """A method declared with @subscribe."""

    suffix: str
    typ: type
    after: str | None  # the periodic topic its input is held for (None: served as it comes)
    latest: bool  # only the newest sample is worth serving


class Queryable(NamedTuple):
    """A method declared with @query."""

    suffix: str
    typ: type
    priority: bool  # taken before other queued input, on a link of its own
    acts: bool  # served on its exact key only


def subscribe(suffix: str, typ: type | None = None, *, after: str | None = None, latest: bool = False) -> Callable[[Any], Any]:
    """Run the method for every message on `zenav/<robot>/<suffix>`, decoded as `typ`.

    `after`: a periodic topic this service subscribes to; while it flows, each message is
    served in the gap after its next sample (the module's docstring). `latest`: only the
    newest message is worth serving (the module's docstring)."""

    def deco(fn: Any) -> Any:
        fn._zenav_sub = Subscription(suffix, typ or keys.TOPICS[suffix], after, latest)
        return fn

    return deco


def publish(suffix: str) -> Callable[[Any], Any]:
    """Publish the method's return value (unless None) on `suffix`."""

    def deco(fn: Any) -> Any:
        fn._zenav_pub = suffix
        return fn

    return deco


def timer(period: float | str) -> Callable[[Any], Any]:
    """Run the method every `period` seconds of the service clock.

    `period` is seconds, or the name of an attribute of the service holding them
    (so that config can set it: `@timer("tick_period")`).
    """

    def deco(fn: Any) -> Any:
        fn._zenav_timer = period
        return fn

    return deco


def query(suffix: str, typ: type | None = None, *, priority: bool = False, acts: bool = True) -> Callable[[Any], Any]:
    """Serve queries on `suffix`; the method returns a reply, or None to reply later.

    `priority`: taken before any other queued input, and served on a link of its own. `acts=False`: read-only, so a
    wildcard query may reach it; an acting query runs only on its exact key.
    """

    def deco(fn: Any) -> Any:
        fn._zenav_query = Queryable(suffix, typ or keys.QUERIES[suffix][0], priority, acts)
        return fn

    return deco


def on_liveliness(service: str) -> Callable[[Any], Any]:
    """Run the method with `alive: bool` when `service`'s liveliness token appears or goes.

    A process that dies loses its token as soon as its socket closes: faster than any
    message timeout, so safety reactions (stop the wheels) hang on it.
    """

    def deco(fn: Any) -> Any:
        fn._zenav_liveliness = service
        return fn

    return deco
