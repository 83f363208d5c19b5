"""Several computers: the robot, the camera host and the operator's laptop as three network namespaces on one switch.

Each host runs the real `zenav` processes of docs/running.md, "Several computers": the robot host `zenav up` with
the robot's services, its router listening on the LAN; the camera host `zenav up` with the vps alone, its router
linked to the robot's; the laptop the CLI, a client of the robot's router. The test watches the robot's router
through a unix socket it also listens on (a local tool of the robot host, outside the namespaces' network).
Then the camera host and the laptop lose their link, and the robot goes on as the docs say.

Needs root and `ip netns` (skips otherwise). Every namespace, and each process in it, goes when the test ends.
"""

from __future__ import annotations

import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from tests.support.matching import Inbox
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.common.client import Client

pytestmark = pytest.mark.system

REPO = Path(__file__).resolve().parents[2]
ZENAV = str(Path(sys.executable).with_name("zenav"))  # the package's command, in the tests' venv
HOSTS = {"robot": "10.77.0.1", "camera": "10.77.0.2", "laptop": "10.77.0.3"}  # inside the namespaces only
ROBOT = f"tcp/{HOSTS['robot']}:7447"
ROBOT_TLS = f"tls/{HOSTS['robot']}:7447"
ROBOT_SERVICES = "sim,motor,odometry,localizer,navigator"
UP = 120.0  # [s] for a host's processes to start and link (a shared 2-core machine)
GOAL = 90.0  # [s] for a goal to end


