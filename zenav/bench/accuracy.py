"""Accuracy runs: the whole stack on a router at a realtime factor, as separate processes
(as `zenav up` runs it) or in this process (as the integration tests run it).

A `Spec` names one run (scenario, seed, localizer mode, navigator controller, trial,
harness, VPS source); `run` drives it through the navigator and keeps the recording; `replay` feeds that
run's own odometry, fixes and sensors to every localizer mode offline
(the localizer study, `evaluate`), so the fusion rules are compared on the very same
data as the live one.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec

from zenav import services
from zenav.bench import trials
from zenav.bench.scoring import Score, rms, score
from zenav.bench.studies.localizer import evaluate
from zenav.bench.trials import Recorder, Trial, TrialGoal
from zenav.common.config import Settings
from zenav.common.contract import GoalResult
from zenav.robot import Robot
from zenav.services.localizer.base import LocalizerConfig
from zenav.services.localizer.modes import make_mode
from zenav.services.navigator.params import Params
from zenav.stack.inprocess import InProcessStack
from zenav.stack.launcher import ProcStack
from zenav.stack.router import Router

DIAG_WAIT = 10.0  # [s] wall for the sim's diag that covers the end of the trial (1 Hz of stack time)


@dataclass(frozen=True)
class Spec:
    """One accuracy run."""

    scenario: str = "default"
    seed: int = 1
    mode: str = LocalizerConfig().mode  # localizer mode
    controller: str = Params().controller  # navigator controller
    trial: str = "square"  # square: the square trial, `laps` laps; path: the path trial, then the turn sweep
    laps: float = 3.0  # square laps (a fraction: that many of its four goals)
    harness: str = "processes"  # processes, or in-process (one Zenoh session per service, one interpreter)
    # synthetic: the truth plus the scenario's VPS errors; camera: the sim's overhead frames, tags detected; onboard: the
    # robot's own camera's frames, the field's tags detected; camera+onboard: both cameras, each its own vps (in-process)
    vps: str = "synthetic"

    def navigator(self) -> dict[str, Any]:
        """The navigator's settings. Only the EKF modes carry a covariance the navigator's uncertainty
        checks can trust: dead reckoning never learns where the map is (its pose stays "unknown"), and
        the other comparison modes' sigmas are rules of thumb. Their runs drive with the checks off,
        as a robot without a camera that starts at the map's origin would."""
        gated = self.mode in ("ekf", "ekf_no_delay")
        ungated = {} if gated else {"max_position_sigma": math.inf, "max_heading_sigma": math.inf}
        return {"controller": self.controller, **ungated}

    def settings(self, rtf: float, vps: dict[str, Any] | None = None) -> Settings:
        return Settings.load(
            None,
            deployment={"scenario": self.scenario, "seed": self.seed},
            sim={"rtf": rtf, **self._camera()},
            vps=vps or {"source": self.vps.split("+")[0]},
            localizer={"mode": self.mode},
            navigator=self.navigator(),
        )

    def _camera(self) -> dict[str, Any]:
        """The sim's settings for the camera VPS (it renders the frames; the onboard camera's whenever the vps reads them)."""
        cams = self.vps.split("+")
        return {"camera": True, **({"onboard_camera": True} if "onboard" in cams else {})} if "camera" in cams else {}

    def args(self, rtf: float) -> list[str]:
        """The same settings as service command-line options."""
        sets = {
            "sim.rtf": rtf,
            **{f"sim.{k}": str(v).lower() for k, v in self._camera().items()},
            "vps.source": self.vps.split("+")[0],
            "localizer.mode": self.mode,
            **{f"navigator.{k}": v for k, v in self.navigator().items()},
        }
        options = [a for k, v in sets.items() for a in ("--set", f"{k}={v}")]
        return ["--scenario", self.scenario, "--seed", str(self.seed), *options]


@dataclass
class Run:
    """A finished accuracy run."""

    spec: Spec
    rtf: float
    settings: Settings = field(repr=False)
    trial: Trial = field(repr=False)
    overruns: int  # times the sim fell behind and dropped time
    wall: float  # [s] wall time of the driving

    @property
    def pose(self) -> Score:
        return score(self.trial.rec.series("pose"), self.trial.rec.series("sim/truth"))

    @property
    def odom(self) -> Score:
        return score(self.trial.rec.series("odom"), self.trial.rec.series("sim/truth"))

    @property
    def failures(self) -> list[TrialGoal]:
        return [g for g in self.trial.goals if g.result != GoalResult.SUCCEEDED]


