"""The zenav services, one package each: <algorithm>.py pure cores, service.py wiring."""
from __future__ import annotations

import importlib

# Service name -> "module:Class". The order is the start order of `zenav up`.
SERVICE_CLASSES = {
    "sim": "zenav.services.sim.service:Sim",
    "motor": "zenav.services.motor.service:Motor",
    "odometry": "zenav.services.odometry.service:Odometry",
    "vps": "zenav.services.vps.service:Vps",
    "localizer": "zenav.services.localizer.service:Localizer",
    "navigator": "zenav.services.navigator.service:Navigator",
}


def load(name: str) -> type:
    """The Service class of a service name."""
    module, cls = SERVICE_CLASSES[name].split(":")
    return getattr(importlib.import_module(module), cls)
