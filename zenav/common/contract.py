"""The wire contract's codes: navigator states, goal results, move exits, error codes and refusal reasons.

Each is a str-valued enum: a member is equal to its string and travels as it (`State.STOPPED == "STOPPED"`),
so messages keep plain `str` fields and a client that knows a newer code than this one still decodes it.
Programs compare against the members, never against text; the order of each enum is the contract's table order
(docs/contract.md, checked by a test).
"""

from __future__ import annotations

from enum import Enum


class Code(str, Enum):
    """A code on the wire: prints and formats as its value (Python 3.10's enum would print `State.STOPPED`)."""

    def __str__(self) -> str:
        return str.__str__(self)

    def __format__(self, spec: str) -> str:
        return str.__format__(self, spec)


class State(Code):
    """nav/state's, nav/status's and a goal reply's `state`: what the navigator runs."""

    STOPPED = "STOPPED"  # no goal running
    MOVING_TO_POINT = "MOVING_TO_POINT"
    MOVING_TO_POSE = "MOVING_TO_POSE"
    TURNING_TO_HEADING = "TURNING_TO_HEADING"  # turn_to_heading, turn_to_point and swing_to_heading
    MOVING_STRAIGHT = "MOVING_STRAIGHT"
    FOLLOWING_PATH = "FOLLOWING_PATH"


class GoalResult(Code):
    """A goal's `result` once it ended."""

    SUCCEEDED = "succeeded"
    CANCELLED = "cancelled"  # nav/stop, a newer goal
    ABORTED = "aborted"  # it could not go on; the message says why


class Exit(Code):
    """Why a goal's move ended (`exit`): see the navigator's exits module for each rule."""

    WITHIN_TOLERANCE = "within_tolerance"
    PASSED = "passed"
    SETTLED = "settled"
    BIG_ERROR = "big_error"
    TIMEOUT = "timeout"
    STALLED = "stalled"
    CANCELLED = "cancelled"
    ABORTED = "aborted"
    CHAINED = "chained"


class ErrorCode(Code):
    """An error reply's `error`."""

    INVALID_ARGUMENT = "invalid_argument"  # bad input: the message names the field
    UNAVAILABLE = "unavailable"  # the service cannot do it now
    INTERNAL = "internal"  # the service failed (a bug)


class Reason(Code):
    """An error reply's `reason`: which `unavailable` it is, for a client to decide on (the reply's "": none given)."""

    NO_POSE = "no_pose"  # no pose yet
    POSE_STALE = "pose_stale"  # the newest pose is older than [navigator] stale_after
    POSE_UNCERTAIN = "pose_uncertain"  # its sigma is over [navigator] max_position_sigma or max_heading_sigma
    LEASE_UNSEEN = "lease_unseen"  # the goal's lease token was not seen within [navigator] lease_grace
    SUPERSEDED = "superseded"  # a newer goal came while this one waited for its lease
    STOPPED = "stopped"  # a nav/stop voided the goal before it started
    MOTOR_GONE = "motor_gone"  # the motor service is gone: no goal can be driven
    OVERLOADED = "overloaded"  # the service's input queue is full
    RESTARTED = "restarted"  # the stack clock restarted while the goal waited for its lease
    SHUTTING_DOWN = "shutting_down"  # the service is shutting down


RETRYABLE = frozenset({Reason.POSE_STALE, Reason.LEASE_UNSEEN})  # a goal refused for these is worth sending again on the next pose
