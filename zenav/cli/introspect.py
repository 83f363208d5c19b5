"""`zenav topics | echo | hz | query`: look at the robot's keys on the wire, like `ros2 topic` and Zenoh's own tools.

KEY is relative to zenav/<robot>/ (`pose`, `'diag/*'`, `'**'`), a field topic's name
(`sim/body`, `camera/frame`: under zenav/field/) or absolute (`zenav/r1/odom`,
`zenav/field/**`, `@/...` for Zenoh's admin space). Payloads are decoded as their
contract type when the key has one, else as msgpack, JSON or text.
Exit codes: 0 done, 1 nothing came (echo --timeout, hz) or an internal error reply,
2 bad arguments (checked before connecting) or an invalid_argument reply,
3 no router, no reply, or an unavailable reply.
"""

from __future__ import annotations

import argparse
import queue
import sys
import time
from collections import deque
from collections.abc import Callable

import msgspec

from zenav.cli.checks import Failed, fail
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE
from zenav.cli.session import open_bus, positive, robot_id
from zenav.cli.wire import (
    Seen,
    decode,
    error_reply,
    hz_line,
    json_line,
    parse_params,
    query_types,
    rate,
    resolve,
    topic_type,
    topics_table,
    unknown_topic,
)
from zenav.common import codec, keys
from zenav.common.app import connection_args
from zenav.common.bus import ZenohBus
from zenav.common.contract import ErrorCode

POLL = 0.2  # [s] longest wait for a sample before looking at the clock and Ctrl-C again
QUIET_NOTE = 3.0  # [s] with nothing on the key this long, echo and hz say they are still listening
HZ_KEEP = 10_000  # arrivals per key the rate is computed over (the newest)
EXIT_CODES: dict[str, int] = {ErrorCode.INVALID_ARGUMENT: EXIT_USAGE, ErrorCode.UNAVAILABLE: EXIT_UNAVAILABLE}  # others: EXIT_FAILED
Body = Callable[[argparse.Namespace, str, ZenohBus], int]  # a subcommand: (args, key, bus) -> exit code


def count(text: str) -> int:
    """An integer >= 1 (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be 1 or more")
    return value


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    key_help = "key relative to zenav/<robot>/ (pose, 'diag/*'), a field topic (sim/body) or absolute (zenav/r1/odom)"
    p = subcommand(sub, topics, "the robot's keys with publishers, their rates and types, and its liveliness tokens")
    p.add_argument("key", nargs="?", default="**", help=f"{key_help}; default '**', and the field's keys (zenav/field/**)")
    p.add_argument("--window", type=positive, default=2.0, help="seconds to listen (default 2)")
    p = subcommand(sub, echo, "print each message on a key as one JSON object per line: {key, type, msg}")
    p.add_argument("key", help=key_help)
    p.add_argument("--once", action="store_true", help="print one message, then exit")
    p.add_argument("--count", type=count, help="print this many messages, then exit")
    p.add_argument("--timeout", type=positive, help="give up after this many seconds (exit 1 if nothing came)")
    p = subcommand(sub, hz, "message rate on a key, and the min/max/std dev of its period (each second)")
    p.add_argument("key", help=key_help)
    p.add_argument("--window", type=positive, help="listen this many seconds, then exit (default: until Ctrl-C)")
    p.add_argument("--count", type=count, help="stop after this many messages")
    p = subcommand(sub, query, "query a key (any queryable) and print each reply as JSON: zenav query nav/status")
    p.add_argument("key", help=key_help)
    p.add_argument("params", nargs="*", metavar="NAME=VALUE", help="request fields; values parsed as JSON where they parse: x=1 name=r1")
    p.add_argument("--timeout", type=positive, default=5.0, help="seconds to wait for replies (default 5)")


def subcommand(sub: argparse._SubParsersAction[argparse.ArgumentParser], body: Body, help: str) -> argparse.ArgumentParser:
    """The parser of a subcommand named after `body`, with the connection arguments, that runs it through `command`."""
    p = sub.add_parser(body.__name__, help=help)
    connection_args(p)
    p.set_defaults(func=lambda args: command(args, body))
    return p


def command(args: argparse.Namespace, body: Body) -> int:
    """Check the arguments, connect, run `body(args, key, bus)`; one line and an exit code on failure."""
    try:
        key = checked(args)
        bus = open_bus(args)
    except Failed as e:
        return fail(args.command, e)
    try:
        return body(args, key, bus)
    finally:
        bus.close()


def checked(args: argparse.Namespace) -> str:
    """The full key of a command; Failed(EXIT_USAGE) for a bad robot, key, or request."""
    try:
        key = resolve(robot_id(args), args.key)
        if args.command == "query":
            args.request = parse_params(args.params)
            types = query_types(key)
            if types is not None:
                try:
                    msgspec.convert(args.request, types[0])
                except msgspec.ValidationError as e:
                    raise ValueError(codec.invalid(types[0], e, args.request)) from None
    except ValueError as e:
        raise Failed(EXIT_USAGE, str(e)) from None
    return key


def listen(bus: ZenohBus, *on: str) -> queue.SimpleQueue[tuple[str, bytes, float]]:
    """Samples on the keys `on` as (key, payload, arrival [s, monotonic]), queued on Zenoh's thread."""
    samples: queue.SimpleQueue[tuple[str, bytes, float]] = queue.SimpleQueue()
    for key in on:
        bus.subscribe(key, lambda k, data: samples.put((k, data, time.monotonic())))
    return samples


