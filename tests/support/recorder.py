"""A service that records the order its handlers run in, for the runtime's tests."""

from zenav.common.runtime import Service


class Recorder(Service):
    """Records the order its handlers run in (`order`)."""

    def __init__(self, *a):
        super().__init__(*a)
        self.order = []
