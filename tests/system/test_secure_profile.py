"""What docker/make-secrets.sh makes: private files, per-robot operators, TLS with the deployment's own CA.

A `zenav router` process runs on the router config the script writes, listening on
`tls/127.0.0.1:PORT` only; real Zenoh sessions log in with the client configs the
script writes, as the services and host tools do through ZENOH_CONFIG.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest
import zenoh

from tests.support.matching import Inbox, publish, wait_matching
from zenav.common.bus import zenoh_config

pytestmark = pytest.mark.system

REPO = Path(__file__).resolve().parents[2]
ROUTER_UP = 30.0  # [s] for the router process to accept a login


def unused_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def secrets(tmp_path_factory) -> Path:
    """The script's output for robots r1 and r2."""
    out = tmp_path_factory.mktemp("deployment") / "secrets"
    subprocess.run(
        ["sh", str(REPO / "docker" / "make-secrets.sh"), "-d", str(out), "-r", "r1,r2"], check=True, capture_output=True, timeout=60
    )
    return out


class Router:
    """`zenav router` on the generated config, on a TLS endpoint; sessions logged in to it."""

    def __init__(self, secrets: Path) -> None:
        self.secrets = secrets
        self.endpoint = f"tls/127.0.0.1:{unused_port()}"
        env = {k: v for k, v in os.environ.items() if k != "ZENOH_CONFIG"}
        cmd = [sys.executable, "-m", "zenav", "router", "--listen", self.endpoint, "--zenoh-config", str(secrets / "router.json5")]
        self.proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self._sessions: list[zenoh.Session] = []

    def login(self, user: str | None = None, config: Path | None = None, timeout: float = 3.0) -> zenoh.Session:
        """A session logged in as `user` with the config the script made (or another `config`)."""
        path = config or (self.secrets / f"{user}.json5" if user else None)
        session = zenoh.open(zenoh_config("client", self.endpoint, config_file=str(path) if path else None, connect_timeout=timeout))
        self._sessions.append(session)
        return session

    def close(self) -> str:
        for s in self._sessions:
            s.close()
        self.proc.send_signal(signal.SIGINT)
        try:
            return self.proc.communicate(timeout=10)[0]
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.communicate()[0]


@pytest.fixture(scope="module")
def router(secrets):
    r = Router(secrets)
    try:
        r.login("viewer", timeout=ROUTER_UP)  # retries until the router is up
        yield r
    finally:
        print(r.close())  # shown when a test fails


def replies(session: zenoh.Session, key: str) -> list[str]:
    """The replies to a query (an ACL denial gives none)."""
    querier = session.declare_querier(key, timeout=3.0)
    wait_matching(querier)
    try:
        return [r.ok.payload.to_bytes().decode() for r in querier.get() if r.ok is not None]
    finally:
        querier.undeclare()


def test_the_secrets_are_private(secrets):
    assert stat.S_IMODE(secrets.stat().st_mode) == 0o700
    files = [p for p in secrets.iterdir()]
    assert {p.name for p in files} >= {"users.txt", "ca.key", "router.key", "router.json5", "operator-r1.json5", "operator-r2.json5"}
    assert {p.name: stat.S_IMODE(p.stat().st_mode) for p in files} == {p.name: 0o600 for p in files}
    assert not (secrets / "operator.json5").exists()  # no login drives every robot


