"""The localizer's correction applied to odometry: the composition, pairing by t, order and restarts."""

import math

import pytest

from zenav.services.navigator.correction import Paired, Pairing, compose, correction, inverse

FRAME = (1.0, -0.5, 0.7)  # the odometry's frame in the map frame


def close(a, b):
    return a == pytest.approx(b, abs=1e-12)


def in_odom(pose):
    """A map-frame pose as the odometry sees it."""
    return compose(inverse(FRAME), pose)


def test_compose_and_inverse():
    a, b = (1.0, 2.0, math.pi / 2), (0.5, 0.0, 0.1)
    assert close(compose(a, b), (1.0, 2.5, math.pi / 2 + 0.1))  # b's x is along a's heading, y up
    assert close(compose(a, inverse(a)), (0.0, 0.0, 0.0))
    assert close(compose(inverse(a), a), (0.0, 0.0, 0.0))


def test_the_correction_takes_the_odom_sample_onto_the_pose():
    pose = (0.3, 0.4, -2.0)
    odom = in_odom(pose)
    assert close(correction(pose, odom), FRAME)
    assert close(compose(correction(pose, odom), odom), pose)


def test_a_pose_pairs_with_the_odom_sample_of_its_t_and_corrects_the_later_ones():
    p = Pairing()
    assert p.on_odom(0.01, in_odom((0.0, 0.0, 0.0))) is None  # no correction yet
    assert p.on_odom(0.02, in_odom((0.1, 0.0, 0.0))) is None
    assert p.on_pose(0.01, (0.0, 0.0, 0.0), "pose 1") == Paired.PAIRED  # the sample of 0.01, not the newest
    assert close(p.correction, FRAME) and p.pose == "pose 1" and p.t == 0.01
    assert close(p.on_odom(0.03, in_odom((0.2, 0.1, 0.3))), (0.2, 0.1, 0.3))


def test_a_pose_before_its_odom_sample_pairs_when_the_sample_comes():
    p = Pairing()
    p.on_odom(0.01, in_odom((0.0, 0.0, 0.0)))
    assert p.on_pose(0.02, (0.5, 0.0, 0.0), "pose 2") == Paired.WAITING
    assert p.correction is None
    assert close(p.on_odom(0.02, in_odom((0.5, 0.0, 0.0))), (0.5, 0.0, 0.0))  # paired on arrival, then applied
    assert p.t == 0.02 and p.pose == "pose 2"


def test_a_waiting_pose_whose_sample_was_skipped_pairs_with_the_odometry_between():
    p = Pairing()
    p.on_odom(0.01, (0.0, 0.0, 0.0))
    assert p.on_pose(0.02, (1.0, 0.0, 0.0), "skipped") == Paired.WAITING
    assert close(p.on_odom(0.05, (0.4, 0.0, 0.0)), (1.3, 0.0, 0.0))  # odom at 0.02 was 0.1: correction +0.9
    assert p.t == 0.02 and p.pose == "skipped"


def test_a_pose_of_a_skipped_sample_pairs_with_the_odometry_between():
    p = Pairing()
    p.on_odom(0.01, (0.0, 0.0, 3.1))
    p.on_odom(0.03, (0.2, 0.2, -3.1))  # turned through pi, not back round
    assert p.on_pose(0.02, (5.0, 5.0, 0.0), "between") == Paired.PAIRED
    assert close(p.correction, correction((5.0, 5.0, 0.0), (0.1, 0.1, 3.1 + (math.tau - 6.2) / 2)))


def test_a_waiting_pose_with_no_sample_before_it_is_dropped():
    p = Pairing()
    p.on_pose(0.02, (0.0, 0.0, 0.0), "first")
    assert p.on_odom(0.03, (0.0, 0.0, 0.0)) is None and p.correction is None


def test_a_fix_jumps_the_correction_from_the_next_sample():
    p = Pairing()
    p.on_odom(0.01, (0.0, 0.0, 0.0))
    p.on_pose(0.01, (0.0, 0.0, 0.0), "before")
    assert close(p.on_odom(0.02, (0.1, 0.0, 0.0)), (0.1, 0.0, 0.0))
    p.on_pose(0.02, (0.1, 0.05, 0.0), "fixed")  # a fix moved the estimate 5 cm left
    assert close(p.on_odom(0.03, (0.2, 0.0, 0.0)), (0.2, 0.05, 0.0))


def test_out_of_order_poses_and_odom_samples_are_refused():
    p = Pairing()
    for t in (0.01, 0.02, 0.03):
        p.on_odom(t, (t, 0.0, 0.0))
    assert p.on_pose(0.02, (0.0, 0.0, 0.0), "2") == Paired.PAIRED
    assert p.on_pose(0.01, (9.0, 9.0, 0.0), "1") == Paired.OUT_OF_ORDER
    assert p.pose == "2"
    with pytest.raises(ValueError, match="0.015"):
        p.on_odom(0.015, (0.0, 0.0, 0.0))
    assert close(p.on_odom(0.04, (0.04, 0.0, 0.0)), (0.02, 0.0, 0.0))  # the correction held


def test_a_pose_whose_sample_is_gone_is_unpaired():
    p = Pairing(keep=3)
    for k in range(1, 6):
        p.on_odom(k / 100, (0.0, 0.0, 0.0))
    assert p.on_pose(0.01, (0.0, 0.0, 0.0), "old") == Paired.UNPAIRED  # kept: 0.03 to 0.05
    assert p.on_pose(0.03, (0.0, 0.0, 0.0), "kept") == Paired.PAIRED


def test_a_restart_forgets_everything():
    p = Pairing()
    p.on_odom(50.0, (0.0, 0.0, 0.0))
    p.on_pose(50.0, (1.0, 0.0, 0.0), "before")
    p.reset()
    assert p.correction is None and p.pose is None and p.t is None
    assert p.on_odom(0.01, (0.0, 0.0, 0.0)) is None  # t back near 0: no out-of-order
    assert p.on_pose(0.01, (0.0, 0.0, 0.0), "after") == Paired.PAIRED
