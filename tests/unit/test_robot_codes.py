"""The library decides on an error reply's code and reason, never on its words: changed words change nothing."""

import threading

import msgspec
import pytest

from tests.support.navigator import World
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.client import Client, Internal, InvalidArgument, Unavailable, ZenavError
from zenav.common.contract import ErrorCode, Reason
from zenav.robot import Robot

WORDS = ("pose stale", "invalid_argument: x", "internal error", "unavailable", "")  # words that name other codes, or none


class Canned:
    """A bus whose every query is answered with one error reply."""

    def __init__(self, reply: m.ErrorReply) -> None:
        self.reply = reply

    def get(self, selector, payload=None, timeout=5.0, urgent=False):
        return [(False, codec.encode(self.reply))]

    def close(self):
        pass


@pytest.mark.parametrize(
    ("code", "exception"),
    [(ErrorCode.INVALID_ARGUMENT, InvalidArgument), (ErrorCode.UNAVAILABLE, Unavailable), (ErrorCode.INTERNAL, Internal)],
)
@pytest.mark.parametrize("words", WORDS)
def test_the_exception_follows_the_code_whatever_the_message_says(code, exception, words):
    client = Client("r1", bus=Canned(m.ErrorReply(error=code, message=words, reason=Reason.POSE_STALE)))
    with pytest.raises(ZenavError) as raised:
        client.query("nav/status")
    assert type(raised.value) is exception and raised.value.code == code and raised.value.message == words
    assert raised.value.reason == Reason.POSE_STALE


def test_an_unknown_code_is_a_plain_zenav_error_keeping_its_code_and_reason():
    client = Client("r1", bus=Canned(m.ErrorReply(error="resource_exhausted", message="unavailable", reason="later")))
    with pytest.raises(ZenavError) as raised:
        client.query("nav/status")
    assert type(raised.value) is ZenavError and (raised.value.code, raised.value.reason) == ("resource_exhausted", "later")


class Reworded(World):
    """The navigator's error replies with their words (and, if asked, their reason) replaced."""

    def __init__(self, message: str, reason: str | None = None) -> None:
        super().__init__()
        self.message, self.reason = message, reason

    def get(self, selector, payload=None, timeout=5.0, urgent=False):
        out = []
        for ok, data in super().get(selector, payload, timeout, urgent):
            if not ok:
                err = codec.decode(data, m.ErrorReply)
                err = msgspec.structs.replace(err, message=self.message, reason=err.reason if self.reason is None else self.reason)
                data = codec.encode(err)
            out.append((ok, data))
        return out


def refuse_once_on_a_stale_pose(world: World) -> tuple[threading.Thread, Robot]:
    """A robot, the newest pose stale, and a helper that publishes a fresh pose once a goal was refused."""
    world.clock.advance(1.0)

    def fresh_pose():
        assert world.refused.wait(5.0)
        for key, data in world.samples():  # the robot at rest where it started
            world.bus.publish(key, data)

    helper = threading.Thread(target=fresh_pose)
    helper.start()
    return helper, Robot("r1", bus=world)


def test_a_stale_pose_refusal_in_other_words_is_still_sent_again_on_the_next_pose():
    world = Reworded("the words of this refusal changed")
    world.pose()
    helper, bot = refuse_once_on_a_stale_pose(world)
    with bot:
        goal = bot.move_to_point(0.2, 0.0)
        helper.join(5.0)
        assert len(world.goals_sent()) == 2 and goal.reply.state == "MOVING_TO_POINT"
    world.nav.close()


def test_a_refusal_whose_words_say_pose_stale_but_whose_reason_is_another_is_not_sent_again():
    world = Reworded("pose stale: the newest is 1.00 s old", reason=Reason.MOTOR_GONE)
    world.pose()
    helper, bot = refuse_once_on_a_stale_pose(world)
    with bot:
        with pytest.raises(Unavailable) as raised:
            bot.move_to_point(0.2, 0.0)
        helper.join(5.0)
        assert raised.value.reason == Reason.MOTOR_GONE and len(world.goals_sent()) == 1
    world.nav.close()
