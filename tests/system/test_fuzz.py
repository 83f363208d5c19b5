"""Bad input against the whole stack on a real router: nobody dies, every query is answered, every drop counted.

All six services run in this process (make_stack), each on its own Zenoh session.
Malformed payloads (tests/unit/test_fuzz_payloads.py) go to every key a service
subscribes to (put) and to every queryable (get, with a malformed payload or
malformed selector parameters). Only payloads the codec itself refuses are sent,
so each put must end as one `bad_input` in the receiver's diag counters (or, on an
input that keeps only the newest, one `dropped_superseded` if a newer sample came
before it was read) and each query as an `invalid_argument` error reply carrying the
codec's own message.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import msgspec
import pytest
import zenoh
from hypothesis import Phase, given, settings
from hypothesis import strategies as st

from tests.support.fuzz import FUZZ, malformed, malformed_params, not_utf8_payloads
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import JSON, ZenohBus
from zenav.common.runtime import FORMAT_PARAM, format_refusal
from zenav.services import NAMES

pytestmark = pytest.mark.system

ROBOT = "r1"  # the stack's default robot id
CI_PAYLOADS = 10_000  # the default run: well under a minute
LONG_PAYLOADS = 100_000  # the slow suite
ROUND = 2_000  # most malformed puts one service gets before its counters are checked (its queue holds 10,000)
BATCH = 10  # payloads drawn per Hypothesis example
START_TIMEOUT = 60.0  # [s] for every service's token and first diag
COUNT_TIMEOUT = 30.0  # [s] for a diag whose counters cover what was sent
QUERY_TIMEOUT = 5.0  # [s] for the error reply of one query
DEEP = 5_000  # nesting levels: well past Python's recursion limit


@dataclass(frozen=True)
class Put:
    suffix: str
    payload: bytes


@dataclass(frozen=True)
class Get:
    suffix: str
    selector: zenoh.Selector
    payload: bytes | None
    error: str  # the message the reply must carry: the codec's own


@pytest.fixture
def declared(monkeypatch):
    """Every subscription and queryable declared on a ZenohBus from now on, as (bus, method, key)."""
    seen: list[tuple[ZenohBus, str, str]] = []
    for method in ("subscribe", "queryable"):

        def spy(bus, key, callback, method=method, original=getattr(ZenohBus, method), **options):  # noqa: B008 (bind per loop)
            seen.append((bus, method, key))
            return original(bus, key, callback, **options)

        monkeypatch.setattr(ZenohBus, method, spy)
    return seen


def inputs(stack, declared) -> tuple[dict[str, dict[str, int]], dict[str, str]]:
    """What the running services declared: topic -> {subscriber: subscriptions}, query -> server."""
    topics: dict[str, dict[str, int]] = {}
    queries: dict[str, str] = {}
    for name, svc in stack.services.items():
        for bus, method, key in declared:
            if bus is not svc.bus:
                continue
            table = keys.TOPICS if method == "subscribe" else keys.QUERIES
            for suffix in table:
                if zenoh.KeyExpr(key).intersects(zenoh.KeyExpr(keys.key(ROBOT, suffix))):
                    if method == "subscribe":
                        subs = topics.setdefault(suffix, {})
                        subs[name] = subs.get(name, 0) + 1
                    else:
                        queries[suffix] = name
    return topics, queries


def draw(strategy: st.SearchStrategy, n: int, keep: Callable[[object], object]) -> list:
    """The first n values of `strategy` that keep() turns into something (deterministic)."""
    for factor in (1.25, 2.5, 5.0):  # most targets keep ~93% of the payloads; some far fewer
        out: list = []

        @settings(FUZZ, max_examples=math.ceil(factor * n / BATCH), phases=[Phase.generate])
        @given(st.lists(strategy, min_size=BATCH, max_size=BATCH))
        def collect(values: list) -> None:
            out.extend(x for x in map(keep, values) if x is not None)  # noqa: B023 (runs in this iteration)

        collect()
        if len(out) >= n:
            return out[:n]
    raise AssertionError(f"only {len(out)} of {n} payloads are malformed")


def refusal(decode: Callable[[], object]) -> str | None:
    """The codec's message if decode() refuses its input, else None."""
    try:
        decode()
    except codec.BadInput as e:
        return str(e)
    return None


