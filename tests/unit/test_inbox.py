"""The service input queue: the priority lane first, bounds in items and bytes."""

from zenav.common.inbox import Inbox


def test_the_priority_lane_is_emptied_first_then_arrival_order():
    box = Inbox(10, 1000)
    for item in ("a", "b"):
        box.put(item, 1)
    box.put("stop", priority=True)
    box.put("c", 1)
    assert [box.get()[1] for _ in range(4)] == ["stop", "a", "b", "c"]
    assert box.get() == (False, None) and box.qsize() == 0 and box.nbytes() == 0


def test_puts_past_either_bound_are_refused():
    box = Inbox(3, 100)
    assert box.put("big", 80) and not box.put("too much", 30) and box.put("small", 20)
    assert box.nbytes() == 100
    assert box.put("third", 0) and not box.put("fourth", 0)  # three items
    assert box.put("stop", 50, priority=True)  # the priority lane: its own item bound only
    assert box.get()[1] == "stop" and box.nbytes() == 100


def test_a_latest_item_takes_the_place_of_the_one_queued_under_its_key():
    box = Inbox(10, 100)
    assert box.put("a", 1) and box.put_latest("frame", "f1", 10) == "queued"
    assert box.put("b", 1) and box.put_latest("frame", "f2", 30) == "replaced"
    assert box.put_latest("other", "o1", 5) == "queued"
    assert box.qsize() == 4 and box.nbytes() == 1 + 30 + 1 + 5  # the replaced one's bytes are gone
    assert [box.get()[1] for _ in range(2)] == ["a", "f2"]  # in the first one's place
    assert box.put_latest("frame", "f3", 10) == "queued"  # taken: a new one queues behind the rest
    assert [box.get()[1] for _ in range(3)] == ["b", "o1", "f3"]
    assert box.get() == (False, None) and box.nbytes() == 0


def test_a_latest_item_past_a_bound_is_refused_and_the_queued_one_kept():
    box = Inbox(2, 100)
    assert box.put_latest("frame", "f1", 60) == "queued" and box.put_latest("frame", "f2", 120) == "refused"
    assert box.put("a", 0) and box.put_latest("other", "o1", 0) == "refused"  # two items
    assert [box.get()[1] for _ in range(2)] == ["f1", "a"] and box.nbytes() == 0


def test_get_waits_up_to_its_timeout():
    box = Inbox(1, 1)
    assert box.get(timeout=0.01) == (False, None)


def test_a_poke_before_the_worker_waits_is_not_lost():
    ib = Inbox(4, 100)
    ib.poke()  # between the worker's look and its wait
    assert not ib.idle()  # so it looks again instead of waiting
    assert ib.idle()
    ib.put("x")
    assert not ib.idle()
