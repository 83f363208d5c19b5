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

A service (SS) is a queryable on its key; its type name is the service's
(`example_interfaces::srv::dds_::AddTwoInts_`, no Request_/Response_) and so is its hash; a
reply carries the request's sequence number and client GID back. An action is three
services (`<name>/_action/send_goal`, `cancel_goal`, `get_result`) and two topics
(`_action/feedback`, `_action/status`, the latter transient local).

Humble's rmw_zenoh has no type hashes: its keys carry `TypeHashNotSupported`.
Payloads are CDR (little endian, with the 4-byte encapsulation header), serialized by
`rosbags` from its ROS 2 message definitions, which also give the RIHS01 type hashes
(REP-2016). A service's hash is that of a structure of its request, response and event
(`service_msgs/ServiceEventInfo info`, `Request[<=1] request`, `Response[<=1] response`),
checked against rmw_zenoh's `AddTwoInts` example.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass
from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore

ADMIN_SPACE = "@ros2_lv"
NO_HASH = "TypeHashNotSupported"  # what Humble's rmw_zenoh puts where the type hash goes
STORES = {"humble": Stores.ROS2_HUMBLE, "jazzy": Stores.ROS2_JAZZY, "kilted": Stores.ROS2_KILTED}
DEFAULT_DISTRO = "jazzy"
GID_SIZE = 16
TRANSIENT_LOCAL = 1  # rmw_qos_durability_policy_e
EVENT_INFO = "service_msgs/msg/ServiceEventInfo"


def mangle(name: str) -> str:
    """A ROS name as one key chunk: `/` -> `%`; empty (or `/`) is `%`."""
    return name.replace("/", "%") if name.strip("/") else "%"


def dds_type_name(ros_type: str) -> str:
    """`nav_msgs/msg/Odometry` -> `nav_msgs::msg::dds_::Odometry_` (the type name rmw_zenoh puts in keys)."""
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def qos(depth: int, durability: int | None = None) -> str:
    """The token's QoS chunk of a keep-last(`depth`) endpoint, the rest at rmw_zenoh's defaults (reliable, volatile)."""
    return f":{'' if durability is None else durability}:,{depth}:,:,:,,"


def distro_of(value: str | None) -> str:
    """The distro to speak: `value` (e.g. $ROS_DISTRO) if given, else the default; ValueError if not one known."""
    distro = (value or DEFAULT_DISTRO).strip().lower()
    if distro not in STORES:
        raise ValueError(f"distro {value!r}: expected one of {', '.join(STORES)}")
    return distro


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

    kind: str  # MP, MS or SS
    topic: str  # fully qualified ROS name, e.g. /r1/pose
    ros_type: str  # e.g. nav_msgs/msg/Odometry, or a service's: nav2_msgs/action/NavigateToPose_SendGoal
    type_hash: str
    depth: int  # keep-last depth announced in the token
    durability: int | None = None  # None: volatile (the default); TRANSIENT_LOCAL


class Wire:
    """Names and payloads for one ROS node on one domain and distro."""

    def __init__(self, domain: int = 0, distro: str = DEFAULT_DISTRO, node: str = "zenav_bridge", namespace: str = "") -> None:
        self.domain, self.distro, self.node = domain, distro_of(distro), node
        self.namespace = "/" + namespace.strip("/") if namespace.strip("/") else ""
        self.store = get_typestore(STORES[self.distro])  # this Wire's own: registering types changes no other
        if self.distro != "humble":  # char[16] is uint8[16] in the IDL that REP-2016 hashes (rosbags keeps char)
            consts, fields = self.store.fielddefs[EVENT_INFO]
            u8: Any = (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), GID_SIZE))
            self.store.fielddefs[EVENT_INFO] = (consts, [(n, u8 if n == "client_gid" else d) for n, d in fields])

    def register(self, defs: dict[str, Any]) -> None:
        """Add message types (rosbags Typesdict: name -> (constants, fields)) this store lacks."""
        self.store.register({name: d for name, d in defs.items() if name not in self.store.fielddefs})

    def register_service(self, srv: str) -> None:
        """Add the structure a service's hash is taken over (its `_Request` and `_Response` must be registered)."""
        if self.distro == "humble" or srv in self.store.fielddefs:
            return
        req, resp, event = (Nodetype.NAME, f"{srv}_Request"), (Nodetype.NAME, f"{srv}_Response"), f"{srv}_Event"
        info = (Nodetype.NAME, EVENT_INFO)
        self.register(
            {event: ([], [("info", info), ("request", (Nodetype.SEQUENCE, (req, 1))), ("response", (Nodetype.SEQUENCE, (resp, 1)))])}
        )
        self.register({srv: ([], [("request_message", req), ("response_message", resp), ("event_message", (Nodetype.NAME, event))])})

    def type_hash(self, ros_type: str) -> str:
        """The RIHS01 hash rmw_zenoh puts in keys (Humble: TypeHashNotSupported)."""
        return NO_HASH if self.distro == "humble" else self.store.hash_rihs01(ros_type)

    def name(self, topic: str) -> str:
        """A topic's fully qualified name: relative names go under the node's namespace."""
        return topic if topic.startswith("/") else f"{self.namespace}/{topic}"

    def endpoint(self, kind: str, topic: str, ros_type: str, depth: int = 10, durability: int | None = None) -> Endpoint:
        """A publisher (MP), subscription (MS) or service server (SS) of this node."""
        return Endpoint(kind, self.name(topic), ros_type, self.type_hash(ros_type), depth, durability)

    def key(self, ep: Endpoint) -> str:
        """The key expression its samples travel on."""
        return f"{self.domain}/{ep.topic.strip('/')}/{dds_type_name(ep.ros_type)}/{ep.type_hash}"

    def any_hash_key(self, ep: Endpoint) -> str:
        """Its key with any type hash: what a subscription or service listens on, so that a peer whose hash
        differs (another distro's, a definition that changed) still reaches it; its type name must match."""
        return self.key(ep).rsplit("/", 1)[0] + "/*"

    def node_token(self, zid: str, node_id: int = 0) -> str:
        """The liveliness token announcing this node in the ROS graph."""
        return f"{ADMIN_SPACE}/{self.domain}/{zid}/{node_id}/{node_id}/NN/%/{mangle(self.namespace)}/{self.node}"

    def token(self, zid: str, ep: Endpoint, entity_id: int, node_id: int = 0) -> str:
        """The liveliness token announcing one endpoint of this node."""
        head = f"{ADMIN_SPACE}/{self.domain}/{zid}/{node_id}/{entity_id}/{ep.kind}/%/{mangle(self.namespace)}/{self.node}"
        return f"{head}/{mangle(ep.topic)}/{dds_type_name(ep.ros_type)}/{ep.type_hash}/{qos(ep.depth, ep.durability)}"

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
