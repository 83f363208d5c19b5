"""The `secure` deployment: a router that requires a login and applies config/secure/router.json5.

The router is a `zenav router --zenoh-config` process on the config that
docker/make-secrets.sh writes; sessions log in with the client configs the script
makes, as the services do through ZENOH_CONFIG. Each rule is checked with
stand-in sessions declaring what the services would (a subscriber on cmd_vel,
queryables on nav/*), then the six real services run under it as processes, and
(docker suite) as the compose deployment.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import zenoh

from tests.support import docker as compose
from tests.support import goals
from tests.support.matching import Inbox, publish, wait_matching
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.common.client import Client, Unavailable
from zenav.common.keys import QUERIES
from zenav.services import NAMES, PROFILES
from zenav.stack.inprocess import free_port

pytestmark = pytest.mark.system

REPO = Path(__file__).resolve().parents[2]
ROBOTS = ("r1", "r2")  # the robots the deployment's logins are made for


def login(service: str, robot: str = "r1") -> str:
    """The login of one robot's service (`vps-r1`)."""
    return f"{service}-{robot}"


USERS = (*(login(s) for s in NAMES), "operator-r1", "viewer")
ROBOT = "zenav/r1"
ROUTER_UP = 30.0  # [s] for the router process to accept a login
REFUSED_WITHIN = 5.0  # [s] a refused login must fail by then
STACK_UP = 90.0  # [s] for six service processes to log in and declare their tokens
GOAL = (0.3, 0.0)  # [m] map frame
GOAL_TOLERANCE = 0.15  # [m] the navigator's tolerance plus localization error

# Who may publish each topic and serve each query (the contract's tables).
PUBLISHER = {
    "clock": "sim-r1",
    "sim/truth": "sim-r1",
    "sensors/encoders": "sim-r1",
    "sensors/imu": "sim-r1",
    "sensors/compass": "sim-r1",
    "vps/pose": "vps-r1",
    "odom": "odometry-r1",
    "pose": "localizer-r1",
    "localizer/fixes": "localizer-r1",
    "cmd_vel": "navigator-r1",
    "nav/state": "navigator-r1",
    "motors/wheels": "motor-r1",
    **{f"diag/{s}": login(s) for s in NAMES},
}
SERVER = {
    q: login("localizer" if q.startswith("localizer/") or q == "time/sync" else "sim" if q == "sim/reset" else "navigator") for q in QUERIES
}
READ_ONLY = {"localizer/pose", "time/sync"}  # what anyone may ask: the pose, the stack's clock


def client_config(endpoint: str, config_file: str | None, timeout: float) -> zenoh.Config:
    """The services' client config (bus.zenoh_config), failing after `timeout` seconds."""
    return zenoh_config("client", endpoint, config_file=config_file, connect_timeout=timeout)


class Deployment:
    """The router process and the logins it knows."""

    def __init__(self, endpoint: str, secrets: Path) -> None:
        self.endpoint, self.secrets = endpoint, secrets
        self._sessions: list[zenoh.Session] = []

    def login(self, user: str, timeout: float = 2.0) -> zenoh.Session:
        """A session logged in as `user` with the password the script made."""
        conf = client_config(self.endpoint, str(self.secrets / f"{user}.json5"), timeout)
        session = zenoh.open(conf)
        self._sessions.append(session)
        return session

    def close(self) -> None:
        for s in self._sessions:
            s.close()


def stop(proc: subprocess.Popen) -> str:
    """SIGINT, then SIGKILL if it lingers; its output."""
    proc.send_signal(signal.SIGINT)
    try:
        return proc.communicate(timeout=10)[0]
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate()[0]


@pytest.fixture(scope="module")
def secure_router(tmp_path_factory):
    """The router process on a free port; yields (endpoint, secrets directory)."""
    secrets = tmp_path_factory.mktemp("secrets")
    make = ["sh", str(REPO / "docker" / "make-secrets.sh"), "-d", str(secrets), "-r", ",".join(ROBOTS)]
    subprocess.run(make, check=True, capture_output=True, timeout=30)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    env = {k: v for k, v in os.environ.items() if k != "ZENOH_CONFIG"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "zenav", "router", "--listen", endpoint, "--zenoh-config", str(secrets / "router.json5")],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        Deployment(endpoint, secrets).login("viewer", timeout=ROUTER_UP).close()  # retries until the router is up
        yield endpoint, secrets
    finally:
        print(stop(proc))  # shown when a test fails


@pytest.fixture
def deployment(secure_router):
    """Logins to the router, all closed after the test."""
    dep = Deployment(*secure_router)
    yield dep
    dep.close()


