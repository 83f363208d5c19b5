"""Configuration: one TOML file per deployment, a section per service.

Every key has a typed default in code (the service's Config struct); the file
overrides what it names, and `zenav/data/default.toml` documents every key (a test
keeps the two equal). A bad or unknown key fails fast, naming the key and the
accepted range: `config: [motor] watchdog: Expected `float` > 0.0`.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import json
import logging
import os
import re
import sys
from dataclasses import dataclass
from importlib import resources
from typing import Annotated, Any, Literal, TypeVar

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib
import msgspec
from msgspec import Meta, Struct

from zenav.common import codec, fieldtags, geometry
from zenav.common import field as fieldmod
from zenav.common import messages as m
from zenav.common.keys import DEFAULT_CONNECT
from zenav.common.roles import ALL as SERVICES
from zenav.common.scenarios import Scenario, scenario

T = TypeVar("T")
_log = logging.getLogger("zenav")
OWN_SECTIONS = ("deployment", "robot", "scenario", "limits", "field")  # the sections Settings reads itself


class ConfigError(ValueError):
    """A configuration value that is missing, unknown, of the wrong type or out of range."""


class Deployment(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Where and as what this stack runs (also from env and CLI)."""

    robot: Annotated[str, Meta(pattern=m.ROBOT_ID_PATTERN)] = "r1"  # key prefix zenav/<robot>/
    connect: str = DEFAULT_CONNECT  # Zenoh router endpoint(s), comma-separated
    zenoh_mode: Literal["client", "peer"] = (
        "client"  # client: every message through the router; peer: services also link directly on loopback
    )
    clock: Literal["sim", "wall"] = "sim"  # follow the sim's `clock` topic, or the host clock
    scenario: str = "default"  # scenario preset (default, coarse, harsh)
    seed: Annotated[int, Meta(ge=0)] = 1  # seed of the run's random generators
    compose: tuple[str, ...] = ()  # services `zenav up` runs together in one process (small computers); () each its own
    # SCHED_FIFO priority of the robot's control loop (driver, odometry, localizer, navigator, motor, and the router
    # `zenav up` embeds): ahead of every normal process for a core; 0: the host's normal scheduling
    realtime: Annotated[int, Meta(ge=0, le=99)] = 0

    def __post_init__(self) -> None:
        unknown = [name for name in self.compose if name not in SERVICES]
        if unknown:
            raise ValueError(f"compose: not a service: {', '.join(map(repr, unknown))} (the services: {', '.join(SERVICES)})")


class RobotConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The robot's nominal geometry: what the stack believes, not what the world is."""

    wheel_diameter: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.0673  # [m] 2.65 in
    track_width: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.1156  # [m] wheel contact to contact
    ticks_per_rev: Annotated[int, Meta(ge=1, le=1000000)] | None = None  # None: the scenario's
    max_wheel_speed: Annotated[float, Meta(gt=0.0, le=1e3)] = 10.0  # [rad/s]
    imu_x: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0  # [m] the IMU ahead of the middle of the wheels' axle
    imu_y: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0  # [m] the IMU left of it
    radius: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.1  # [m] the footprint, a disc about the middle of the wheels' axle

    @property
    def wheel_radius(self) -> float:
        return self.wheel_diameter / 2.0


MESSAGE_HEADROOM = 64 << 10  # [bytes] a message's key, encoding and Zenoh's headers, beyond its payload and parameters