def _drive(spec: Spec) -> Callable[[Robot, list[TrialGoal], float], None]:
    if spec.trial == "square":
        return lambda bot, goals, rtf: trials.square(bot, goals, rtf, spec.laps)

    def path_then_turns(bot: Robot, goals: list[TrialGoal], rtf: float) -> None:
        trials.path(bot, goals, rtf)
        trials.turns(bot, goals, rtf)

    return path_then_turns


@contextmanager
def _stack(spec: Spec, rtf: float, settings: Settings, log_dir: Path) -> Iterator[tuple[str, Callable[[], None]]]:
    """The stack of the spec, up; yields its endpoint and a check that raises if a process died."""
    if spec.harness == "processes":
        with ProcStack(("r1",), services.NAMES, log_dir, spec.args(rtf)) as procs:
            yield procs.endpoint, procs.check
    else:
        with Router() as router:
            stack = InProcessStack(settings, router.endpoint).start()
            stacks = [stack]
            if spec.vps == "camera+onboard":  # the second camera's own vps
                onboard = spec.settings(rtf, vps={"source": "onboard", "name": "onboard"})
                stacks.append(InProcessStack(onboard, router.endpoint, ["vps"]).start())
            try:
                yield router.endpoint, lambda: None
            finally:
                for s in reversed(stacks):
                    s.stop()


def run(spec: Spec, rtf: float, log_dir: Path) -> Run:
    """Start the stack of `spec` at `rtf`, wait for the warm-up, drive the trial; service logs go to `log_dir`."""
    settings = spec.settings(rtf)
    with _stack(spec, rtf, settings, log_dir) as (endpoint, check):
        with Robot("r1", endpoint, lease=False) as bot:
            trial = Trial(Recorder(bot.client))
            diag = bot.client.latest("diag/sim")
            trials.wait_ready(bot, rtf)
            w0 = time.monotonic()
            _drive(spec)(bot, trial.goals, rtf)
            wall = time.monotonic() - w0
            check()
            end = trial.rec.msgs["sim/truth"][-1].t
            overruns = diag.wait(lambda d: d.t >= end, timeout=DIAG_WAIT).counters.get("overruns", 0)
    return Run(spec, rtf, settings, trial, overruns, wall)


def replay(run: Run, modes: Sequence[str]) -> dict[str, Score]:
    """Every mode fed offline with the run's own streams, scored against its truth."""
    rec, scen = run.trial.rec, run.settings.scenario
    outage = None
    if scen.vps_outage_start is not None:
        outage = (scen.vps_outage_start, scen.vps_outage_start + scen.vps_outage_duration)
    base = run.settings.section("localizer", LocalizerConfig)
    out = {}
    for mode in modes:
        loc = make_mode(msgspec.structs.replace(base, mode=mode), run.settings.robot)
        out[mode] = evaluate(
            loc,
            odom=rec.msgs["odom"],
            fixes=rec.fixes(),
            truth=rec.msgs["sim/truth"],
            imu=rec.msgs["sensors/imu"],
            compass=rec.msgs["sensors/compass"],
            warmup=trials.WARMUP,
            outage=outage,
        )
    return out


@dataclass(frozen=True)
class Summary:
    """What the tables need of a run (the recording itself is let go)."""

    spec: Spec
    rtf: float
    pose: Score
    odom: Score
    errors: dict[str, list[float]]  # goal kind -> truth error of each succeeded goal ([m], turns [rad])
    durations: dict[str, list[float]]  # goal kind -> [s] of each succeeded goal
    goal_rmse: list[float]  # [m] the fused pose's RMSE over each succeeded goal
    goals: int  # goals sent
    failures: list[str]  # "result: message" of each goal that did not succeed
    overruns: int
    wall: float  # [s]
    replay: dict[str, Score] = field(default_factory=dict)  # mode -> offline score on this run's streams


def summarise(r: Run, modes: Sequence[str] = ()) -> Summary:
    """The run's scores, goal errors and, for `modes`, the offline replays."""
    kinds = ("point", "path", "turn")
    return Summary(
        spec=r.spec,
        rtf=r.rtf,
        pose=r.pose,
        odom=r.odom,
        errors={k: r.trial.errors(k) for k in kinds},
        durations={k: r.trial.durations(k) for k in kinds},
        goal_rmse=_goal_rmse(r),
        goals=len(r.trial.goals),
        failures=[f"{g.result}: {g.message}" for g in r.failures],
        overruns=r.overruns,
        wall=r.wall,
        replay=replay(r, modes) if modes else {},
    )


def _goal_rmse(r: Run) -> list[float]:
    rec = r.trial.rec
    t, pos, _ = rec.truth().errors(rec.series("pose"))
    return [rms(pos[(t >= g.t_start) & (t <= g.t_end)]) for g in r.trial.goals if g.result == GoalResult.SUCCEEDED]
