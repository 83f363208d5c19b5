"""The bench's sections that print their tables instead of writing the report.

zenav bench safety [--floods 30]             the safety figures on real processes (bench/safety.py)
zenav bench link                             the motor board's serial link at 57600 to 2400 baud (bench/link.py)
zenav bench studies NAME... [--seeds N] [--scenarios NAME...]
                                             one part alone on the world model (bench/studies/, bench/peers.py)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Study:
    """One study: its table, and the seeds and scenarios it runs unless told."""

    table: Callable[[Sequence[str], int], str]  # (scenarios, seeds 1..N or 0..N-1) -> markdown
    seeds: int
    scenarios: tuple[str, ...]
    about: str


def _localizer(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench.studies import localizer
    from zenav.services.localizer.base import MODES

    return localizer.table(scenarios, MODES, range(1, seeds + 1))


def _fix_latency(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench.studies import localizer

    return localizer.latency_table(scenarios, range(1, seeds + 1))


def _pushed(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench.studies import localizer

    return localizer.pushed_table(scenarios, range(1, seeds + 1))


def _calibration(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench.studies import calibration

    return calibration.table(scenarios, range(1, seeds + 1))


def _odometry(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench.studies import odometry

    return odometry.table(scenarios, seeds)


def _navigator(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench.studies import navigator

    return navigator.report(seeds)


def _peers(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench import peers

    peers.wpimath()
    res = peers.study(scenarios, range(1, seeds + 1))
    return "\n".join(peers.lines({f"{name}, synthetic VPS, world model, seeds 1..{seeds}": r for name, r in res.items()}))


def _detectors(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench import camera

    (default, cfg), (ideal, ideal_cfg), (worse, worse_cfg) = camera.CAMERAS.items()
    measured = {
        f"{default}, apriltag": camera.measure(cfg, DETECTOR_FRAMES, "apriltag"),
        f"{default}, opencv": camera.measure(cfg, DETECTOR_FRAMES, "opencv"),
        f"{ideal}, apriltag": camera.measure(ideal_cfg, DETECTOR_FRAMES, "apriltag"),
        f"{worse}, apriltag": camera.measure(worse_cfg, DETECTOR_FRAMES, "apriltag"),
    }
    return "\n".join(camera.lines(measured, DETECTOR_FRAMES))


def _onboard(scenarios: Sequence[str], seeds: int) -> str:
    from zenav.bench import onboard

    return "\n".join([*onboard.fix_errors(ONBOARD_POSES, 1), "", *onboard.drive(ONBOARD_LAPS, 1.0)])


ONBOARD_POSES, ONBOARD_LAPS = 300, 3.0  # random poses whose frames are solved; laps of the square driven
DETECTOR_FRAMES = 50  # frames timed per camera and detector
ALL = ("default", "coarse", "harsh")
STUDIES = {
    "localizer": Study(_localizer, 5, ("default", "harsh"), "every localizer mode, RMSE against the truth"),
    "localizer-latency": Study(_fix_latency, 5, ("default", "harsh"), "the ekf with stamped fixes, or latency estimated"),
    "localizer-pushed": Study(_pushed, 5, ("default", "harsh"), "the ekf with another robot in the way, slip found or not"),
    "calibration": Study(_calibration, 5, ALL, "the online calibration after 60 s against the truth"),
    "odometry": Study(_odometry, 10, ALL, "dead reckoning's drift with each heading source"),
    "navigator": Study(_navigator, 10, (), "each controller's path and square on default and harsh, its turns"),
    "peers": Study(_peers, 5, ALL, "WPILib's pose estimator beside zenav's on the same streams"),
    "onboard": Study(_onboard, 1, (), "the onboard camera's fixes by tag count and distance, then the square driven"),
    "detectors": Study(_detectors, 1, (), "the overhead camera's detectors, pupil-apriltags and OpenCV, on rendered frames"),
}


def studies(names: Sequence[str], seeds: int | None, scenarios: Sequence[str] | None, say: Callable[[str], None] = print) -> None:
    """Each study named, in turn: its table."""
    for name in names:
        s = STUDIES[name]
        n, chosen = seeds or s.seeds, tuple(scenarios or s.scenarios) if s.scenarios else ()
        say(f"## {name}: {s.about} ({', '.join((*chosen, f'{n} seeds'))})\n")
        say(s.table(chosen, n) + "\n")


def link(say: Callable[[str], None] = print) -> None:
    """The serial link's table at each baud rate, 5 s each."""
    from zenav.bench import link as serial_link

    say(serial_link.table([serial_link.run(baud, 5.0) for baud in serial_link.BAUDS]))


def safety(floods: int) -> None:
    """The safety figures (printed as measured)."""
    from zenav.bench import safety as rig

    rig.measure(floods)
