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


# Known hashes: rmw_zenoh's design doc (AddTwoInts); a ROS 2 install's share/*.json as quoted by others (the rest).
FIBONACCI = "action_tutorials_interfaces/action/Fibonacci"
SERVICE_HASHES = {
    "action_msgs/srv/CancelGoal": "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a",
    "action_msgs/msg/GoalStatusArray": "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e",
    f"{FIBONACCI}_SendGoal": "RIHS01_a0603060ed69fe2dfbd1a6f3b982a1749957ef346e4a4d2b311a05e305ec37bb",
    f"{FIBONACCI}_GetResult": "RIHS01_8b47e383f1e31f6d8df6417ab54957e7d5ea24dad315646ad711ac3fdea81d58",
    f"{FIBONACCI}_FeedbackMessage": "RIHS01_50fc26b9cac313652ecbeab3adf9b5414d59fd4d4d5f9058ddcc7525169927f1",
}


def test_service_and_action_hashes_match_the_known_ones():
    from rosbags.typesys.base import Nodetype

    from zenav.tools import ros2_types as rt

    wire = rz.Wire()
    i64 = (Nodetype.BASE, ("int64", 0))
    srv = "example_interfaces/srv/AddTwoInts"
    wire.register({f"{srv}_Request": ([], [("a", i64), ("b", i64)]), f"{srv}_Response": ([], [("sum", i64)])})
    wire.register_service(srv)
    assert wire.type_hash(srv) == "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
    rt.register(wire)
    rt.register_action(wire, FIBONACCI, "int32 order", "int32[] sequence", "int32[] partial_sequence")
    assert {t: wire.type_hash(t) for t in SERVICE_HASHES} == SERVICE_HASHES
    ep = wire.endpoint("SS", "navigate_to_pose/_action/send_goal", f"{rt.NAVIGATE}_SendGoal")
    assert wire.key(ep).startswith("0/navigate_to_pose/_action/send_goal/nav2_msgs::action::dds_::NavigateToPose_SendGoal_/RIHS01_")
    assert wire.any_hash_key(ep) == "0/navigate_to_pose/_action/send_goal/nav2_msgs::action::dds_::NavigateToPose_SendGoal_/*"


def test_navigate_to_pose_per_distro():
    from zenav.tools import ros2_types as rt

    fields = {}
    for distro in ("humble", "jazzy", "kilted"):
        wire = rz.Wire(distro=distro)
        rt.register(wire)
        fields[distro] = list(wire.types()[f"{rt.NAVIGATE}_Result"].__dataclass_fields__)[:-1]  # the last: __msgtype__
    assert fields == {"humble": ["result"], "jazzy": ["error_code", "error_msg"], "kilted": ["error_code", "error_msg"]}


def test_transient_local_qos_and_distros():
    wire = rz.Wire()
    ep = wire.endpoint("MP", "a/_action/status", "action_msgs/msg/GoalStatusArray", depth=1, durability=rz.TRANSIENT_LOCAL)
    assert wire.token("z", ep, 5).endswith("/:1:,1:,:,:,,")
    assert rz.distro_of(None) == "jazzy" and rz.distro_of("Humble") == "humble" and rz.distro_of("kilted") == "kilted"
    with pytest.raises(ValueError, match="rolling"):
        rz.distro_of("rolling")