class Limits(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """What one input may cost a service: sizes checked before decoding, the queue's bounds, time's steps."""

    max_payload: Annotated[int, Meta(ge=1024, le=1 << 30)] = 1 << 20  # [bytes] larger payloads are refused undecoded
    max_params: Annotated[int, Meta(ge=256, le=1 << 30)] = 64 << 10  # [bytes] larger selector parameters are refused
    queue_items: Annotated[int, Meta(ge=16, le=10_000_000)] = 10_000  # [items] a service's input queue; more are dropped
    queue_bytes: Annotated[int, Meta(ge=1 << 16, le=1 << 34)] = 64 << 20  # [bytes] payload bytes queued; more are dropped
    future_stamp: Annotated[float, Meta(ge=0.0, le=60.0)] = 0.1  # [s] a stamp may lead the stack clock by this (sim: plus one tick)
    clock_jump: Annotated[float, Meta(gt=0.0, le=3600.0)] = 1.0  # [s] a sim clock tick may run this far past the rtf's pace

    def max_message(self) -> int:
        """[bytes] the largest message a zenav router or service session takes off a link (Zenoh drops larger
        ones there, before any copy reaches Python): a payload and selector parameters at their limits, plus headroom."""
        return self.max_payload + self.max_params + MESSAGE_HEADROOM


class Obstacle(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """One thing on the field the robot must not touch: a polygon's corners, or a disc [x, y, r]."""

    name: Annotated[str, Meta(max_length=64)] = ""  # shown in errors and the scene; "": obstacles[i]
    polygon: tuple[tuple[float, ...], ...] | None = None  # [m] [[x, y], ...] at least 3 corners, simple
    circle: tuple[float, ...] | None = None  # [m] [x, y, r]

    def __post_init__(self) -> None:
        if (self.polygon is None) == (self.circle is None):
            raise ValueError("an obstacle is either a polygon = [[x, y], ...] or a circle = [x, y, r]")


class FieldTag(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """A fixed tag on the field (the cameras' reference): its id and size, and its pose as WPILib's field layouts give it
    (a translation, and a rotation: yaw about z, then pitch about y, then roll about x; `quaternion` has it as W, X, Y, Z)."""

    id: Annotated[int, Meta(ge=0, le=586)]  # tag36h11 id
    size: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.15  # [m] edge of its black square
    x: float  # [m] map frame, the tag's centre
    y: float  # [m]
    z: float = 0.0  # [m] above the floor
    yaw: float = 0.0  # [rad] the tag's normal (its outward face) from map x, about z
    pitch: float = 0.0  # [rad] about y
    roll: float = 0.0  # [rad] about x

    @property
    def quaternion(self) -> tuple[float, float, float, float]:
        """(W, X, Y, Z) of the rotation, as WPILib's AprilTagFieldLayout writes it."""
        return geometry.quaternion(self.yaw, self.pitch, self.roll)

    def corners(self) -> Any:
        """4 x 3 [m] map points of its black square, top-left first as seen facing it (fieldtags.corners)."""
        return fieldtags.corners(self.size, self.x, self.y, self.z, self.yaw, self.pitch, self.roll)


# The default field's tags (a config that sets neither the field's bounds nor its tags gets them): three on the wall of
# each of its edges, 0.25 m up, facing in (FRC's 0.1651 m tags).
DEFAULT_TAGS = (
    FieldTag(id=1, size=0.1651, x=3.0, y=0.0, z=0.25, yaw=3.1415927),
    FieldTag(id=2, size=0.1651, x=3.0, y=1.0, z=0.25, yaw=3.1415927),
    FieldTag(id=3, size=0.1651, x=3.0, y=2.0, z=0.25, yaw=3.1415927),
    FieldTag(id=4, size=0.1651, x=0.0, y=3.0, z=0.25, yaw=-1.5707963),
    FieldTag(id=5, size=0.1651, x=1.0, y=3.0, z=0.25, yaw=-1.5707963),
    FieldTag(id=6, size=0.1651, x=2.0, y=3.0, z=0.25, yaw=-1.5707963),
    FieldTag(id=7, size=0.1651, x=-1.0, y=0.0, z=0.25, yaw=0.0),
    FieldTag(id=8, size=0.1651, x=-1.0, y=1.0, z=0.25, yaw=0.0),
    FieldTag(id=9, size=0.1651, x=-1.0, y=2.0, z=0.25, yaw=0.0),
    FieldTag(id=10, size=0.1651, x=0.0, y=-1.0, z=0.25, yaw=1.5707963),
    FieldTag(id=11, size=0.1651, x=1.0, y=-1.0, z=0.25, yaw=1.5707963),
    FieldTag(id=12, size=0.1651, x=2.0, y=-1.0, z=0.25, yaw=1.5707963),
)

FIELD_FILE_KEYS = ("x_min", "x_max", "y_min", "y_max", "obstacles", "tags")  # what a [field] file describes


class Field(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The area the robot may drive in (map frame), what stands on it, and its fixed tags; goals outside it are refused."""

    enabled: bool = True  # false: no bounds
    x_min: float = -1.0  # [m]
    x_max: float = 3.0  # [m]
    y_min: float = -1.0  # [m]
    y_max: float = 3.0  # [m]
    file: str = ""  # a field file (TOML or JSON) with the bounds, obstacles and tags; read when the config is loaded
    margin: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.05  # [m] kept clear beyond the robot's footprint ([robot] radius)
    obstacles: tuple[Obstacle, ...] = ()
    tags: tuple[FieldTag, ...] = ()  # a loaded config's default: DEFAULT_TAGS, on the default field (Settings.load)
    tags_file: str = ""  # a WPILib AprilTagFieldLayout JSON whose tags join `tags`; read when the config is loaded
    tag_size: Annotated[float, Meta(gt=0.0, le=10.0)] | None = None  # [m] edge of tags_file's tags (the layout has none)

    def __post_init__(self) -> None:
        if not (self.x_min < self.x_max and self.y_min < self.y_max):
            raise ValueError("x_min < x_max and y_min < y_max are required")
        ids = [t.id for t in self.tags]
        twice = sorted({i for i in ids if ids.count(i) > 1})
        if twice:
            raise ValueError(f"tags: id {twice[0]} is given twice")
        for t in self.tags if self.enabled else ():
            why = fieldtags.misplaced(t.id, t.x, t.y, t.yaw, t.pitch, t.roll, (self.x_min, self.y_min, self.x_max, self.y_max))
            if why:
                raise ValueError(f"tags: {why}")
        fieldmod.check_layout(self.shapes(), (self.x_min, self.y_min, self.x_max, self.y_max) if self.enabled else None)

    def shapes(self) -> tuple[fieldmod.Shape, ...]:
        """The obstacles as checked shapes (FieldError names a bad one)."""
        return _shapes(self.obstacles)

    def beyond(self, x: float, y: float) -> float:
        """[m] how far (x, y) lies outside the field: 0 inside it (or with the field off)."""
        if not self.enabled:
            return 0.0
        return max(self.x_min - x, x - self.x_max, self.y_min - y, y - self.y_max, 0.0)

    def outside(self, x: float, y: float) -> str | None:
        """The bound (x, y) [m] lies beyond, as text, or None when inside (or the field is off)."""
        if not self.enabled or (self.x_min <= x <= self.x_max and self.y_min <= y <= self.y_max):
            return None
        for name, value, ok in (
            (f"x_min = {self.x_min}", x, x >= self.x_min),
            (f"x_max = {self.x_max}", x, x <= self.x_max),
            (f"y_min = {self.y_min}", y, y >= self.y_min),
            (f"y_max = {self.y_max}", y, y <= self.y_max),
        ):
            if not ok:
                return f"{value:g} m is outside the field ([field] {name})"
        return None


@functools.cache
def _shapes(obstacles: tuple[Obstacle, ...]) -> tuple[fieldmod.Shape, ...]:
    out = []
    for i, o in enumerate(obstacles):
        name = f"obstacles[{i}]" + (f" {o.name!r}" if o.name else "")
        out.append(fieldmod.circle_shape(name, o.circle) if o.circle is not None else fieldmod.polygon_shape(name, o.polygon or ()))
    return tuple(out)


def field_file(path: str, base: str | None) -> dict[str, Any]:
    """The [field] keys a field file sets: a path (relative: to the config file's directory), or the name of a shipped
    one (zenav/data/fields/<name>.toml); TOML or JSON by its suffix."""
    shipped = resources.files("zenav").joinpath(f"data/fields/{path}.toml")
    if "/" not in path and "." not in path and shipped.is_file():
        text, suffix = shipped.read_text(), ".toml"
    else:
        full = os.path.join(os.path.dirname(base), path) if base and not os.path.isabs(path) else path
        try:
            with open(full, encoding="utf-8") as f:
                text, suffix = f.read(), os.path.splitext(full)[1].lower()
        except OSError as e:
            raise ConfigError(f"config [field] file: {e}") from None
    try:
        raw = json.loads(text) if suffix == ".json" else tomllib.loads(text)
    except (ValueError, tomllib.TOMLDecodeError) as e:
        raise ConfigError(f"config [field] file {path}: {e}") from None
    if not isinstance(raw, dict):
        raise ConfigError(f"config [field] file {path}: must be a table of {', '.join(FIELD_FILE_KEYS)}")
    unknown = [k for k in raw if k not in FIELD_FILE_KEYS]
    if unknown:
        raise ConfigError(f"config [field] file {path}: unknown key `{unknown[0]}` (a field file has {', '.join(FIELD_FILE_KEYS)})")
    return raw


def _layout_tags(path: str, size: Any, base: str | None) -> list[dict[str, float]]:
    """The tags of [field] tags_file, a WPILib AprilTagFieldLayout JSON (relative: to the config file's directory)."""
    full = os.path.join(os.path.dirname(base), path) if base and not os.path.isabs(path) else path
    try:
        with open(full, encoding="utf-8") as f:
            raw = json.load(f)
        return fieldtags.wpilib_tags(raw, None if size is None else float(size), f"config [field] tags_file {path}")
    except (OSError, ValueError) as e:
        text = str(e) if isinstance(e, fieldtags.LayoutError) else f"config [field] tags_file {path}: {e}"
        raise ConfigError(text) from None


@functools.cache
def known_sections() -> tuple[str, ...]:
    """The sections a config may have: the Settings' own, then every one the shipped default.toml documents
    (each service's, [camera]), so a section is known wherever the settings are loaded, whatever is imported."""
    with resources.files("zenav").joinpath("data/default.toml").open("rb") as f:
        documented = tomllib.load(f)
    return tuple(dict.fromkeys([*OWN_SECTIONS, *documented]))


# Keys a config may still carry from an earlier release: [section] key -> what became of it.
RETIRED: dict[tuple[str, str], str] = {
    ("vps", "delivery_period"): "each fix is sent at its delivery time, with no timer to set; delete the line",
}


# Names a config may still use from an earlier release: each still works, and loading logs one line naming the new one.
RENAMED_KEYS: dict[tuple[str, str], str] = {  # [section] old key -> new key
    ("localizer", "multisensor_gyro_weight"): "complementary_gyro_weight",
    ("localizer", "multisensor_compass_weight"): "complementary_compass_weight",
    ("localizer", "multisensor_fix_weight"): "complementary_fix_weight",
    ("localizer", "seed001_distance_weights"): "estimate_average_distance_weights",
    ("localizer", "seed001_angle_weights"): "estimate_average_angle_weights",
    ("localizer", "seed001_fix_weight"): "estimate_average_fix_weight",
    ("localizer", "seed001_fix_heading_weight"): "estimate_average_fix_heading_weight",
    ("navigator", "min_speed"): "crawl_speed",  # a goal's min_speed (a chained goal) is another thing
}
RENAMED_VALUES: dict[tuple[str, str, str], str] = {  # [section] key = old value -> new value
    ("localizer", "mode", "weighted"): "speed_weighted",
    ("localizer", "mode", "weighted_latency"): "speed_weighted_latency",
    ("localizer", "mode", "multisensor"): "complementary",
    ("localizer", "mode", "seed001"): "estimate_average",
}


def _renamed(where: str, values: dict[str, Any]) -> dict[str, Any]:
    """A section with the old names of RENAMED_KEYS and RENAMED_VALUES replaced by the new, a log line for each."""
    out: dict[str, Any] = {}
    for key, value in values.items():
        new_key = RENAMED_KEYS.get((where, key), key)
        if new_key != key and new_key in values:
            raise ConfigError(f"config [{where}]: `{key}` is the old name of `{new_key}`, and both are set: keep `{new_key}`")
        if new_key != key:
            _log.warning("config [%s] `%s` is now called `%s`: rename it (the old name still works)", where, key, new_key)
        new_value = RENAMED_VALUES.get((where, new_key, value), value) if isinstance(value, str) else value
        if new_value != value:
            _log.warning('config [%s] %s = "%s" is now called "%s": rename it (the old name still works)', where, new_key, value, new_value)
        out[new_key] = new_value
    return out


def _convert(raw: Any, typ: type[T], where: str) -> T:
    for key in raw if isinstance(raw, dict) else ():
        if (where, key) in RETIRED:
            raise ConfigError(f"config [{where}]: `{key}` is no longer a setting: {RETIRED[where, key]}")
    try:
        return msgspec.convert(raw, typ)
    except msgspec.ValidationError as e:
        text = re.sub(r"`\$\.?([^`]*)`", lambda g: f"`{where}.{g.group(1)}`".rstrip("."), str(e))
        raise ConfigError(f"config [{where}]: {text}{codec.nearest_field(typ, str(e))}") from None


@dataclass(frozen=True)
class Settings:
    """A loaded configuration: deployment values, robot, scenario, and raw sections."""

    deployment: Deployment
    robot: RobotConfig
    scenario: Scenario
    sections: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    path: str | None = None
    limits: Limits = Limits()
    field: Field = Field()

    @property
    def robot_id(self) -> str:
        return self.deployment.robot

    def section(self, name: str, typ: type[T]) -> T:
        """The typed config of one service; ConfigError names a bad key."""
        return _convert(self.sections.get(name, {}), typ, name)

    @classmethod
    def load(cls, path: str | None = None, **overrides: dict[str, Any]) -> Settings:
        """Read `path` (or only defaults), then apply per-section overrides.

        `Settings.load(None, deployment={"robot": "r2"}, sim={"rtf": 5.0})`.
        """
        raw: dict[str, Any] = {}
        if path:
            try:
                with open(path, "rb") as f:
                    raw = tomllib.load(f)
            except (OSError, tomllib.TOMLDecodeError) as e:
                raise ConfigError(f"config {path}: {e}") from None
        for name, values in overrides.items():
            raw[name] = {**raw.get(name, {}), **{k: v for k, v in values.items() if v is not None}}
        for name, value in raw.items():
            if not isinstance(value, dict):
                raise ConfigError(f"config: `{name}` must be a [section], not a value")
        raw = {name: _renamed(name, values) for name, values in raw.items()}
        unknown = [name for name in raw if name not in known_sections()]
        if unknown:
            near = difflib.get_close_matches(unknown[0], known_sections(), n=1)
            hint = f"did you mean [{near[0]}]? " if near else ""
            raise ConfigError(f"config: unknown section [{unknown[0]}] ({hint}known: {', '.join(known_sections())})")
        deployment = _convert(raw.get("deployment", {}), Deployment, "deployment")
        try:
            scen = scenario(deployment.scenario, raw.get("scenario"))
        except msgspec.ValidationError as e:
            raise ConfigError(f"config [scenario]: {e}") from None
        except ValueError as e:
            raise ConfigError(f"config [deployment] scenario: {e}") from None
        robot = _convert(raw.get("robot", {}), RobotConfig, "robot")
        limits = _convert(raw.get("limits", {}), Limits, "limits")
        area = raw.get("field", {})
        if area.get("file"):
            described = field_file(str(area["file"]), path)
            both = [k for k in described if k in area]
            if both:
                raise ConfigError(f"config [field]: `{both[0]}` is set both here and in its file {area['file']}: keep one")
            area = {**area, **described}
        if not any(k in area for k in ("tags", "tags_file", "x_min", "x_max", "y_min", "y_max")):
            area = {**area, "tags": msgspec.to_builtins(DEFAULT_TAGS)}  # they stand on the default field's walls only
        if area.get("tags_file"):
            area = {**area, "tags": [*area.get("tags", []), *_layout_tags(str(area["tags_file"]), area.get("tag_size"), path)]}
        bounds = _convert(area, Field, "field")
        if robot.ticks_per_rev is None:  # the encoders are known: take the scenario's
            robot = msgspec.structs.replace(robot, ticks_per_rev=scen.ticks_per_rev)
        sections = {k: v for k, v in raw.items() if k not in OWN_SECTIONS}
        return cls(deployment, robot, scen, sections, path, limits, bounds)


class Anchor(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """A fixed fiducial on the floor: its tag id and the map position of its centre, sides along x and y."""

    id: Annotated[int, Meta(ge=0, le=586)]  # tag36h11 id
    x: float  # [m] map frame
    y: float  # [m]


Positive = Annotated[float, Meta(gt=0.0, le=1e4)]
DEFAULT_ANCHORS = tuple(
    Anchor(id=100 + i, x=x, y=y) for i, (x, y) in enumerate(((-0.5, -0.2), (1.5, -0.2), (1.5, 1.2), (-0.5, 1.2), (0.5, -0.2), (0.5, 1.2)))
)


AUTO_CALIBRATION = "auto"  # [camera] calibration: fit it to the fixed tags in the frames, no file
CALIBRATION_FILE = "camera-calibration.json"  # where `zenav camera calibrate` writes by default


class Camera(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The [camera] section: the overhead camera of the field, its fiducials, and how the VPS reads it."""

    device: str = ""  # frame source: "" the sim's frames on the bus; a video file; a webcam index ("0"); an RTSP/HTTP URL
    width: Annotated[int, Meta(ge=16, le=8192)] = 640  # [px]
    height: Annotated[int, Meta(ge=16, le=8192)] = 480  # [px]
    rate_hz: Annotated[float, Meta(gt=0.0, le=1000.0)] = 10.0  # [Hz] frames captured
    x: Annotated[float, Meta(ge=-1e3, le=1e3)] = 0.5  # [m] optical centre, map frame
    y: Annotated[float, Meta(ge=-1e3, le=1e3)] = 0.5  # [m]
    z: Annotated[float, Meta(gt=0.0, le=100.0)] = 2.0  # [m] above the floor
    yaw: Annotated[float, Meta(ge=-7.0, le=7.0)] = 0.0  # [rad] image x axis from map x
    tilt: Annotated[float, Meta(ge=-0.8, le=0.8)] = 0.0  # [rad] optical axis off vertical, about the image x axis
    fx: Positive = 533.0  # [px] focal length
    fy: Positive = 533.0  # [px]
    cx: Annotated[float, Meta(ge=0.0, le=8192.0)] | None = None  # [px] principal point; None: the image centre
    cy: Annotated[float, Meta(ge=0.0, le=8192.0)] | None = None  # [px]
    k1: Annotated[float, Meta(ge=-10.0, le=10.0)] = -0.05  # radial distortion (OpenCV model)
    k2: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0
    p1: Annotated[float, Meta(ge=-1.0, le=1.0)] = 0.0  # tangential distortion
    p2: Annotated[float, Meta(ge=-1.0, le=1.0)] = 0.0
    k3: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0
    exposure: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.008  # [s] sim: motion blur over this time
    noise: Annotated[float, Meta(ge=0.0, le=100.0)] = 2.0  # [grey levels] sim: sensor noise, 1 sigma
    lighting: Annotated[float, Meta(ge=0.0, le=0.9)] = 0.15  # sim: relative swing of the light over time and across the field
    tag_size: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.10  # [m] robot tag, edge of its black square
    tag_height: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.12  # [m] robot tag above the floor
    robot_radius: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.09  # [m] sim: the robot's top, a disc under its tag
    anchor_size: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.15  # [m] fixed tags, edge of their black square
    anchors: tuple[Anchor, ...] = DEFAULT_ANCHORS  # fixed tags on the floor (calibration)
    robots: dict[Annotated[str, Meta(pattern=m.ROBOT_ID_PATTERN)], Annotated[int, Meta(ge=0, le=586)]] = msgspec.field(
        default_factory=lambda: {"r1": 0}
    )  # robot id -> the tag id on top of it
    # "auto": fitted to the fixed tags of the first frame that shows two; else the file `zenav camera calibrate` writes
    calibration: str = AUTO_CALIBRATION
    link_delay: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.3  # [s] added after detection (the radio link)
    corner_sigma: Annotated[float, Meta(gt=0.0, le=100.0)] = 0.3  # [px] 1 sigma of a sharp tag corner, the base of a fix's covariance
    # The camera's own errors (world/camera_errors.py): the sim renders them; the vps stamps rows by the readout and
    # widens each fix's covariance by the rest. "ideal": none of them (unit tests that need exact figures).
    model: Literal["realistic", "ideal"] = "realistic"
    calibration_error: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.3  # [px] rms: the true lens off the calibrated one
    mount_tilt: Annotated[float, Meta(ge=0.0, le=0.2)] = 0.0175  # [rad] sim: the mount off the configured tilt and yaw
    vibration: Annotated[float, Meta(ge=0.0, le=0.05)] = 0.0003  # [rad] 1 sigma: the mount's shake, frame to frame
    tag_height_error: Annotated[float, Meta(ge=0.0, le=0.5)] = 0.003  # [m] 1 sigma: a robot tag's true height off tag_height
    print_scale_error: Annotated[float, Meta(ge=0.0, le=0.2)] = 0.005  # [-] 1 sigma: the printed tags' scale off 1
    readout: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.03  # [s] rolling shutter: top row to bottom row; 0: global shutter
    jpeg_quality: Annotated[int, Meta(ge=0, le=100)] = 80  # sim: frames sent as JPEG of this quality; 0: raw mono8
    drop_rate: Annotated[float, Meta(ge=0.0, le=0.9)] = 0.02  # sim: fraction of frames lost on the way
    link_jitter: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.01  # [s] 1 sigma: the link delay's spread
    clock_sync: bool = True  # the vps measures the camera host's clock against the stack's (time/sync) and restamps
    clock_offset: Annotated[float, Meta(ge=-1e6, le=1e6)] = 0.0  # [s] sim: the camera host's clock ahead of the stack's
    clock_drift: Annotated[float, Meta(ge=-1e4, le=1e4)] = 0.0  # [ppm] sim: the camera host's clock running fast

    @property
    def principal(self) -> tuple[float, float]:
        """(cx, cy) [px]."""
        return (self.width / 2.0 if self.cx is None else self.cx, self.height / 2.0 if self.cy is None else self.cy)


def set_keys(text: str, section: str, values: dict[str, float] | dict[str, float | int]) -> str:
    """TOML `text` with `key = value` set in [section] (lines replaced, new ones at the section's end, the section added
    when missing; comments and every other line kept): what the commands that calibrate write to a config file."""
    lines = text.splitlines()
    head = next((i for i, s in enumerate(lines) if re.match(rf"^\s*\[{re.escape(section)}\]\s*(#.*)?$", s)), None)
    if head is None:
        lines += ["", f"[{section}]"]
        head = len(lines) - 1
    end = next((i for i in range(head + 1, len(lines)) if re.match(r"^\s*\[", lines[i])), len(lines))
    for key, value in values.items():
        line = f"{key} = {value!r}"
        at = next((i for i in range(head + 1, end) if re.match(rf"^\s*{re.escape(key)}\s*=", lines[i])), None)
        if at is None:
            last = max([head, *(i for i in range(head + 1, end) if lines[i].strip())])
            lines.insert(last + 1, line)
            end += 1
        else:
            lines[at] = line
    return "\n".join(lines) + "\n"
