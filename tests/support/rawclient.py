"""A client of the stack that imports only zenoh and msgpack, as any user's could."""

from __future__ import annotations

import json
import threading
import time

import msgpack
import zenoh


class RawClient:
    def __init__(self, endpoint: str, robot: str = "r1") -> None:
        conf = zenoh.Config()
        conf.insert_json5("mode", '"client"')
        conf.insert_json5("connect", json.dumps({"endpoints": [endpoint], "timeout_ms": -1}))
        conf.insert_json5("scouting", json.dumps({"multicast": {"enabled": False}}))
        self.session = zenoh.open(conf)
        self.prefix = f"zenav/{robot}"
        self.lock = threading.Condition()
        self.latest: dict[str, dict] = {}
        self.history: dict[str, list[dict]] = {}
        self._subs = []

    def follow(self, suffix: str, keep: bool = False) -> None:
        """Keep the newest message of every key under `suffix` (and all of them if keep)."""

        def on_sample(sample: zenoh.Sample) -> None:
            msg = msgpack.unpackb(sample.payload.to_bytes(), raw=False)
            key = str(sample.key_expr)[len(self.prefix) + 1 :]
            with self.lock:
                self.latest[key] = msg
                if keep:
                    self.history.setdefault(key, []).append(msg)
                self.lock.notify_all()

        self._subs.append(self.session.declare_subscriber(f"{self.prefix}/{suffix}", on_sample))

    def wait(self, pred, timeout: float):
        """Block until pred(self.latest) is true; TimeoutError otherwise."""
        deadline = time.monotonic() + timeout
        with self.lock:
            while not pred(self.latest):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"not met in {timeout} s; have {sorted(self.latest)}")
                self.lock.wait(left)
            return self.latest

    def wait_nav_ready(self, timeout: float = 30.0) -> None:
        """Block until nav/status says a goal would start (asking again on each new pose; needs follow("pose"))."""
        deadline = time.monotonic() + timeout
        while True:
            ok, st = self.query("nav/status", timeout=timeout)
            if ok and not st.get("not_ready"):
                return
            if time.monotonic() > deadline:
                raise TimeoutError(f"navigator not ready after {timeout:g} s: {st}")
            t = self.wait(lambda latest: "pose" in latest, timeout)["pose"]["t"]
            self.wait(lambda latest, t=t: latest["pose"]["t"] > t, max(deadline - time.monotonic(), 0.1))

    def alive(self) -> set[str]:
        return {str(r.ok.key_expr).rsplit("/", 1)[-1] for r in self.session.liveliness().get(f"{self.prefix}/alive/*", timeout=2.0) if r.ok}

    def put(self, suffix: str, msg: dict) -> None:
        self.session.put(f"{self.prefix}/{suffix}", msgpack.packb(msg))

    def query(self, suffix: str, request: dict | None = None, params: str = "", timeout: float = 10.0) -> tuple[bool, dict]:
        sel = f"{self.prefix}/{suffix}" + (f"?{params}" if params else "")
        payload = msgpack.packb(request) if request is not None else None
        for rep in self.session.get(sel, payload=payload, timeout=timeout):
            if rep.ok is not None:
                return True, msgpack.unpackb(rep.ok.payload.to_bytes(), raw=False)
            return False, msgpack.unpackb(rep.err.payload.to_bytes(), raw=False)
        raise TimeoutError(f"no reply to {sel}")

    def close(self) -> None:
        self.session.close()