def test_an_operator_commands_its_own_robot_only(router):
    navigators = {robot: router.login(f"navigator-{robot}") for robot in ("r1", "r2")}
    motor, watcher = router.login("motor-r2"), router.login("viewer")
    goals: list[str] = []

    def serve(q: zenoh.Query) -> None:
        goals.append(str(q.key_expr))
        q.reply(q.key_expr, b"accepted")

    for robot, navigator in navigators.items():
        navigator.declare_queryable(f"zenav/{robot}/nav/move_to_point", serve)
    commands, leases = Inbox(), Inbox()
    motor.declare_subscriber("zenav/*/cmd_vel", commands.on_sample)
    watcher.liveliness().declare_subscriber("zenav/*/lease/**", leases.on_sample, history=True)

    op1, op2 = router.login("operator-r1"), router.login("operator-r2")
    assert replies(op1, "zenav/r1/nav/move_to_point") == ["accepted"]
    assert replies(op1, "zenav/r2/nav/move_to_point") == []  # refused by the router
    assert replies(op2, "zenav/r2/nav/move_to_point") == ["accepted"]
    assert goals == ["zenav/r1/nav/move_to_point", "zenav/r2/nav/move_to_point"]

    for robot in ("r1", "r2"):
        publish(op1, f"zenav/{robot}/cmd_vel", "operator-r1")  # only the navigator drives the wheels
    publish(navigators["r1"], "zenav/r2/cmd_vel", "navigator-r1")  # and only its own robot's
    publish(navigators["r2"], "zenav/r2/cmd_vel", "navigator-r2")
    assert commands.settle({("zenav/r2/cmd_vel", "navigator-r2")}) == {("zenav/r2/cmd_vel", "navigator-r2")}

    tokens = [op1.liveliness().declare_token(f"zenav/{robot}/lease/goal") for robot in ("r1", "r2")]
    assert leases.settle({("zenav/r1/lease/goal", "")}) == {("zenav/r1/lease/goal", "")}
    for token in tokens:
        token.undeclare()


def test_each_service_holds_only_its_own_tokens(router):
    """Liveliness and instance tokens (duplicate detection) pass for their own service and robot; the driver logs in too."""
    watcher, alive = router.login("viewer"), Inbox()
    watcher.liveliness().declare_subscriber("zenav/r1/**", alive.on_sample, history=True)
    navigator, driver, operator = router.login("navigator-r1"), router.login("driver-r1"), router.login("operator-r1")
    held = {
        navigator: ["zenav/r1/alive/navigator", "zenav/r1/instance/navigator/host-1-a"],
        driver: ["zenav/r1/alive/driver", "zenav/r1/instance/driver/host-2-b", "zenav/r1/alive/motor"],
        operator: ["zenav/r1/instance/navigator/fake"],  # would make the real navigator report a duplicate
    }
    tokens = [session.liveliness().declare_token(key) for session, keys in held.items() for key in keys]
    allowed = {(k, "") for k in held[navigator] + held[driver][:2]}
    assert alive.settle(allowed) == allowed
    encoders = Inbox()
    watcher.declare_subscriber("zenav/r1/sensors/encoders", encoders.on_sample)
    publish(driver, "zenav/r1/sensors/encoders", "driver-r1")
    assert encoders.settle({("zenav/r1/sensors/encoders", "driver-r1")}) == {("zenav/r1/sensors/encoders", "driver-r1")}
    for token in tokens:
        token.undeclare()


def test_tls_clients_need_the_deployments_ca(router, tmp_path):
    login: dict = {"transport": {"auth": {"usrpwd": {"user": "viewer", "password": password(router.secrets, "viewer")}}}}
    without_ca = tmp_path / "no-ca.json5"
    without_ca.write_text(json.dumps(login))
    with pytest.raises(zenoh.ZError):
        router.login(config=without_ca, timeout=2.0)
    other_ca = tmp_path / "other-ca.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes", "-days", "1", "-subj", "/CN=other"]
        + ["-keyout", str(tmp_path / "other.key"), "-out", str(other_ca)],
        check=True,
        capture_output=True,
        timeout=30,
    )
    wrong_ca = tmp_path / "wrong-ca.json5"
    login["transport"]["link"] = {"tls": {"root_ca_certificate": str(other_ca)}}
    wrong_ca.write_text(json.dumps(login))
    with pytest.raises(zenoh.ZError):
        router.login(config=wrong_ca, timeout=2.0)
    with_ca = router.login("viewer")  # the script's config: the login and the CA
    assert not with_ca.is_closed()


def test_a_login_is_still_required_over_tls(router, tmp_path):
    ca_only = tmp_path / "ca-only.json5"
    ca_only.write_text(json.dumps({"transport": {"link": {"tls": {"root_ca_certificate": str(router.secrets / "ca.pem")}}}}))
    with pytest.raises(zenoh.ZError):
        router.login(config=ca_only, timeout=2.0)


def password(secrets: Path, user: str) -> str:
    for line in (secrets / "users.txt").read_text().splitlines():
        name, _, pw = line.partition(":")
        if name == user:
            return pw
    raise LookupError(user)
