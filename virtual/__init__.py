"""The virtual device: a simulated gimbal that writes the logs a rig would.

Its truth is ``virtual.toml`` (rsp_inertia.virtual.config: the true body and fixture, the
friction law, the rig's imperfections, the simulated runs' settings); it integrates the
plant's model (rsp_inertia.plant.model) through the passes (rsp_inertia.virtual.integrate),
drives and logs them as a rig's motor, encoder and logger would (rsp_inertia.virtual.drive),
runs a torque program in closed loop (rsp_inertia.virtual.reverse) and simulates braking,
pendulum and pilot runs (rsp_inertia.virtual.device). Nothing below it (plant, estimation)
knows it exists: a real rig's experiment never loads it.

The names below are its public API, each from the module that is its home, loaded on first
use (rsp_inertia.infra.lazy).
"""

from __future__ import annotations

from rsp_inertia.infra.lazy import lazy_names

_HOMES = {
    "Virtual": "config",
    "experiment_virtual": "config",
    "load_virtual": "config",
    "placed_body": "config",
    "write_virtual": "config",
    "SimulatedPass": "drive",
    "run_program": "reverse",
    "simulate_ideal_reverse": "reverse",
    "simulate_braking": "device",
    "simulate_pendulum": "device",
    "simulate_pilot": "device",
}
"""Each public name and the module (of this package) that is its home."""

__all__ = [
    "SimulatedPass",
    "Virtual",
    "experiment_virtual",
    "load_virtual",
    "placed_body",
    "run_program",
    "simulate_braking",
    "simulate_ideal_reverse",
    "simulate_pendulum",
    "simulate_pilot",
    "write_virtual",
]

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
