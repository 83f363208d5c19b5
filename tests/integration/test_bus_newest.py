"""A view's subscription (Bus.newest, Client.newest): Zenoh keeps a topic's newest sample, read when the view
draws, through a real router."""

from __future__ import annotations

import threading

from tests.support.matching import wait_subscriber
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.bus import ZenohBus
from zenav.common.client import Client


def test_newest_holds_the_last_sample_published_and_each_one_once(router):
    view, sender = ZenohBus.open(router, connect_timeout=5.0), ZenohBus.open(router, connect_timeout=5.0)
    marks: list[threading.Event] = [threading.Event(), threading.Event()]
    try:
        newest = view.newest("zenav/r1/pose")
        # A marker on another loop topic (the same priority, the same link): it is read after every pose before it.
        view.subscribe("zenav/r1/odom", lambda key, data: marks[data[0]].set())
        assert newest.take() is None
        wait_subscriber(sender, "zenav/r1/pose")
        wait_subscriber(sender, "zenav/r1/odom")
        for i in range(50):
            sender.publish("zenav/r1/pose", b"pose %d" % i)
        sender.publish("zenav/r1/odom", bytes([0]))
        assert marks[0].wait(5.0)
        assert newest.take() == b"pose 49"  # the 49 before it were let go in Zenoh's buffer
        assert newest.take() is None  # nothing came since
        sender.publish("zenav/r1/pose", b"pose 50")
        sender.publish("zenav/r1/odom", bytes([1]))
        assert marks[1].wait(5.0)
        assert newest.take() == b"pose 50"
    finally:
        view.close()
        sender.close()


def test_a_client_s_sampled_topic_keeps_its_newest_valid_message(router):
    sender = ZenohBus.open(router, connect_timeout=5.0)
    marked = threading.Event()
    with Client("r1", router) as c:
        pose = c.newest("pose")
        c.subscribe("odom", lambda msg: marked.set())
        assert pose.msg is None
        wait_subscriber(sender, "zenav/r1/pose")
        wait_subscriber(sender, "zenav/r1/odom")
        sender.publish("zenav/r1/pose", codec.encode(m.Pose(t=1.0, x=0.5, y=0.25, theta=0.0, v=0.0, omega=0.0)))
        sender.publish("zenav/r1/pose", b"\xc1 not a pose")  # the newest, and bad: the valid one before it stays
        sender.publish("zenav/r1/odom", codec.encode(m.Odom(t=1.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))
        try:
            assert marked.wait(5.0)
            assert pose.msg is None  # the bad one was the newest: nothing valid yet
            sender.publish("zenav/r1/pose", codec.encode(m.Pose(t=2.0, x=0.5, y=0.25, theta=0.0, v=0.0, omega=0.0)))
            marked.clear()
            sender.publish("zenav/r1/odom", codec.encode(m.Odom(t=2.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))
            assert marked.wait(5.0)
            first = pose.msg
            assert first is not None and first.t == 2.0
            sender.publish("zenav/r1/pose", b"\xc1 not a pose")
            marked.clear()
            sender.publish("zenav/r1/odom", codec.encode(m.Odom(t=3.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))
            assert marked.wait(5.0)
            assert pose.msg == first  # a bad newest one does not hide the last valid
            assert pose.msg == first  # read again with nothing new
        finally:
            sender.close()
