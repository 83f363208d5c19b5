"""`zenav ros2`: a ROS 2 node on rmw_zenoh for one robot, until Ctrl-C.

Publishes odometry, the fused pose, the map -> odom -> base_link transforms and the
navigator's state, with --image the camera's frames; takes cmd_vel, initialpose, goal_pose,
NavigateToPose and FollowWaypoints goals; through the router the stack and the ROS 2 nodes
(RMW_IMPLEMENTATION=rmw_zenoh_cpp) both reach. Needs the `ros2` extra (--image also `camera`).
Exit codes: 0 stopped, 2 bad arguments, a bad config or an extra missing, 3 no router.
"""

from __future__ import annotations

import argparse
import os
import re
import sys

from zenav.cli.checks import Failed, fail
from zenav.cli.main import EXIT_OK, EXIT_USAGE
from zenav.cli.session import open_bus, robot_id
from zenav.common import extras
from zenav.common.app import deployment_args, settings_from_args, stop_on_signals
from zenav.common.config import Camera, ConfigError

DISTROS = ("humble", "jazzy", "kilted")  # as tools/rmw_zenoh.py STORES (not imported here: it needs the extra)
ROS_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")  # a ROS node name
NAMESPACE = re.compile(r"^/?([A-Za-z][A-Za-z0-9_]*/?)*$")  # a ROS namespace


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("ros2", help="a ROS 2 node on rmw_zenoh: odom, pose, /tf, nav state out; cmd_vel, initialpose, goals in")
    deployment_args(p)
    p.add_argument(
        "--domain", type=int, default=os.environ.get("ROS_DOMAIN_ID") or "0", help="ROS domain id (env ROS_DOMAIN_ID; default 0)"
    )
    p.add_argument(
        "--distro",
        default=os.environ.get("ROS_DISTRO") or DISTROS[1],
        help=f"ROS 2 distro of the other nodes: {', '.join(DISTROS)} (env ROS_DISTRO; default {DISTROS[1]})",
    )
    p.add_argument("--node", default="zenav_bridge", help="ROS node name (default zenav_bridge)")
    p.add_argument("--namespace", default="", help="ROS namespace of the node and its topics, e.g. /r1 (default none)")
    p.add_argument(
        "--image",
        action="store_true",
        help="also publish the overhead camera's frames on camera/image_raw, camera/camera_info ([camera] intrinsics; zenav[camera])",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    extras.require("rosbags", "the ROS 2 bridge")  # the optional package (zenav[ros2]): main prints the one line
    from zenav.tools.rmw_zenoh import Wire
    from zenav.tools.ros2bridge import Bridge

    try:
        robot = robot_id(args)
        if not ROS_NAME.match(args.node):
            raise Failed(EXIT_USAGE, f"--node {args.node!r} is not a ROS node name (a letter, then letters, digits, _)")
        if not NAMESPACE.match(args.namespace):
            raise Failed(EXIT_USAGE, f"--namespace {args.namespace!r} is not a ROS namespace (names of letters, digits, _ joined by /)")
        if not 0 <= args.domain <= 232:
            raise Failed(EXIT_USAGE, f"--domain {args.domain} must be 0..232")
        if args.distro.lower() not in DISTROS:
            raise Failed(EXIT_USAGE, f"--distro (or ROS_DISTRO) {args.distro!r}: expected one of {', '.join(DISTROS)}")
        wire = Wire(args.domain, args.distro, args.node, args.namespace)
        camera = None
        if args.image:
            extras.require("cv2", "--image", "camera")
            try:
                camera = settings_from_args(args).section("camera", Camera)
            except ConfigError as e:
                raise Failed(EXIT_USAGE, str(e)) from None
        bus = open_bus(args)
    except Failed as e:
        return fail("ros2", e)
    done = stop_on_signals()
    bridge = Bridge(bus, robot, wire, camera).start()
    try:
        for endpoint, key in bridge.keys().items():
            print(f"{endpoint:<44} {key}", file=sys.stderr)
        print(
            f"ROS 2 node {wire.name(args.node)} ({wire.distro}) on domain {args.domain} for robot {robot}; Ctrl-C to stop",
            file=sys.stderr,
            flush=True,
        )
        done.wait()
    finally:
        bridge.stop()
        bus.close()
    print(", ".join(f"{k}: {v}" for k, v in bridge.counts.items()), file=sys.stderr)
    return EXIT_OK
