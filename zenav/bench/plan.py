"""How much one `zenav bench` run measures: FULL, or QUICK for CI, restricted to some sections."""

from __future__ import annotations

from dataclasses import dataclass, replace

from zenav.common.scenarios import PRESETS
from zenav.services.localizer.base import MODES
from zenav.services.navigator.params import CONTROLLERS

SECTIONS = ("latency", "cost", "speed", "accuracy", "navigation", "settle", "planning", "camera", "peers", "profile", "fleet")


@dataclass(frozen=True)
class Plan:
    """How much one bench run measures."""

    latency_window: float  # [s] one robot at 100 Hz: each latency run, and the cost run
    sweep_window: float  # [s] each other point of the rate and robot sweeps
    rates: tuple[float, ...]  # [Hz] sensor rates swept, one robot
    robots: tuple[int, ...]  # robot counts swept on one router, at 100 Hz
    speed_harnesses: tuple[str, ...]  # processes (what the accuracy runs use), in-process (what integration tests use)
    speed_rtfs: tuple[float, ...]  # realtime factors compared with the first (1.0)
    speed_seeds: tuple[int, ...]  # seeds of the speed study's path and turn trials
    rtf: float  # realtime factor of the accuracy runs, or the most they may use (follow_speed)
    follow_speed: bool  # lower `rtf` to the highest the speed study finds within noise of realtime
    modes: tuple[str, ...]  # localizer modes run live (default scenario, first seed)
    scenarios: tuple[str, ...]
    seeds: tuple[int, ...]  # accuracy seeds per scenario (every mode replayed on each)
    laps: float  # square laps of an accuracy run
    controllers: tuple[str, ...]
    path_seeds: tuple[int, ...]  # the path trial (then the turn sweep) per controller
    square_laps: float  # the square trial per controller (0: not run)
    kinematic_seeds: int  # the navigator's kinematic path trial per controller (bench/studies/navigator.py)
    latency_runs: int = 3  # latency runs per deployment, the deployments interleaved (bench/added.py pools them)
    compose: tuple[str, ...] = ("odometry", "localizer", "navigator", "motor")  # run again composed in one process (none: not)
    peers: bool = True  # the latency run again with the services as Zenoh peers, beside a bare chain of peers
    busy: bool = True  # the latency run again with one core kept busy, at normal and at real-time priority
    profile_seconds: float = 10.0  # [s] of stack time each service is timed over (bench/profile.py)
    spy_seconds: int = 10  # [s] py-spy samples the robot's service processes as deployed (bench/spy.py)
    board_window: float = 20.0  # [s] each deployment of the robot profile on the emulated board (bench/board.py; 0: not run)
    fleet_robots: tuple[int, ...] = (1, 2, 5, 10, 20)  # robots' traffic played through one router (bench/fleet.py)
    fleet_window: float = 10.0  # [s] each robot count plays
    fleet_hosts: int = 3  # namespaces, one router each (0: not run)
    settle_trials: int = 100  # seeded trials per move of the settle table (bench/settle.py)
    planning_pairs: int = 200  # reachable random start/goal pairs per layout (bench/planning.py)
    planning_drives: int = 20  # goals planned round obstacles driven per layout
    crossing_runs: int = 50  # perturbed runs of 2 robots swapping and of 4 crossing the centre (bench/crossing.py)
    camera_frames: int = 200  # frames rendered and read per camera (bench/camera.py)
    camera_scenarios: tuple[str, ...] = ("default", "harsh")  # the square with the camera VPS and with the synthetic, first seed
    camera_path_seeds: tuple[int, ...] = (1, 2, 3)  # the path trial with the camera VPS and with the synthetic
    # Realtime factor of those runs: the sim renders each frame in its own process, so faster than
    # realtime the rendering delays its steps on a small machine; 1 is how `zenav up` runs it.
    camera_rtf: float = 1.0
    # WPILib's DifferentialDrivePoseEstimator on the stream zenav's localizer gets (bench/peers.py): each scenario's
    # square on the live stack with each VPS (first seed), and on the world model over `wpilib_seeds`
    wpilib_scenarios: tuple[str, ...] = ("default", "coarse", "harsh")
    wpilib_vps: tuple[str, ...] = ("synthetic", "camera")
    wpilib_seeds: tuple[int, ...] = (1, 2, 3, 4, 5)
    sections: tuple[str, ...] = SECTIONS
    limit: float | None = None  # [s] the whole run should take less (the quick plan's CI budget)


FULL = Plan(
    latency_window=20.0,
    sweep_window=20.0,
    rates=(50.0, 100.0, 200.0, 400.0),
    robots=(1, 2, 5, 10, 20),
    speed_harnesses=("processes", "in-process"),
    speed_rtfs=(1.0, 2.0, 3.0, 4.0, 5.0, 8.0),
    speed_seeds=(1, 2),
    rtf=3.0,
    follow_speed=True,
    modes=MODES,
    scenarios=tuple(PRESETS),
    seeds=(1, 2, 3),
    laps=3.0,
    controllers=CONTROLLERS,
    path_seeds=tuple(range(1, 11)),
    square_laps=3.0,
    kinematic_seeds=10,
)
QUICK = Plan(
    latency_window=8.0,
    sweep_window=5.0,
    rates=(100.0,),
    robots=(1, 2),
    speed_harnesses=("processes",),
    speed_rtfs=(1.0, 3.0),
    speed_seeds=(1,),
    rtf=3.0,
    follow_speed=False,
    modes=("ekf",),
    scenarios=("default", "harsh"),
    seeds=(1,),
    laps=1.0,
    controllers=CONTROLLERS,
    path_seeds=(1,),
    square_laps=0.0,
    kinematic_seeds=3,
    latency_runs=3,
    compose=(),
    peers=False,
    busy=False,
    profile_seconds=3.0,
    spy_seconds=3,
    board_window=0.0,
    fleet_robots=(1, 5),
    fleet_window=3.0,
    settle_trials=3,
    camera_frames=20,
    camera_scenarios=("default",),
    camera_path_seeds=(1,),
    wpilib_scenarios=("default",),
    wpilib_vps=("synthetic",),
    wpilib_seeds=(1,),
    # the camera, the peers, the profile, the fleet and planning only when asked (--only ...): the quick run keeps its budget
    planning_pairs=20,
    planning_drives=2,
    crossing_runs=3,
    sections=tuple(s for s in SECTIONS if s not in ("camera", "peers", "profile", "fleet", "planning")),
    limit=120.0,
)


def only(plan: Plan, sections: list[str] | None) -> Plan:
    """The plan restricted to some sections (None: all)."""
    return plan if not sections else replace(plan, sections=tuple(s for s in SECTIONS if s in sections))
