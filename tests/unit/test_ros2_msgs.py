"""zenav poses as ROS 2 messages, checked with a CDR reader written here (not the library that encodes)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from zenav.common import messages as m
from zenav.tools import ros2_msgs as rm
from zenav.tools.rmw_zenoh import Wire

COV = (0.01, 0.002, 0.003, 0.002, 0.02, 0.004, 0.003, 0.004, 0.05)
POSE = m.Pose(t=12.25, x=1.5, y=-2.0, theta=2.5, v=0.3, omega=-0.4, cov=COV)


class CdrReader:
    """XCDR1 little endian (encapsulation 00 01 00 00): each primitive aligned to its size from the data's start."""

    def __init__(self, data: bytes) -> None:
        assert data[:4] == b"\x00\x01\x00\x00", data[:4].hex()
        self.data, self.pos = data[4:], 0

    def _read(self, fmt: str) -> tuple:
        size = struct.calcsize(fmt[-1])
        self.pos += -self.pos % size
        out = struct.unpack_from("<" + fmt, self.data, self.pos)
        self.pos += struct.calcsize("<" + fmt)
        return out

    def int32(self) -> int:
        return self._read("i")[0]

    def uint32(self) -> int:
        return self._read("I")[0]

    def doubles(self, n: int) -> tuple[float, ...]:
        return self._read(f"{n}d")

    def string(self) -> str:
        n = self.uint32()  # length with the terminating NUL
        raw = self.data[self.pos : self.pos + n]
        self.pos += n
        assert raw.endswith(b"\x00")
        return raw[:-1].decode()

    def done(self) -> bool:
        return self.pos == len(self.data)


@pytest.fixture(scope="module")
def wire():
    return Wire()


def test_odometry_decoded_field_by_field(wire):
    data = wire.serialize(rm.odometry(wire.types(), POSE, 1_700_000_000.123456789), "nav_msgs/msg/Odometry")
    r = CdrReader(data)
    sec, nanosec = r.int32(), r.uint32()
    assert sec == 1_700_000_000 and abs(nanosec - 123_456_789) < 1_000  # float seconds: sub-microsecond rounding
    assert r.string() == "map" and r.string() == "base_link"
    assert r.doubles(3) == (1.5, -2.0, 0.0)
    qx, qy, qz, qw = r.doubles(4)
    assert (qx, qy) == (0.0, 0.0) and (qz, qw) == pytest.approx((math.sin(1.25), math.cos(1.25)))
    cov = np.array(r.doubles(36)).reshape(6, 6)
    for i, a in enumerate((0, 1, 5)):
        for j, b in enumerate((0, 1, 5)):
            assert cov[a, b] == COV[3 * i + j]
    assert np.count_nonzero(cov) == 9
    assert r.doubles(3) == (0.3, 0.0, 0.0)  # linear twist, base_link
    assert r.doubles(3) == (0.0, 0.0, -0.4)  # angular twist
    assert r.doubles(36) == (0.0,) * 36
    assert r.done()


def test_pose_with_covariance_stamped_decoded(wire):
    r = CdrReader(wire.serialize(rm.pose_with_covariance(wire.types(), POSE, 12.25), "geometry_msgs/msg/PoseWithCovarianceStamped"))
    assert (r.int32(), r.uint32(), r.string()) == (12, 250_000_000, "map")
    assert r.doubles(3) == (1.5, -2.0, 0.0)
    assert rm.yaw(wire.types()["geometry_msgs/msg/Quaternion"](*r.doubles(4))) == pytest.approx(2.5)
    assert np.array(r.doubles(36)).reshape(6, 6)[5, 5] == 0.05 and r.done()


def test_tf_message_decoded(wire):
    types = wire.types()
    msg = rm.tf_message(types, [rm.transform(types, 3.5, "map", "odom", (0.5, -0.25, -math.pi / 2))])
    r = CdrReader(wire.serialize(msg, "tf2_msgs/msg/TFMessage"))
    assert r.uint32() == 1  # sequence length
    assert (r.int32(), r.uint32(), r.string(), r.string()) == (3, 500_000_000, "map", "odom")
    assert r.doubles(3) == (0.5, -0.25, 0.0)
    assert r.doubles(4) == pytest.approx((0.0, 0.0, -math.sqrt(0.5), math.sqrt(0.5)))
    assert r.done()