def follow(bus: ZenohBus, key: str, command: str) -> queue.SimpleQueue[tuple[str, bytes, float]]:
    """`listen` for echo and hz, saying first on stderr if the key names no contract topic (a typo?)."""
    note = unknown_topic(key)
    if note:
        print(f"zenav {command}: {note}", file=sys.stderr, flush=True)
    return listen(bus, key)


def quiet(command: str, key: str, since: float, said: bool) -> bool:
    """Say once on stderr that nothing came on the key for QUIET_NOTE seconds since `since`; whether it is said."""
    if not said and time.monotonic() - since >= QUIET_NOTE:
        print(f"zenav {command}: nothing on {key} yet; still listening (zenav topics lists what is published)", file=sys.stderr, flush=True)
        return True
    return said


def take(samples: queue.SimpleQueue[tuple[str, bytes, float]], deadline: float | None) -> tuple[str, bytes, float] | None:
    """The next sample, or None after POLL seconds or at the deadline."""
    left = POLL if deadline is None else min(POLL, deadline - time.monotonic())
    try:
        return samples.get(timeout=max(left, 0.0))
    except queue.Empty:
        return None


def topics(args: argparse.Namespace, key: str, bus: ZenohBus) -> int:
    """Listen for --window seconds; print each key seen, its type and rate, and the liveliness tokens (by
    default the robot's keys and the field's, which every robot shares: the camera, the robots' bodies)."""
    samples = listen(bus, key, keys.field_key("**")) if args.key == "**" else listen(bus, key)
    deadline = time.monotonic() + args.window
    tokens = bus.tokens(key, timeout=args.window)
    arrivals: dict[str, list[float]] = {}
    sizes: dict[str, int] = {}
    kinds: dict[str, str] = {}
    while time.monotonic() < deadline:
        got = take(samples, deadline)
        if got is not None:
            k, data, at = got
            arrivals.setdefault(k, []).append(at)
            sizes[k] = sizes.get(k, 0) + len(data)
            if k not in kinds:
                kinds[k] = decode(data, topic_type(k))[0]
    seen = [Seen(k, kinds[k], rate(ts), sizes[k] / len(ts)) for k, ts in arrivals.items()]
    print(topics_table(seen, tokens, args.window))
    return EXIT_OK


def echo(args: argparse.Namespace, key: str, bus: ZenohBus) -> int:
    """Print each sample on the key as a JSON line, until --once/--count/--timeout or Ctrl-C."""
    samples = follow(bus, key, "echo")
    limit = 1 if args.once else args.count
    start = time.monotonic()
    deadline = None if args.timeout is None else start + args.timeout
    shown, said = 0, False
    while (limit is None or shown < limit) and (deadline is None or time.monotonic() < deadline):
        got = take(samples, deadline)
        if got is not None:
            k, data, _ = got
            print(json_line(k, data, topic_type(k)), flush=True)
            shown += 1
        elif shown == 0:
            said = quiet("echo", key, start, said)
    if shown == 0:
        print(f"zenav echo: no message on {key} in {args.timeout:g} s", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def hz(args: argparse.Namespace, key: str, bus: ZenohBus) -> int:
    """Print the rate of each key matching, every second, until --window/--count or Ctrl-C."""
    samples = follow(bus, key, "hz")
    start = time.monotonic()
    deadline = None if args.window is None else start + args.window
    arrivals: dict[str, deque[float]] = {}
    total, shown, said = 0, start, False
    while (args.count is None or total < args.count) and (deadline is None or time.monotonic() < deadline):
        got = take(samples, deadline)
        if got is not None:
            arrivals.setdefault(got[0], deque(maxlen=HZ_KEEP)).append(got[2])
            total += 1
        elif not arrivals:
            said = quiet("hz", key, start, said)
        if time.monotonic() - shown >= 1.0 and arrivals:
            shown = time.monotonic()
            print("\n".join(hz_line(k, rate(ts)) for k, ts in sorted(arrivals.items())), flush=True)
    if not arrivals:
        print(f"zenav hz: no message on {key} in {time.monotonic() - start:.1f} s", file=sys.stderr)
        return EXIT_FAILED
    print("\n".join(hz_line(k, rate(ts)) for k, ts in sorted(arrivals.items())), flush=True)
    return EXIT_OK


def query(args: argparse.Namespace, key: str, bus: ZenohBus) -> int:
    """Send the query; print each reply as a JSON line (errors on stderr); the worst reply's exit code."""
    payload = codec.encode(args.request)
    code, replies = EXIT_OK, 0
    for reply in bus.session.get(key, payload=payload, timeout=args.timeout):
        replies += 1
        if reply.ok is not None:
            k = str(reply.ok.key_expr)
            types = query_types(k)  # the replier's own key: with a wildcard query too
            print(json_line(k, reply.ok.payload.to_bytes(), None if types is None else types[1]), flush=True)
        elif reply.err is not None:
            error, message = error_reply(reply.err.payload.to_bytes())
            print(f"zenav query: {key}: {error}: {message}", file=sys.stderr)
            code = max(code, EXIT_CODES.get(error, EXIT_FAILED))
    if replies == 0:
        print(f"zenav query: no reply from {key} in {args.timeout:g} s (is its service up?)", file=sys.stderr)
        return EXIT_UNAVAILABLE
    return code
