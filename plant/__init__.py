"""Gimbal model, geometry, device description, the experiment's files and the virtual device.

The names below are its public API, each from the module that is its home; they load on
first use (rsp_inertia.plant.lazy, as ``rsp_inertia`` does), so importing one module of the
package does not import the others.
"""

from __future__ import annotations

from rsp_inertia.plant.lazy import lazy_names

_HOMES = {
    "InputError": "errors",
    "Device": "config",
    "Direction": "direction",
    "Virtual": "config",
    "load_device": "config",
    "load_reference": "config",
    "load_virtual": "config",
    "placed_body": "config",
    "Experiment": "experiment",
    "open_experiment": "experiment",
    "Log": "logs",
    "Program": "logs",
    "dropped_samples": "logs",
    "read_device_log": "logs",
    "read_log": "logs",
    "read_program": "logs",
    "write_log": "logs",
    "write_program": "logs",
    "check_writable": "files",
    "write_atomic": "files",
    "GimbalModel": "model",
    "MODEL": "model",
    "ModelParameters": "model",
    "inertia_harmonics": "model",
    "reduced_inertia": "model",
    "AxisDesign": "geometry",
    "ENTRY_KEYS": "geometry",
    "design_matrix": "geometry",
    "device_design": "geometry",
    "entries_from_tensor": "geometry",
    "place_body": "geometry",
    "principal": "geometry",
    "principal_uncertainty": "geometry",
    "tensor_from_entries": "geometry",
    "SimulatedPass": "virtual",
    "run_program": "virtual",
    "simulate_braking": "virtual",
    "simulate_ideal_reverse": "virtual",
    "simulate_pendulum": "virtual",
    "simulate_pilot": "virtual",
}
"""Each public name and the module (of this package) that is its home."""

__all__ = [
    "ENTRY_KEYS",
    "MODEL",
    "AxisDesign",
    "Device",
    "Direction",
    "Experiment",
    "GimbalModel",
    "InputError",
    "Log",
    "ModelParameters",
    "Program",
    "SimulatedPass",
    "Virtual",
    "check_writable",
    "design_matrix",
    "device_design",
    "dropped_samples",
    "entries_from_tensor",
    "inertia_harmonics",
    "load_device",
    "load_reference",
    "load_virtual",
    "open_experiment",
    "place_body",
    "placed_body",
    "principal",
    "principal_uncertainty",
    "read_device_log",
    "read_log",
    "read_program",
    "reduced_inertia",
    "run_program",
    "simulate_braking",
    "simulate_ideal_reverse",
    "simulate_pendulum",
    "simulate_pilot",
    "tensor_from_entries",
    "write_atomic",
    "write_log",
    "write_program",
]

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