@pytest.mark.parametrize(
    ("pose", "odom"),
    [((1.0, 2.0, 0.5), (1.0, 2.0, 0.5)), ((3.0, -1.0, 2.9), (0.4, 0.7, -3.0)), ((0.0, 0.0, 0.0), (1.0, 0.0, math.pi / 2))],
)
def test_map_to_odom_composed_with_odom_gives_the_pose(pose, odom):
    mx, my, mth = rm.map_to_odom(pose, odom)
    c, s = math.cos(mth), math.sin(mth)
    x, y = mx + c * odom[0] - s * odom[1], my + s * odom[0] + c * odom[1]
    assert (x, y) == pytest.approx(pose[:2])
    assert math.remainder(mth + odom[2] - pose[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_goal_from_pose_stamped(wire):
    types = wire.types()
    point = types["geometry_msgs/msg/Point"](x=1.0, y=-0.5, z=0.0)
    pose = types["geometry_msgs/msg/Pose"](position=point, orientation=rm.quaternion(types, -2.0))
    msg = types["geometry_msgs/msg/PoseStamped"](header=rm.header(types, 1.0, "map"), pose=pose)
    frame, x, y, heading = rm.goal(wire.deserialize(wire.serialize(msg, "geometry_msgs/msg/PoseStamped"), "geometry_msgs/msg/PoseStamped"))
    assert (frame, x, y) == ("map", 1.0, -0.5) and heading == pytest.approx(-2.0)


def field_map(**changes) -> m.FieldMap:
    box = {"name": "box", "polygon": [[0.5, -0.1], [0.7, -0.1], [0.7, 0.1], [0.5, 0.1]]}
    base = dict(t=3.0, enabled=True, x_min=-1.0, x_max=1.0, y_min=-0.5, y_max=0.5, obstacles=[box, {"circle": [-0.5, 0.0, 0.1]}])
    return m.FieldMap(**{**base, "radius": 0.1, "margin": 0.05, **changes})


def test_the_field_as_grid_cells_inside_obstacles_occupied():
    x0, y0, cells = rm.field_cells(field_map())
    assert (x0, y0, cells.shape) == (-1.0, -0.5, (50, 100))  # 2 m x 1 m in 2 cm cells, row 0 at y_min

    def at(x: float, y: float) -> int:
        return int(cells[int((y - y0) / rm.MAP_RESOLUTION), int((x - x0) / rm.MAP_RESOLUTION)])

    assert [at(0.6, 0.0), at(0.69, 0.09), at(-0.5, 0.0), at(-0.5, 0.09)] == [rm.OCCUPIED] * 4
    assert [at(0.75, 0.0), at(0.6, 0.15), at(-0.5, 0.13), at(0.0, 0.0)] == [rm.FREE] * 4
    assert int((cells == rm.OCCUPIED).sum()) == pytest.approx(100 + math.pi * 25, rel=0.1)  # the box's 10x10 cells, the disc's


def test_a_field_without_bounds_is_drawn_round_its_obstacles_and_an_empty_one_not_at_all():
    x0, y0, cells = rm.field_cells(field_map(enabled=False))
    assert (x0, y0) == pytest.approx((-0.6 - rm.MAP_PAD, -0.1 - rm.MAP_PAD))
    assert cells.shape == (round((0.2 + 2 * rm.MAP_PAD) / rm.MAP_RESOLUTION), round((1.3 + 2 * rm.MAP_PAD) / rm.MAP_RESOLUTION))
    assert rm.field_cells(field_map(enabled=False, obstacles=[])) is None


def test_the_map_round_trips_through_cdr(wire):
    grid = rm.occupancy_grid(wire.types(), field_map(), 1_700_000_000.5)
    back = wire.deserialize(wire.serialize(grid, "nav_msgs/msg/OccupancyGrid"), "nav_msgs/msg/OccupancyGrid")
    assert (back.header.frame_id, back.info.width, back.info.height) == ("map", 100, 50)
    assert back.info.resolution == pytest.approx(rm.MAP_RESOLUTION)
    assert (back.info.origin.position.x, back.info.origin.position.y) == (-1.0, -0.5)
    assert np.array_equal(np.asarray(back.data), rm.field_cells(field_map())[2].reshape(-1))


def test_the_map_is_sent_again_only_when_the_field_changes(wire):
    from zenav.tools import ros2_out as ro

    conv = ro.Converter(wire.types())
    conv.feed(m.Clock(t=1.0, wall=1_700_000_000.0))
    sent = [[topic for topic, _ in conv.feed(field_map(t=t, **change))] for t, change in [(2.0, {}), (3.0, {}), (4.0, {"x_max": 2.0})]]
    assert sent == [["map"], [], ["map"]]