@pytest.fixture
def services(secure_router):
    """The six services as processes, each logged in as itself (ZENOH_CONFIG), as compose runs them
    (with the sim profile's settings: the sim's camera frames pass the ACL to the vps)."""
    endpoint, secrets = secure_router
    sets = {name: [a for s in PROFILES["sim"].sets() if s.startswith(f"{name}.") for a in ("--set", s)] for name in NAMES}
    procs = {
        name: subprocess.Popen(
            [sys.executable, "-m", f"zenav.services.{name}", "--connect", endpoint, *sets[name]],
            env={**os.environ, "ZENOH_CONFIG": str(secrets / f"{login(name)}.json5")},
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for name in NAMES
    }
    yield procs
    for name, proc in procs.items():
        print(f"--- {name}\n{stop(proc)[-2000:]}")  # shown when a test fails


def replied(session: zenoh.Session, suffix: str) -> bool:
    """Whether a query on `suffix` got any reply (an ACL denial gives none)."""
    querier = session.declare_querier(f"{ROBOT}/{suffix}", timeout=3.0)
    wait_matching(querier)
    try:
        return any(True for _ in querier.get())
    finally:
        querier.undeclare()


def test_a_client_without_a_login_cannot_open_a_session(deployment):
    t0 = time.monotonic()
    with pytest.raises(zenoh.ZError):
        zenoh.open(client_config(deployment.endpoint, None, 1.0))
    assert time.monotonic() - t0 < REFUSED_WITHIN


@pytest.mark.parametrize("user, password", [("operator-r1", "wrong"), ("intruder", "anything")])
def test_a_wrong_password_or_an_unknown_user_is_refused(deployment, tmp_path, user, password):
    conf = tmp_path / "client.json5"
    conf.write_text(json.dumps({"transport": {"auth": {"usrpwd": {"user": user, "password": password}}}}))
    t0 = time.monotonic()
    with pytest.raises(zenoh.ZError):
        zenoh.open(client_config(deployment.endpoint, str(conf), 1.0))
    assert time.monotonic() - t0 < REFUSED_WITHIN


def test_a_non_operator_can_watch_but_cannot_move_the_robot(deployment):
    motor, viewer, navigator = deployment.login("motor-r1"), deployment.login("viewer"), deployment.login("navigator-r1")
    localizer, operator = deployment.login("localizer-r1"), deployment.login("operator-r1")
    commands, poses = Inbox(), Inbox()
    motor.declare_subscriber(f"{ROBOT}/cmd_vel", commands.on_sample)
    viewer.declare_subscriber(f"{ROBOT}/pose", poses.on_sample)
    goals: list[str] = []

    def serve(q: zenoh.Query) -> None:
        goals.append(str(q.key_expr))
        q.reply(q.key_expr, b"accepted")

    navigator.declare_queryable(f"{ROBOT}/nav/move_to_point", serve)

    publish(localizer, f"{ROBOT}/pose", "localizer-r1")
    assert poses.settle({(f"{ROBOT}/pose", "localizer-r1")}) == {(f"{ROBOT}/pose", "localizer-r1")}

    for user, sender in (("viewer", viewer), ("operator-r1", operator), ("navigator-r1", navigator)):
        publish(sender, f"{ROBOT}/cmd_vel", user)
    assert commands.settle({(f"{ROBOT}/cmd_vel", "navigator-r1")}) == {(f"{ROBOT}/cmd_vel", "navigator-r1")}

    assert replied(operator, "nav/move_to_point")
    assert not replied(viewer, "nav/move_to_point")
    assert goals == [f"{ROBOT}/nav/move_to_point"]  # the operator's only


def test_each_topic_reaches_subscribers_only_from_its_publisher(deployment):
    inbox = Inbox()
    deployment.login("viewer").declare_subscriber(f"{ROBOT}/**", inbox.on_sample)
    for user in USERS:
        sender = deployment.login(user)
        for topic in PUBLISHER:  # the sim stack's topics (the secure deployment has no driver)
            publish(sender, f"{ROBOT}/{topic}", user)
    expected = {(f"{ROBOT}/{topic}", PUBLISHER[topic]) for topic in PUBLISHER}
    assert inbox.settle(expected) == expected


def test_only_operators_query_nav_set_pose_and_reset_anyone_reads_the_pose(deployment):
    for user in set(SERVER.values()):  # stand-ins serving every query of the contract
        server = deployment.login(user)
        for suffix in (q for q, owner in SERVER.items() if owner == user):
            server.declare_queryable(f"{ROBOT}/{suffix}", lambda q: q.reply(q.key_expr, b"{}"))
    for user in USERS:
        session = deployment.login(user)
        answered = {suffix for suffix in QUERIES if replied(session, suffix)}
        assert answered == (set(QUERIES) if user == "operator-r1" else READ_ONLY), user


def test_only_the_navigator_serves_nav_queries(deployment):
    """A session of any other user cannot answer nav/* (and so hijack the goals)."""
    for user in USERS:
        deployment.login(user).declare_queryable(f"{ROBOT}/nav/status", lambda q, u=user: q.reply(q.key_expr, u))
    querier = deployment.login("operator-r1").declare_querier(
        f"{ROBOT}/nav/status", target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE, timeout=3.0
    )
    wait_matching(querier)
    answers = [r.ok.payload.to_bytes().decode() for r in querier.get() if r.ok]
    assert answers == ["navigator-r1"]


def test_only_a_service_declares_its_liveliness_and_only_operators_hold_leases(deployment):
    # Each user declares every service's instance token of each robot, named by the user, and a lease on r1.
    tokens = []  # a token lives as long as its handle
    for user in (*USERS, "vps-r2"):
        session = deployment.login(user)
        instances = (f"zenav/{robot}/instance/{svc}/{user}" for svc in NAMES for robot in ROBOTS)
        for key in (*instances, f"zenav/r1/lease/{user}"):
            tokens.append(session.liveliness().declare_token(key))
    inbox = Inbox()
    deployment.login("viewer").liveliness().declare_subscriber("zenav/**", inbox.on_sample, history=True)
    own = {(f"zenav/r1/instance/{s}/{login(s)}", "") for s in NAMES}
    expected = {*own, ("zenav/r2/instance/vps/vps-r2", ""), ("zenav/r1/lease/operator-r1", "")}
    assert inbox.settle(expected) == expected


def test_a_service_login_of_one_robot_acts_on_that_robot_only(deployment):
    """A leaked vps password publishes fixes for its own robot, not for the rest of the fleet."""
    inbox = Inbox()
    deployment.login("viewer").declare_subscriber("zenav/*/vps/pose", inbox.on_sample)
    for user in ("vps-r1", "vps-r2"):
        sender = deployment.login(user)
        for robot in ROBOTS:
            publish(sender, f"zenav/{robot}/vps/pose", user)
    expected = {("zenav/r1/vps/pose", "vps-r1"), ("zenav/r2/vps/pose", "vps-r2")}
    assert inbox.settle(expected) == expected


def test_the_services_run_under_the_acl_and_only_an_operator_drives(deployment, services):
    viewer = Client("r1", bus=ZenohBus(deployment.login("viewer")))
    operator = Client("r1", bus=ZenohBus(deployment.login("operator-r1")))
    viewer.wait_alive(NAMES, timeout=STACK_UP)
    for svc in NAMES:  # each publishes its own diag
        viewer.latest(f"diag/{svc}").wait(timeout=STACK_UP)
    viewer.latest("pose").wait(timeout=STACK_UP)
    assert viewer.query("localizer/pose").t >= 0.0
    vps = viewer.latest("diag/vps").wait(lambda d: d.counters.get("fixes_captured", 0) > 0, timeout=STACK_UP)
    assert vps.counters["frames"] > 0  # the sim's frames reached the vps through the router's rules

    with pytest.raises(Unavailable):  # no reply: the router dropped the query
        viewer.query("nav/move_to_point", {"x": GOAL[0], "y": GOAL[1]})

    reply = goals.move_to_point(operator, *GOAL, timeout=STACK_UP)
    assert reply.result == "succeeded", reply
    truth = viewer.latest("sim/truth").wait(timeout=5.0)
    assert math.hypot(truth.x - GOAL[0], truth.y - GOAL[1]) < GOAL_TOLERANCE


@pytest.mark.docker
@pytest.mark.timeout(900)
def test_the_secure_compose_deployment(image_mb, tmp_path):
    """docker-compose.yml with docker/secure/compose.yml: the same rules, in containers."""
    compose_command = compose.compose_command()  # skips without compose
    secrets = tmp_path / "secrets"
    subprocess.run(["sh", str(REPO / "docker" / "make-secrets.sh"), "-d", str(secrets)], check=True, capture_output=True, timeout=30)
    port = free_port()
    env = {**os.environ, "ZENAV_IMAGE": compose.IMAGE, "ZENAV_PORT": str(port), "ZENAV_SECRETS": str(secrets)}
    cmd = [
        *compose_command,
        "--project-name",
        f"zenavsecure{os.getpid()}",
        "--file",
        str(REPO / "docker-compose.yml"),
        "--file",
        str(REPO / "docker" / "secure" / "compose.yml"),
    ]
    dep = Deployment(f"tls/127.0.0.1:{port}", secrets)
    try:
        compose.run([*cmd, "up", "--detach", "--no-build"], env=env)
        viewer = Client("r1", bus=ZenohBus(dep.login("viewer", timeout=ROUTER_UP)))
        operator = Client("r1", bus=ZenohBus(dep.login("operator-r1")))
        with pytest.raises(zenoh.ZError):
            zenoh.open(client_config(dep.endpoint, None, 1.0))
        viewer.wait_alive(NAMES, timeout=STACK_UP)
        viewer.latest("pose").wait(timeout=STACK_UP)
        with pytest.raises(Unavailable):
            viewer.query("nav/move_to_point", {"x": GOAL[0], "y": GOAL[1]})
        reply = goals.move_to_point(operator, *GOAL, timeout=STACK_UP)
        assert reply.result == "succeeded", reply
    finally:
        dep.close()
        compose.run([*cmd, "down", "--volumes", "--timeout", "10"], env=env)
