"""The plant: the gimbal's model and geometry, the transducers, and the file contracts of an
experiment (device.toml, reference.toml, the logs and programs, the experiment folder).

The names below are its public API, each from the module that is its home; they load on
first use (rsp_inertia.infra.lazy, as ``rsp_inertia`` does), so importing one module of the
package does not import the others.
"""

from __future__ import annotations

from rsp_inertia.infra.lazy import lazy_names

_HOMES = {
    "Device": "config",
    "Direction": "direction",
    "load_device": "config",
    "load_reference": "config",
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
    "FRICTION": "friction",
    "FrictionLaw": "friction",
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
    "Log",
    "ModelParameters",
    "Program",
    "design_matrix",
    "device_design",
    "dropped_samples",
    "entries_from_tensor",
    "inertia_harmonics",
    "load_device",
    "load_reference",
    "open_experiment",
    "place_body",
    "principal",
    "principal_uncertainty",
    "read_device_log",
    "read_log",
    "read_program",
    "reduced_inertia",
    "tensor_from_entries",
    "write_log",
    "write_program",
]

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