def payloads(topics: dict[str, dict[str, int]], queries: dict[str, str], total: int) -> tuple[list[Put], list[Get], Counter]:
    """About `total` malformed inputs spread over every input of every service, and how many each receives."""
    per_target = math.ceil(total / (len(topics) + 2 * len(queries)))
    received: Counter = Counter()
    by_topic: list[list[Put]] = []
    for suffix, subscribers in sorted(topics.items()):
        typ = keys.TOPICS[suffix]
        bad = draw(malformed(typ), per_target, lambda c, t=typ: c.payload if refusal(lambda: codec.decode(c.payload, t)) else None)
        by_topic.append([Put(suffix, p) for p in bad])
        received.update({s: n * len(bad) for s, n in subscribers.items()})
    puts = [p for group in zip(*by_topic) for p in group]  # interleaved, as from several clients at once
    gets: list[Get] = []
    for suffix, server in sorted(queries.items()):
        typ, key = keys.QUERIES[suffix][0], keys.key(ROBOT, suffix)

        def with_payload(c, suffix=suffix, t=typ, key=key) -> Get | None:
            error = c.payload and refusal(lambda: codec.decode(c.payload, t))  # an empty payload means "use the parameters"
            return Get(suffix, zenoh.Selector(key), c.payload, error) if error else None

        def with_params(case, suffix=suffix, t=typ, key=key) -> Get | None:
            selector = zenoh.Selector(key, str(zenoh.Parameters(case[0])))
            params = dict(selector.parameters)
            seen = {k: v for k, v in params.items() if not k.startswith("_")}  # `_` names are Zenoh's, ignored
            # zenav's own `_format` (the reply's encoding) is read first; then the request (what the service will see)
            error = format_refusal(params.get(FORMAT_PARAM)) or refusal(lambda: codec.from_params(seen, t))
            return Get(suffix, selector, None, error) if error else None

        gets += draw(malformed(typ), per_target, with_payload) + draw(malformed_params(typ), per_target, with_params)
        received[server] += 2 * per_target
    return puts, gets, received


def answer(replies: list[zenoh.Reply]) -> object:
    """What a query got: the decoded error reply, or a description of anything else."""
    if len(replies) != 1:
        return f"{len(replies)} replies"
    if replies[0].err is None:
        return ("ok", replies[0].ok.payload.to_bytes())
    err = replies[0].err
    try:
        if str(err.encoding) == JSON:  # asked for with `_format=json`
            return msgspec.json.decode(err.payload.to_bytes(), type=m.ErrorReply)
        return codec.decode(err.payload.to_bytes(), m.ErrorReply)
    except (codec.BadInput, msgspec.DecodeError) as e:
        return ("error reply not an ErrorReply", str(e))


def diag_of(client, service: str, pred: Callable[[m.Diag], bool], timeout: float, what: str) -> m.Diag:
    """The newest diag of `service` once pred holds; an assertion naming the service otherwise."""
    try:
        return client.latest(f"diag/{service}").wait(pred, timeout)
    except TimeoutError as e:
        raise AssertionError(f"{service}: no diag {what} in {timeout} s ({e})") from None


def workers_running(client, timeout: float = COUNT_TIMEOUT) -> None:
    """Every service still has its token and publishes diag (its worker thread runs)."""
    client.wait_alive(NAMES, timeout=timeout)
    for s in NAMES:
        latest = client.latest(f"diag/{s}")
        seen = latest.count
        diag_of(client, s, lambda d, seen=seen, latest=latest: latest.count >= seen + 2, timeout, "after the bad input")


