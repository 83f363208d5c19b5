"""rmw_zenoh's names: keys, liveliness tokens, attachments and type hashes, against rmw_zenoh's docs/design.md examples."""

from __future__ import annotations

import pytest

from zenav.tools import rmw_zenoh as rz

STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"  # std_msgs/msg/String, from the doc
TF_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"  # tf2_msgs/msg/TFMessage


def test_type_hashes_match_the_known_ones():
    wire = rz.Wire()
    assert wire.type_hash("std_msgs/msg/String") == STRING_HASH
    assert wire.type_hash("tf2_msgs/msg/TFMessage") == TF_HASH
    assert rz.Wire(distro="humble").type_hash("std_msgs/msg/String") == "TypeHashNotSupported"


def test_keys_as_the_doc_shows():
    wire = rz.Wire()
    assert wire.key(wire.endpoint("MP", "chatter", "std_msgs/msg/String")) == f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    ns = rz.Wire(domain=2, namespace="/robot1")
    assert ns.key(ns.endpoint("MP", "chatter", "std_msgs/msg/String")) == f"2/robot1/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    assert ns.key(ns.endpoint("MP", "/tf", "tf2_msgs/msg/TFMessage")) == f"2/tf/tf2_msgs::msg::dds_::TFMessage_/{TF_HASH}"


def test_tokens_as_the_doc_shows():
    zid = "8b20917502ee955ac4476e0266340d5c"
    wire = rz.Wire(domain=2, node="talker")
    assert wire.node_token(zid) == f"@ros2_lv/2/{zid}/0/0/NN/%/%/talker"
    ep = wire.endpoint("MP", "chatter", "std_msgs/msg/String", depth=7)
    assert wire.token(zid, ep, 10) == f"@ros2_lv/2/{zid}/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/{STRING_HASH}/::,7:,:,:,,"
    ns = rz.Wire(node="bridge", namespace="r1/")
    assert ns.node_token(zid).endswith("/NN/%/%r1/bridge")
    assert "/bridge/%r1%goal_pose/" in ns.token(zid, ns.endpoint("MS", "goal_pose", "geometry_msgs/msg/PoseStamped"), 3)


def test_attachment_layout():
    gid = rz.gid("@ros2_lv/0/x/0/1/MP/%/%/n/%t/a::msg::dds_::B_/h/::,10:,:,:,,")
    data = rz.attachment(7, 1_700_000_000_123_456_789, gid)
    assert len(data) == 8 + 8 + 1 + 16 and data[:8] == (7).to_bytes(8, "little") and data[16] == 16
    assert rz.parse_attachment(data) == (7, 1_700_000_000_123_456_789, gid)
    with pytest.raises(ValueError):
        rz.parse_attachment(data[:-1])


def test_names():
    assert rz.mangle("/r1/pose") == "%r1%pose" and rz.mangle("") == "%" and rz.mangle("/") == "%"
    assert rz.dds_type_name("nav_msgs/msg/Odometry") == "nav_msgs::msg::dds_::Odometry_"
    with pytest.raises(ValueError, match="distro"):
        rz.Wire(distro="kinetic")
