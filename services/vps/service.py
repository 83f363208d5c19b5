"""The VPS service: the simulated overhead camera, delivering late fixes on `vps/pose`."""
from __future__ import annotations

from typing import Annotated

import msgspec
from msgspec import Meta, Struct

from zenav.common import messages as m
from zenav.common import scenarios
from zenav.common.runtime import Service, subscribe, timer

from .camera import Camera, DeliveryQueue, make_rng


class VpsConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The [vps] section (the camera's errors are the scenario's)."""

    delivery_period: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.005  # [s] how often fixes that are due are sent


class Vps(Service):
    """Samples `sim/truth` at the scenario's VPS rate and publishes each fix after its latency."""

    name = "vps"
    config_type = VpsConfig

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.delivery_period = self.cfg.delivery_period
        self.camera = Camera(self.settings.scenario, make_rng(self.settings.deployment.seed))
        self.queue = DeliveryQueue()
        self._last_t = -1.0  # [s] newest truth sample

    @subscribe("sim/truth")
    def on_truth(self, msg: m.Truth) -> None:
        """One truth sample: a capture when one is due."""
        if msg.t < self._last_t:
            self.count("truth_restarts")  # the sim started again: its pending fixes are void
            self.queue.clear()
        self._last_t = msg.t
        d = self.camera.capture(msg)
        if d is not None:
            self.queue.push(d)
            self.count("fixes_captured")

    @timer("delivery_period")
    def deliver(self, now: float) -> None:
        """Publish every fix whose delivery time has come."""
        for d in self.queue.pop_due(now):
            fix = d.fix
            faults = scenarios.active(self.settings.scenario.faults, fix.t)
            if "future_stamp" in faults:
                fix = msgspec.structs.replace(fix, t=fix.t + scenarios.FUTURE_OFFSET)
            for _ in range(2 if "duplicate" in faults else 1):
                self.publish("vps/pose", fix)
