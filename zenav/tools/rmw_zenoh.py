"""The wire of ROS 2's rmw_zenoh: key expressions, graph liveliness tokens, sample attachments, CDR.

Follows rmw_zenoh's docs/design.md (ros2/rmw_zenoh, rolling and jazzy, rmw_zenoh_cpp 0.2+)
and its liveliness_utils.cpp (`qos_to_keyexpr`):

- topic key: `<domain_id>/<fully qualified name without the leading slash>/<DDS type name>/<type hash>`,
  e.g. `0/chatter/std_msgs::msg::dds_::String_/RIHS01_df66...`;
- graph tokens: `@ros2_lv/<domain_id>/<session id>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>`
  and, for a publisher (MP) or subscription (MS), `/<topic>/<type name>/<type hash>/<qos>` after it,
  with every `/` in a name replaced by `%` (an empty name is `%`);
- attachment of every sample: sequence number (int64 LE), source timestamp [ns since the epoch]
  (int64 LE), GID length (one byte, 16), GID (16 bytes).

Humble's rmw_zenoh has no type hashes: its keys carry `TypeHashNotSupported`.
Payloads are CDR (little endian, with the 4-byte encapsulation header), serialized by
`rosbags` from its ROS 2 message definitions, which also give the RIHS01 type hashes (REP-2011).
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass
from typing import Any

from rosbags.typesys import Stores, get_typestore

ADMIN_SPACE = "@ros2_lv"
NO_HASH = "TypeHashNotSupported"  # what Humble's rmw_zenoh puts where the type hash goes
STORES = {"jazzy": Stores.ROS2_JAZZY, "humble": Stores.ROS2_HUMBLE}
GID_SIZE = 16


def mangle(name: str) -> str:
    """A ROS name as one key chunk: `/` -> `%`; empty (or `/`) is `%`."""
    return name.replace("/", "%") if name.strip("/") else "%"


def dds_type_name(ros_type: str) -> str:
    """`nav_msgs/msg/Odometry` -> `nav_msgs::msg::dds_::Odometry_` (the type name rmw_zenoh puts in keys)."""
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def qos(depth: int) -> str:
    """The token's QoS chunk of a reliable, volatile, keep-last(`depth`) endpoint (the rest at rmw_zenoh's defaults)."""
    return f"::,{depth}:,:,:,,"


def attachment(seq: int, stamp_ns: int, gid: bytes) -> bytes:
    """The attachment rmw_zenoh puts on each sample: sequence number, source time [ns], GID."""
    return struct.pack("<qqB", seq, stamp_ns, len(gid)) + gid


def parse_attachment(data: bytes) -> tuple[int, int, bytes]:
    """(sequence number, source time [ns], GID) of an attachment; ValueError if malformed."""
    if len(data) < 17 or len(data) != 17 + data[16]:
        raise ValueError(f"attachment of {len(data)} bytes is not seq, stamp, GID")
    seq, stamp, n = struct.unpack_from("<qqB", data)
    return seq, stamp, bytes(data[17 : 17 + n])


@dataclass(frozen=True)
class Endpoint:
    """One publisher (MP) or subscription (MS) of a ROS node, as rmw_zenoh names it."""

    kind: str  # MP or MS
    topic: str  # fully qualified ROS name, e.g. /r1/pose
    ros_type: str  # e.g. nav_msgs/msg/Odometry
    type_hash: str
    depth: int  # keep-last depth announced in the token


class Wire:
    """Names and payloads for one ROS node on one domain and distro."""

    def __init__(self, domain: int = 0, distro: str = "jazzy", node: str = "zenav_bridge", namespace: str = "") -> None:
        if distro not in STORES:
            raise ValueError(f"distro {distro!r}: expected one of {', '.join(STORES)}")
        self.domain, self.distro, self.node = domain, distro, node
        self.namespace = "/" + namespace.strip("/") if namespace.strip("/") else ""
        self.store = get_typestore(STORES[distro])

    def type_hash(self, ros_type: str) -> str:
        """The RIHS01 hash rmw_zenoh puts in keys (Humble: TypeHashNotSupported)."""
        return NO_HASH if self.distro == "humble" else self.store.hash_rihs01(ros_type)

    def name(self, topic: str) -> str:
        """A topic's fully qualified name: relative names go under the node's namespace."""
        return topic if topic.startswith("/") else f"{self.namespace}/{topic}"

    def endpoint(self, kind: str, topic: str, ros_type: str, depth: int = 10) -> Endpoint:
        """A publisher (MP) or subscription (MS) of this node."""
        return Endpoint(kind, self.name(topic), ros_type, self.type_hash(ros_type), depth)

    def key(self, ep: Endpoint) -> str:
        """The key expression its samples travel on."""
        return f"{self.domain}/{ep.topic.strip('/')}/{dds_type_name(ep.ros_type)}/{ep.type_hash}"

    def node_token(self, zid: str, node_id: int = 0) -> str:
        """The liveliness token announcing this node in the ROS graph."""
        return f"{ADMIN_SPACE}/{self.domain}/{zid}/{node_id}/{node_id}/NN/%/{mangle(self.namespace)}/{self.node}"

    def token(self, zid: str, ep: Endpoint, entity_id: int, node_id: int = 0) -> str:
        """The liveliness token announcing one endpoint of this node."""
        head = f"{ADMIN_SPACE}/{self.domain}/{zid}/{node_id}/{entity_id}/{ep.kind}/%/{mangle(self.namespace)}/{self.node}"
        return f"{head}/{mangle(ep.topic)}/{dds_type_name(ep.ros_type)}/{ep.type_hash}/{qos(ep.depth)}"

    def serialize(self, msg: Any, ros_type: str) -> bytes:
        """CDR bytes of a message (little endian, with the encapsulation header)."""
        return bytes(self.store.serialize_cdr(msg, ros_type))

    def deserialize(self, data: bytes, ros_type: str) -> Any:
        """A message from CDR bytes."""
        return self.store.deserialize_cdr(data, ros_type)

    def types(self) -> Any:
        """The message classes of this distro, by ROS type name."""
        return self.store.types


def gid(token: str) -> bytes:
    """A 16-byte GID for an endpoint, derived from its liveliness token (unique as the token is)."""
    return hashlib.blake2b(token.encode(), digest_size=GID_SIZE).digest()