def fuzz(make_stack, declared, client, total: int) -> dict:
    """Send about `total` malformed inputs to the whole stack, check every outcome; figures of the run."""
    stack = make_stack(NAMES)
    client.wait_alive(NAMES, timeout=START_TIMEOUT)
    base = {s: diag_of(client, s, lambda d: True, START_TIMEOUT, "at start").counters for s in NAMES}
    topics, queries = inputs(stack, declared)
    assert set(queries) == set(keys.QUERIES), "every query of the contract is served"
    puts, gets, received = payloads(topics, queries, total)
    session = client.bus.session
    t0 = time.monotonic()

    # Puts, in rounds small enough for the services' queues; the counters must keep up. Each is
    # refused once read (bad_input), or dropped unread for a newer sample of an input that keeps
    # only the newest (dropped_superseded: the motor's commands, the navigator's poses).
    def dropped(counters: dict[str, int]) -> int:
        return counters["bad_input"] + counters.get("dropped_superseded", 0)

    sent: Counter = Counter()
    for start in range(0, len(puts), ROUND):
        for p in puts[start : start + ROUND]:
            session.put(keys.key(ROBOT, p.suffix), p.payload, congestion_control=zenoh.CongestionControl.BLOCK)
            sent.update(topics[p.suffix])
        for s, n in sent.items():
            diag_of(client, s, lambda d, s=s, n=n: dropped(d.counters) >= dropped(base[s]) + n, COUNT_TIMEOUT, f"counting {n} bad puts")

    # Queries: each must get exactly one invalid_argument error naming the problem.
    wrong = []
    for g in gets:
        got = answer(list(session.get(g.selector, payload=g.payload, timeout=QUERY_TIMEOUT)))
        if got != m.ErrorReply(error="invalid_argument", message=g.error):
            wrong.append((g.suffix, str(g.selector.parameters), g.payload, got))
    elapsed = time.monotonic() - t0
    assert not wrong, f"{len(wrong)} of {len(gets)} queries not answered as expected, e.g. {wrong[:3]}"

    # Every drop counted, and nothing overflowed: exactly, where no input was superseded. Where one
    # was, a bad put may have gone unread, or taken the place of a good sample that came before it.
    for s in NAMES:
        want = dropped(base[s]) + received[s]
        d = diag_of(client, s, lambda d, want=want: dropped(d.counters) >= want, COUNT_TIMEOUT, f"with {want} dropped")
        bad, exact = d.counters["bad_input"], base[s]["bad_input"] + received[s]
        superseded = d.counters.get("dropped_superseded", 0) - base[s].get("dropped_superseded", 0)
        if superseded == 0:
            assert bad == exact, f"{s}: bad_input {bad}, expected {exact}"
        else:
            assert bad <= exact <= bad + superseded, f"{s}: bad_input {bad}, superseded {superseded}"
        assert d.counters.get("dropped_overflow", 0) == base[s].get("dropped_overflow", 0), s

    # Still alive: the token, a fresh diag (the worker runs), and queries answered.
    workers_running(client)
    for suffix in ("nav/status", "localizer/pose"):
        replies = list(session.get(keys.key(ROBOT, suffix), timeout=QUERY_TIMEOUT))
        assert len(replies) == 1, suffix
        if replies[0].err is not None:  # an error is an answer too, but not a bad-input one
            assert codec.decode(replies[0].err.payload.to_bytes(), m.ErrorReply).error != "invalid_argument"
    return {"puts": len(puts), "queries": len(gets), "seconds": round(elapsed, 1), "per_second": round((len(puts) + len(gets)) / elapsed)}


def test_deeply_nested_input_does_not_stop_a_service(make_stack, declared, client):
    stack = make_stack(NAMES)
    client.wait_alive(NAMES, timeout=START_TIMEOUT)
    topics, queries = inputs(stack, declared)
    deep = b"\x91" * DEEP + b"\xc0"  # [[[...nil...]]], in a key no message has
    session = client.bus.session
    for suffix in topics:
        session.put(keys.key(ROBOT, suffix), b"\x82" + codec.encode("t") + codec.encode(0.0) + codec.encode("not_a_field") + deep)
    for suffix in queries:
        list(session.get(zenoh.Selector(keys.key(ROBOT, suffix), "x=" + "[" * DEEP), timeout=QUERY_TIMEOUT))
    workers_running(client)


def test_text_that_is_not_utf8_does_not_stop_a_service(make_stack, declared, client):
    stack = make_stack(NAMES)
    client.wait_alive(NAMES, timeout=START_TIMEOUT)
    topics, queries = inputs(stack, declared)
    session = client.bus.session
    for suffix in topics:
        for payload in not_utf8_payloads(keys.TOPICS[suffix]):
            session.put(keys.key(ROBOT, suffix), payload)
    for suffix in queries:
        for payload in not_utf8_payloads(keys.QUERIES[suffix][0]):
            got = answer(list(session.get(keys.key(ROBOT, suffix), payload=payload, timeout=QUERY_TIMEOUT)))
            assert isinstance(got, m.ErrorReply) and got.error == "invalid_argument", (suffix, payload, got)
    workers_running(client)


def test_ten_thousand_malformed_payloads(make_stack, declared, client):
    stats = fuzz(make_stack, declared, client, CI_PAYLOADS)
    assert stats["puts"] + stats["queries"] >= CI_PAYLOADS
    print(f"fuzz: {stats}")


@pytest.mark.slow
@pytest.mark.timeout(1800)
def test_a_hundred_thousand_malformed_payloads(make_stack, declared, client):
    stats = fuzz(make_stack, declared, client, LONG_PAYLOADS)
    assert stats["puts"] + stats["queries"] >= LONG_PAYLOADS
    print(f"fuzz: {stats}")