class Lan:
    """Three hosts on one switch: a network namespace each, a veth pair from each into a bridge in a fourth."""

    def __init__(self) -> None:
        self.prefix = f"zmh{os.getpid()}"
        self.made: list[str] = []
        self.procs: list[subprocess.Popen] = []

    def ns(self, host: str) -> str:
        return f"{self.prefix}{host}"

    def up(self) -> None:
        switch = self.ns("lan")
        for name in (switch, *(self.ns(h) for h in HOSTS)):
            ip("netns", "add", name)
            self.made.append(name)
        ip("-n", switch, "link", "add", "br0", "type", "bridge")
        ip("-n", switch, "link", "set", "br0", "up")
        for host, address in HOSTS.items():
            ns = self.ns(host)
            ip("link", "add", "eth0", "netns", ns, "type", "veth", "peer", "name", host, "netns", switch)
            ip("-n", switch, "link", "set", host, "master", "br0")
            ip("-n", switch, "link", "set", host, "up")
            ip("-n", ns, "addr", "add", f"{address}/24", "dev", "eth0")
            ip("-n", ns, "link", "set", "eth0", "up")
            ip("-n", ns, "link", "set", "lo", "up")

    def start(self, host: str, argv: list[str], log: Path, env: dict[str, str] | None = None) -> subprocess.Popen:
        """A process on `host`, its output into `log`."""
        with open(log, "w") as out:
            proc = subprocess.Popen(
                ["ip", "netns", "exec", self.ns(host), *argv],
                stdout=out,
                stderr=subprocess.STDOUT,
                env={**os.environ, **(env or {})},
                cwd=REPO,
            )
        self.procs.append(proc)
        return proc

    def run(self, host: str, argv: list[str], timeout: float = GOAL, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
        argv = ["ip", "netns", "exec", self.ns(host), *argv]
        return subprocess.run(argv, capture_output=True, text=True, timeout=timeout, cwd=REPO, env={**os.environ, **(env or {})})

    def unplug(self, host: str) -> None:
        """The host's cable out (or its Wi-Fi gone): no packet in or out, no socket closed."""
        ip("-n", self.ns(host), "link", "set", "eth0", "down")

    def plug(self, host: str) -> None:
        ip("-n", self.ns(host), "link", "set", "eth0", "up")

    def power_off(self, host: str) -> None:
        """Kill every process of the host (SIGKILL): they started there, as the test's children."""
        for pid in ip("netns", "pids", self.ns(host)).split():
            try:
                os.kill(int(pid), signal.SIGKILL)
            except ProcessLookupError:
                pass

    def close(self) -> None:
        for host in HOSTS:
            if self.ns(host) in self.made:
                self.power_off(host)
        for proc in self.procs:
            proc.wait(timeout=30)
        for name in reversed(self.made):
            subprocess.run(["ip", "netns", "del", name], capture_output=True)


def ip(*args: str) -> str:
    return subprocess.run(["ip", *args], check=True, capture_output=True, text=True, timeout=30).stdout


@pytest.fixture
def lan() -> Iterator[Lan]:
    if os.geteuid() != 0:
        pytest.skip("network namespaces need root")
    if shutil.which("ip") is None:
        pytest.skip("no `ip` command (iproute2)")
    net = Lan()
    try:
        try:
            net.up()
        except subprocess.CalledProcessError as e:
            pytest.skip(f"cannot make network namespaces here: {e.stderr.strip()}")
        yield net
    finally:
        net.close()


@pytest.fixture
def scratch() -> Iterator[Path]:
    """A short directory (a unix socket's path has at most 107 bytes), logs shown when a test fails."""
    path = Path(tempfile.mkdtemp(prefix="zmh"))
    yield path
    for f in sorted(path.glob("**/*.log")):
        print(f"--- {f.relative_to(path)}\n{f.read_text()[-3000:]}")
    shutil.rmtree(path, ignore_errors=True)


class Watch:
    """What the robot's router carries, seen from the robot host: nav/state and the localizer's fixes, kept in order."""

    def __init__(self, client: Client) -> None:
        self.client = client
        self.fixes: list = []
        client.subscribe("localizer/fixes", self.fixes.append)
        self.nav = client.latest("nav/state")
        self.truth = client.latest("sim/truth")

    def running(self, goal_id: int):
        """Block until goal `goal_id` runs; its nav/state."""
        return self.nav.wait(lambda s: s.goal_id == goal_id and s.result is None, timeout=GOAL)

    def ended(self, goal_id: int):
        """Block until goal `goal_id` ends; its last nav/state."""
        return self.nav.wait(lambda s: s.goal_id == goal_id and s.result is not None, timeout=GOAL)

    def accepted(self, since: float, until: float = float("inf")) -> int:
        """Fixes the localizer accepted that reached it from stack time `since` to `until`."""
        return sum(1 for f in list(self.fixes) if f.accepted and since <= f.t_arrival <= until)


def goto(lan: Lan, log: Path, x: float, y: float, *extra: str) -> subprocess.Popen:
    """`zenav goto` on the laptop, through the robot's router."""
    return lan.start("laptop", [ZENAV, "goto", str(x), str(y), *extra, "--connect", ROBOT], log)


def finished(proc: subprocess.Popen, log: Path) -> str:
    """Wait for a command to end; its output (the test fails, showing it, if it did not exit 0)."""
    proc.wait(timeout=GOAL)
    out = log.read_text()
    assert proc.returncode == 0, out
    return out


STOPPED = 1e-3  # [m/s, rad/s] the robot's true speeds once it stopped


def test_three_hosts_drive_and_losing_the_camera_host_or_the_laptop_leaves_the_robot_driving(lan, scratch):
    sock = f"unixsock-stream/{scratch}/robot.sock"
    lan.start(
        "robot",
        [ZENAV, "up", "--listen", f"{ROBOT},{sock}", "--services", ROBOT_SERVICES, "--log-dir", str(scratch / "robot")],
        scratch / "robot.log",
    )
    lan.start(
        "camera",
        [ZENAV, "up", "--services", "vps", "--router-connect", ROBOT, "--log-dir", str(scratch / "camera")],
        scratch / "camera.log",
    )
    client = Client("r1", sock, connect_timeout=UP)
    try:
        watch = Watch(client)
        # The camera host's vps reads the frames the sim renders on the robot host, across the link, and the
        # robot's localizer takes its fixes.
        client.wait_alive(["vps", *ROBOT_SERVICES.split(",")], timeout=UP)
        vps = client.latest("diag/vps").wait(lambda d: d.counters.get("fixes_captured", 0) > 0, timeout=UP)
        assert vps.counters["frames"] > 0, vps
        client.latest("pose").wait(timeout=UP)
        status = lan.run("laptop", [ZENAV, "status", "--connect", ROBOT], timeout=UP)
        assert "6/6 services alive" in status.stdout, status.stdout + status.stderr

        # 1. A goal from the laptop, on a pose fused with the camera's fixes.
        log = scratch / "goal-1.log"
        first = goto(lan, log, 0.3, 0.0, "--wait")
        began = watch.running(1).t
        assert "goal 1 succeeded" in finished(first, log)
        assert watch.accepted(began, watch.ended(1).t) > 0

        # 2. The camera host's cable out: the robot drives a second goal on odometry alone.
        lan.unplug("camera")
        log = scratch / "goal-2.log"
        second = goto(lan, log, 0.3, 0.3, "--wait")
        began = watch.running(2).t
        assert "goal 2 succeeded" in finished(second, log)
        assert watch.accepted(began) == 0  # no fix came while it drove

        # The camera host back: its router links again and the fixes resume.
        lan.plug("camera")
        back = watch.truth.wait(timeout=5.0).t
        client.latest("localizer/fixes").wait(lambda f: f.accepted and f.t_arrival > back, timeout=UP)

        # 3. The laptop lost mid-goal. A goal sent without --wait (no lease) runs to its end ...
        log = scratch / "goal-3.log"
        finished(goto(lan, log, 0.0, 0.3), log)
        watch.running(3)
        lan.unplug("laptop")
        assert watch.ended(3).result == "succeeded"
        lan.plug("laptop")
        # ... and a goal a program holds (--wait, the library) stops: its lease went with the laptop.
        goto(lan, scratch / "goal-4.log", 0.6, 0.0, "--wait")  # killed with the laptop when the test ends
        watch.running(4)
        lan.unplug("laptop")
        end = watch.ended(4)
        assert end.result == "aborted" and "lease lost" in end.message, end
        watch.truth.wait(lambda t: t.t > end.t and abs(t.v) < STOPPED and abs(t.omega) < STOPPED, timeout=GOAL)
    finally:
        client.close()


CAMERA_LOGIN = """grep '^vps-r1:' users.txt > camera-users.txt
sed "s|usrpwd: {|usrpwd: { dictionary_file: \\"/etc/zenav/camera-users.txt\\",|" vps-r1.json5 > camera-router.json5
"""  # the camera host's files, as docs/running.md makes them


def lines(proc: subprocess.Popen) -> queue.Queue:
    """The process's output lines, read by a thread, so that the test waits for one with a timeout."""
    out: queue.Queue = queue.Queue()

    def read() -> None:
        assert proc.stdout is not None
        with proc.stdout:
            for line in proc.stdout:
                out.put(line)

    threading.Thread(target=read, daemon=True).start()
    return out


def wait_line(out: queue.Queue, text: str, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    seen = []
    while time.monotonic() < deadline:
        try:
            line = out.get(timeout=max(deadline - time.monotonic(), 0.01))
        except queue.Empty:
            break
        seen.append(line)
        if text in line:
            return
    raise TimeoutError(f"no {text!r} in {timeout} s: {''.join(seen)}")


def test_the_camera_host_s_router_logs_in_to_the_robot_s_and_a_wrong_password_is_refused(lan, scratch):
    secrets = scratch / "secrets"
    make = [str(REPO / "docker" / "make-secrets.sh"), "-d", str(secrets), "-n", HOSTS["robot"]]
    subprocess.run(["sh", *make], check=True, capture_output=True, timeout=30)
    subprocess.run(["sh", "-c", CAMERA_LOGIN.replace("/etc/zenav", str(secrets))], cwd=secrets, check=True, timeout=30)
    # An intruder's router on the laptop: the vps's name, a wrong password (its own vps logs in to it, locally).
    (secrets / "intruder-users.txt").write_text("vps-r1:wrong\n")
    intruder = (secrets / "camera-router.json5").read_text().replace(str(secrets / "camera-users.txt"), str(secrets / "intruder-users.txt"))
    (secrets / "intruder.json5").write_text(re.sub(r'password: "[0-9a-f]+"', 'password: "wrong"', intruder))

    sock = f"unixsock-stream/{scratch}/robot.sock"
    router = [ZENAV, "router", "--listen", f"{ROBOT_TLS},{sock}", "--zenoh-config", str(secrets / "router.json5")]
    lan.start("robot", router, scratch / "router.log")
    sim = [sys.executable, "-m", "zenav.services.sim", "--connect", ROBOT_TLS, "--set", "sim.camera=false"]
    lan.start("robot", sim, scratch / "sim.log", env={"ZENOH_CONFIG": str(secrets / "sim-r1.json5")})
    bad = subprocess.Popen(
        ["ip", "netns", "exec", lan.ns("laptop"), ZENAV, "up", "--robot", "r2", "--services", "vps", "--router-connect", ROBOT_TLS]
        + ["--set", "vps.source=synthetic", "--log-dir", str(scratch / "intruder")],
        env={**os.environ, "ZENOH_CONFIG": str(secrets / "intruder.json5")},
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lan.procs.append(bad)
    wait_line(lines(bad), "all 1 services alive", UP)  # its router is up, and trying its login to the robot's
    camera = [ZENAV, "up", "--services", "vps", "--router-connect", ROBOT_TLS, "--set", "vps.source=synthetic"]
    lan.start(
        "camera",
        [*camera, "--log-dir", str(scratch / "camera")],
        scratch / "camera.log",
        env={"ZENOH_CONFIG": str(secrets / "camera-router.json5")},
    )

    session = zenoh.open(zenoh_config("client", sock, config_file=str(secrets / "viewer.json5"), connect_timeout=UP))
    try:
        viewer = Client("r1", bus=ZenohBus(session))
        viewer.wait_alive(["sim", "vps"], timeout=UP)
        viewer.latest("vps/pose").wait(timeout=UP)  # the camera host's fixes, through its router's login
        # Its login is the vps's: the robot's router lets through what the vps may send, and nothing else.
        inbox = Inbox()

        def sent_by_the_test(sample: zenoh.Sample) -> None:  # not the camera's own fixes
            if sample.payload.to_bytes() == b"camera":
                inbox.on_sample(sample)

        for key in ("cmd_vel", "vps/pose"):
            session.declare_subscriber(f"zenav/r1/{key}", sent_by_the_test)
        put = "from tests.support.matching import publish; from zenav.common.bus import zenoh_config; import zenoh\n"
        put += "s = zenoh.open(zenoh_config('client', 'tcp/127.0.0.1:7447', connect_timeout=30))\n"
        put += "for k in ('cmd_vel', 'vps/pose'): publish(s, 'zenav/r1/' + k, 'camera')\n"
        sent = lan.run("camera", [sys.executable, "-c", put], timeout=UP, env={"ZENOH_CONFIG": str(secrets / "vps-r1.json5")})
        assert sent.returncode == 0, sent.stdout + sent.stderr
        assert inbox.settle({("zenav/r1/vps/pose", "camera")}) == {("zenav/r1/vps/pose", "camera")}
        # The intruder's router, up since before the camera's, never linked: its vps is not seen.
        alive, expected = Inbox(), {("zenav/r1/alive/sim", ""), ("zenav/r1/alive/vps", "")}
        session.liveliness().declare_subscriber("zenav/*/alive/*", alive.on_sample, history=True)
        assert alive.settle(expected) == expected
    finally:
        session.close()
