"""The offline trial: streams at the sensor rates, odometry from the service's core, faults, seeding."""

import math

import pytest

from zenav.bench.studies.harness import Trial, odometry_config
from zenav.bench.studies.localizer import pushed_table
from zenav.common.config import RobotConfig
from zenav.common.scenarios import PRESETS, Fault, scenario
from zenav.world.bodies import Disc


def forward(trial):
    return trial.bot.wheels(0.2, 0.0)


def test_streams_at_their_rates_and_aligned():
    trial = Trial(RobotConfig(), PRESETS["default"], seed=1)
    assert not trial.run(forward, 2.0)
    s = trial.streams
    assert len(s.truth) == len(s.imu) == len(s.odom) == 201 and trial.t == pytest.approx(2.0)
    assert [o.t for o in s.odom] == [x.t for x in s.truth] == [i.t for i in s.imu]
    assert [c.t for c in s.compass] == pytest.approx([k / 10 for k in range(21)])
    assert 14 <= len(s.fixes) <= 20 and [a for a, _ in s.fixes] == sorted(a for a, _ in s.fixes)
    assert all(a - f.t == pytest.approx(0.3, abs=0.031) for a, f in s.fixes)
    # encoders only: odometry follows the truth to within the wheel errors
    assert math.hypot(s.odom[-1].x - s.truth[-1].x, s.odom[-1].y - s.truth[-1].y) < 0.01
    assert s.odom[-1].v == pytest.approx(0.2, abs=0.06)


def test_controller_stops_the_trial():
    trial = Trial(RobotConfig(), PRESETS["default"], seed=1, camera=False)
    assert trial.run(lambda tr: None if tr.t >= 0.5 else forward(tr), 2.0)
    assert trial.t == pytest.approx(0.5) and trial.streams.fixes == []


def test_odometry_config_reaches_the_core():
    trial = Trial(RobotConfig(), PRESETS["default"], seed=1, odometry=odometry_config(heading_source="gyro"))
    assert trial.params.heading.source == "gyro"


def test_same_seed_same_streams():
    a, b, c = (Trial(RobotConfig(), PRESETS["harsh"], seed) for seed in (4, 4, 5))
    for trial in (a, b, c):
        trial.run(forward, 1.0)
    assert a.streams == b.streams and a.streams != c.streams


def test_scheduled_faults_act_on_the_streams():
    faults = (
        Fault(kind="gyro_dead", start=0.5, duration=0.5),
        Fault(kind="duplicate", start=0.0, duration=0.15),
        Fault(kind="encoder_frozen", start=1.0, duration=0.5),
    )
    sc = scenario("default", {"vps_drop": 0.0, "faults": faults})
    trial = Trial(RobotConfig(), sc, seed=1)
    trial.run(forward, 2.0)
    s = trial.streams
    assert not any(0.5 <= i.t < 1.0 for i in s.imu) and len(s.imu) == 201 - 50
    assert [f.t for _, f in s.fixes[:3]] == [0.0, 0.0, 0.1]  # fixes captured in the duplicate window sent twice
    theta = {o.t: o.theta for o in s.odom}
    assert theta[1.49] - theta[1.0] > 0.5  # the frozen left wheel turns the odometry left
    assert 1.5 not in theta  # released: the jump in the count is a reset, a new baseline


def test_a_robot_in_the_way_holds_the_trials_robot_while_its_encoders_count_on():
    trial = Trial(RobotConfig(), PRESETS["default"], seed=1, others={"r2": Disc(0.5, 0.0, 0.1)})
    assert not trial.run(forward, 3.0)  # 0.6 m at 0.2 m/s, but the other's body is 0.3 m ahead
    s = trial.streams
    assert s.truth[-1].x == pytest.approx(0.3, abs=0.005) and s.odom[-1].x > 0.5


def test_the_pushed_study_compares_slip_found_with_the_travel_trusted():
    rows = [line.split(" | ") for line in pushed_table(["default"], [1]).splitlines()[2:]]
    (found, found_max), (by_fixes, by_fixes_max), (trusted, trusted_max) = ((float(r[2]), float(r[3])) for r in rows)  # [cm]
    assert found < trusted and by_fixes < trusted  # RMSE
    assert found_max < trusted_max and by_fixes_max < trusted_max
