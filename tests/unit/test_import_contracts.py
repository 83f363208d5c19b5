"""The import contracts that keep the algorithm cores pure cover every module of every service: each module is
either a core (named in both core contracts in pyproject.toml) or one of the few that do the service's I/O,
named here. A new module must be put on one side; lint-imports (`./run check`) then holds the cores to it."""

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]
SERVICES = REPO / "zenav" / "services"
CORES = "the algorithm cores"  # how both core contracts' names begin
# The modules that talk to the bus, the clock, files, devices or threads: each service's wiring.
IO_MODULES = {
    "zenav.services.driver.board",  # the serial port
    "zenav.services.sim.camera",  # a worker thread that renders and sends frames
    "zenav.services.sim.onboard",  # the onboard camera's frames, sent by that worker
    "zenav.services.vps.calibration_file",  # the calibration file
    "zenav.services.vps.clocks",  # the camera host's clock, synchronised over the bus
    "zenav.services.vps.frames",  # webcams, video files and streams
    "zenav.services.vps.onboard_reader",  # the onboard camera's pipeline, timed with the wall clock
    "zenav.services.vps.reader",  # the camera pipeline, timed with the wall clock
}


def contracts() -> list[dict]:
    return tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]


def service_modules() -> set[str]:
    return {
        f"zenav.services.{p.parent.name}.{p.stem}"
        for p in SERVICES.glob("*/*.py")
        if p.stem not in ("__init__", "__main__", "service")  # service.py: each service's wiring to the bus
    }


def test_both_core_contracts_name_the_same_modules_the_world_model_among_them():
    cores = [c for c in contracts() if c["name"].startswith(CORES)]
    assert len(cores) == 2, [c["name"] for c in cores]
    assert cores[0]["source_modules"] == cores[1]["source_modules"]
    assert "zenav.world" in cores[0]["source_modules"]
    assert not cores[0].get("allow_indirect_imports") and "zenav.common.bus" in cores[0]["forbidden_modules"]


def test_every_service_module_is_a_core_or_named_as_doing_io():
    sources = set(next(c for c in contracts() if c["name"].startswith(CORES))["source_modules"]) - {"zenav.world"}
    modules = service_modules()
    assert sources <= modules, f"contracts name modules that do not exist: {sorted(sources - modules)}"
    assert not sources & IO_MODULES
    unclassified = modules - sources - IO_MODULES
    assert not unclassified, f"add each to the core contracts in pyproject.toml, or to IO_MODULES here: {sorted(unclassified)}"


def test_the_services_are_independent_of_each_other():
    independent = next(c for c in contracts() if c["type"] == "independence")
    packages = {f"zenav.services.{p.name}" for p in SERVICES.iterdir() if (p / "service.py").exists()}
    assert set(independent["modules"]) == packages
