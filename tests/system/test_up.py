"""`zenav up` as real processes through its router, seen by a zenoh + msgpack client."""

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

from tests.support.procs import pids, service_pid
from tests.support.rawclient import RawClient
from zenav.bench.live import realtime_refused
from zenav.services import NAMES
from zenav.stack.inprocess import free_port

pytestmark = pytest.mark.system


@pytest.fixture(params=["client", "peer"])
def up(tmp_path, request):
    """`zenav up` with the services as router clients, or as peers that also link directly."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "zenav",
            "up",
            "--listen",
            endpoint,
            "--log-dir",
            str(tmp_path),
            "--set",
            "sim.rtf=2.0",
            "--duration",
            "240",
            "--zenoh-mode",
            request.param,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    client = RawClient(endpoint)
    yield proc, client, endpoint
    client.close()
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        proc.communicate(timeout=30)  # also closes the pipe
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
    for f in tmp_path.glob("*.log"):  # shown when a test fails
        print(f"--- {f.name}\n{f.read_text()[-2000:]}")


def test_up_serves_the_contract_to_a_plain_client(up, tmp_path):
    proc, c, endpoint = up
    c.follow("diag/*")
    for suffix in ("sim/truth", "odom", "motors/wheels"):
        c.follow(suffix, keep=True)
    # every service's token and diag
    c.wait(lambda latest: all(f"diag/{s}" in latest for s in NAMES), timeout=90)
    assert c.alive() == set(NAMES)
    for s in NAMES:
        d = c.latest[f"diag/{s}"]
        assert d["service"] == s and {"msgs_in", "msgs_out", "bad_input", "dropped_stale"} <= set(d["counters"])
    # the sim profile's camera: the sim renders frames, the vps calibrates itself on them and reads the robot's tag
    vps = c.wait(lambda latest: latest["diag/vps"]["counters"].get("fixes_captured", 0) > 0, timeout=30)["diag/vps"]
    assert vps["counters"]["frames"] > 0 and 0 < vps["counters"]["calibration_rms_um"] < 5000, vps
    # drive with cmd_vel (t = 0: a client without the stack clock), watch odom follow truth
    t0 = c.latest["sim/truth"]
    o0 = c.latest["odom"]
    deadline = time.monotonic() + 30
    while math.hypot(c.latest["sim/truth"]["x"] - t0["x"], c.latest["sim/truth"]["y"] - t0["y"]) < 0.3:
        assert time.monotonic() < deadline, "the robot did not move"
        c.put("cmd_vel", {"t": 0.0, "v": 0.2, "omega": 0.0})
        c.wait(lambda latest, n=c.latest["sim/truth"]["t"]: latest["sim/truth"]["t"] >= n + 0.05, timeout=5)
    c.put("cmd_vel", {"t": 0.0, "v": 0.0, "omega": 0.0})
    # compare odom with the truth of the same sample t, from where odom started
    c.wait(lambda latest: latest["odom"]["t"] >= latest["sim/truth"]["t"] - 0.05, timeout=10)
    with c.lock:
        truth = {round(m["t"], 6): m for m in c.history["sim/truth"]}
        odoms = [o for o in c.history["odom"] if o["t"] >= o0["t"] and round(o["t"], 6) in truth]
    first, last = odoms[0], odoms[-1]
    ta, tb = truth[round(first["t"], 6)], truth[round(last["t"], 6)]
    moved_truth = math.hypot(tb["x"] - ta["x"], tb["y"] - ta["y"])
    moved_odom = math.hypot(last["x"] - first["x"], last["y"] - first["y"])
    assert moved_truth > 0.25 and abs(moved_odom - moved_truth) < 0.03
    # a crashed service is restarted, and the launcher says why
    before = c.wait(lambda latest: latest["diag/odometry"]["uptime"] > 2.0, timeout=20)["diag/odometry"]
    os.kill(service_pid("odometry", endpoint), signal.SIGKILL)
    c.wait(lambda latest: latest["diag/odometry"]["uptime"] < before["uptime"] - 0.5, timeout=20)
    # Ctrl-C stops everything, wheels at zero first
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out
    assert "odometry exit" in out or "odometry killed by SIGKILL" in out, out
    assert "odometry restarted" in out, out
    last = c.history["motors/wheels"][-1]
    assert last["left"] == 0.0 and last["right"] == 0.0
    with pytest.raises(LookupError):
        service_pid("sim", endpoint)
    failed = [f.name for f in tmp_path.glob("*.log") if "Traceback" in f.read_text()]
    assert not failed, f"a handler failed (its traceback is in {failed})"


def test_a_second_instance_of_every_service_names_the_running_one(up):
    """Each service started again beside `zenav up`, in the same Zenoh mode: exit 3, naming the running process.
    A peer just opened links to the other peers a moment later: a lookup made before that must not miss them."""
    proc, c, endpoint = up
    c.follow("diag/*")
    c.wait(lambda latest: all(f"diag/{s}" in latest for s in NAMES), timeout=90)
    mode = "peer" if "peer" in proc.args else "client"
    for s in NAMES:  # one after the other: each a whole process start on a small host
        argv = [sys.executable, "-m", f"zenav.services.{s}", "--connect", endpoint, "--zenoh-mode", mode]
        p = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, timeout=60)
        last = p.stderr.strip().splitlines()[-1]
        print(f"{mode} {s}: exit {p.returncode}: {last}")
        assert p.returncode == 3, p.stderr
        assert last.startswith(f"zenav-{s}: another {s} already runs for robot r1 (") and f"-{service_pid(s, endpoint)}-" in last, last


def test_up_composes_the_services_its_config_file_names(tmp_path):
    """[deployment] compose: the robot's four services in one process, each alive with its own diag, and a goal runs through them."""
    robot_services = ("odometry", "localizer", "navigator", "motor")
    config = tmp_path / "small-computer.toml"
    config.write_text(f"[deployment]\ncompose = {json.dumps(robot_services)}\n")  # a JSON array is a TOML array
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    argv = [sys.executable, "-m", "zenav", "up", "--listen", endpoint, "--log-dir", str(tmp_path), "--config", str(config)]
    argv += ["--set", "sim.rtf=2.0", "--duration", "240"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    c = RawClient(endpoint)
    try:
        c.follow("diag/*")
        c.follow("pose")
        c.wait(lambda latest: all(f"diag/{s}" in latest for s in NAMES), timeout=90)
        assert c.alive() == set(NAMES)
        assert len(pids("zenav.stack.composed", endpoint)) == 1
        assert [s for s in NAMES if pids(f"zenav.services.{s}", endpoint)] == [s for s in NAMES if s not in robot_services]
        c.wait_nav_ready(timeout=60)
        ok, reply = c.query("nav/move_to_point", {"x": 0.3, "y": 0.0, "tolerance": 0.03, "wait": True}, timeout=60)
        assert ok and reply["result"] == "succeeded", reply
        # each gyro sample came before the odom sample of its step, though the process reads them down one
        # link in order and serves each encoder sample's whole chain before the next message
        localizer = c.wait(lambda latest: latest["diag/localizer"]["counters"]["msgs_in"] > 400, timeout=20)["diag/localizer"]
        assert localizer["counters"].get("gyro_late", 0) == 0, localizer["counters"]
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 0, out
        assert "motor, odometry, localizer, navigator in one process" in out, out
    finally:
        c.close()
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


ZENOH_THREADS = ("rx-", "tx-", "app-", "acc-", "net-")  # the names of Zenoh's runtime threads
REFUSED = realtime_refused(5)  # why this host refuses real-time priority, if it does


def _threads(pid: int) -> dict[int, tuple[str, int, int]]:
    """tid -> (name, scheduling policy, priority) of every thread of `pid`."""
    out = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        tid = int(task.name)
        out[tid] = ((task / "comm").read_text().strip(), os.sched_getscheduler(tid), os.sched_getparam(tid).sched_priority)
    return out


@pytest.mark.skipif(REFUSED is not None, reason=f"real-time priority refused here: {REFUSED}")
def test_up_runs_the_control_loop_and_its_router_at_the_realtime_priority_it_is_given(tmp_path):
    """[deployment] realtime: the robot's control-loop services, every Zenoh thread of them and of the embedded
    router, at SCHED_FIFO; the sim, the vps and `zenav up`'s own Python thread at the host's normal scheduling."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    argv = [sys.executable, "-m", "zenav", "up", "--listen", endpoint, "--log-dir", str(tmp_path)]
    argv += ["--set", "deployment.realtime=5", "--duration", "240"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    c = RawClient(endpoint)
    try:
        c.follow("diag/*")
        c.wait(lambda latest: all(f"diag/{s}" in latest for s in NAMES), timeout=90)
        for svc in ("odometry", "localizer", "navigator", "motor"):
            threads = _threads(service_pid(svc, endpoint)).values()
            zenoh_threads = [t for t in threads if t[0].startswith(ZENOH_THREADS)]
            assert zenoh_threads and all(t[1:] == (os.SCHED_FIFO, 5) for t in zenoh_threads), (svc, threads)
            assert os.sched_getscheduler(service_pid(svc, endpoint)) == os.SCHED_FIFO, svc
            assert "realtime_refused" not in c.latest[f"diag/{svc}"]["counters"], svc
        for svc in ("sim", "vps"):
            assert os.sched_getscheduler(service_pid(svc, endpoint)) == os.SCHED_OTHER, svc
        up = _threads(proc.pid)
        assert [t for t in up.values() if t[0].startswith(ZENOH_THREADS) and t[1:] != (os.SCHED_FIFO, 5)] == [], up
        assert up[proc.pid][1] == os.SCHED_OTHER  # its status screen and supervisor
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 0, out
    finally:
        c.close()
        if proc.poll() is None:
            proc.kill()


def test_up_runs_a_vps_for_each_camera_its_config_names_and_the_localizer_fuses_both(tmp_path):
    """[vps] also = ["onboard"]: the overhead camera's vps and the robot's own camera's, each its own process and
    presence; the localizer accepts fixes of both latencies (the overhead camera's link 0.3 s, the onboard one's 0.05 s)."""
    pytest.importorskip("cv2")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    argv = [sys.executable, "-m", "zenav", "up", "--listen", endpoint, "--log-dir", str(tmp_path), "--duration", "240"]
    argv += ["--services", "sim,motor,odometry,vps,localizer", "--set", 'vps.source="camera"', "--set", 'vps.also=["onboard"]']
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    c = RawClient(endpoint)
    try:
        c.follow("diag/*")
        c.follow("localizer/fixes", keep=True)
        c.wait(lambda latest: {"diag/vps", "diag/vps_onboard"} <= set(latest), timeout=90)
        assert {"vps", "vps_onboard"} <= c.alive()
        assert len(pids("zenav.services.vps", endpoint)) == 2  # each its own process
        for name in ("vps", "vps_onboard"):
            c.wait(lambda latest, n=name: latest[f"diag/{n}"]["counters"].get("fixes_captured", 0) > 0, timeout=60)
        c.wait(
            lambda latest: {f["latency"] > 0.2 for f in c.history.get("localizer/fixes", []) if f["accepted"]} == {True, False},
            timeout=60,
        )
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 0, out
        assert "starting sim, motor, odometry, vps, localizer, vps_onboard" in out, out
    finally:
        c.close()
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        for f in tmp_path.glob("*.log"):  # shown when the test fails
            print(f"--- {f.name}\n{f.read_text()[-2000:]}")
