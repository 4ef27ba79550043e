"""Read and write the experiment's description files: ``device.toml`` and ``reference.toml``.

``device.toml`` describes the gimbal: its spring, motor, encoder, the stages (one gear ratio
each, with the nodes where the tensor is sampled) and, optionally, the body's mass, how the
body is mounted, the torsion-pendulum baseline and guesses for planning.
``reference.toml`` holds a reference body's certified data. docs/files.md documents every
key. This module is the public home of their config classes, readers and writers, which
live in rsp_inertia.plant.device_config and rsp_inertia.plant.reference_config; nothing
else reads or writes these files. (The virtual device's ``virtual.toml`` is read and written
by rsp_inertia.virtual.config.)

Each file is a frozen config class (:class:`Device`; :class:`TrueBody` for reference.toml)
whose fields declare the keys: name, type, unit, bounds, default and doc
(rsp_inertia.infra.toml_schema). A writer writes every key whose value is not None, reads
the text back and refuses (ValueError) what its loader would refuse or not give back equal.

Bad input raises :class:`rsp_inertia.infra.errors.InputError` with one line that names the
file, the dotted key and the fault, for example
``device.toml: stage[2].gear_ratio: must be >= 0, got -0.5``. Indices in keys count from 1,
as the ``stage1/``, ``stage2/`` folders of an experiment do. Unknown keys and tables are
errors, so that a typo never silently falls back to a default.

A variation of an experiment is a changed config instance written back::

    device = load_device(path)
    encoder = dataclasses.replace(device.encoder, counts_per_rev=4096)
    write_device(path, dataclasses.replace(device, encoder=encoder))
"""

from rsp_inertia.plant.device_config import (
    DEFAULT_GRAVITY,
    PROTOCOL,
    REQUIRED_AXES,
    ROTATION_TOLERANCE,
    Body,
    Device,
    Encoder,
    Motor,
    Mounting,
    Pendulum,
    PlanGuess,
    Spring,
    Stage,
    load_device,
    require_protocol,
    write_device,
)
from rsp_inertia.plant.log_layout import (
    AngleUnit,
    LogFormat,
    LogLayout,
    TimeOrigin,
    TimeUnit,
    TorqueUnit,
)
from rsp_inertia.plant.reference_config import (
    REFERENCE_PARAMETERS,
    Certificate,
    CertifiedBody,
    Reference,
    TrueBody,
    load_reference,
    placed_reference,
    write_reference,
)

__all__ = [
    "DEFAULT_GRAVITY",
    "PROTOCOL",
    "REFERENCE_PARAMETERS",
    "REQUIRED_AXES",
    "ROTATION_TOLERANCE",
    "AngleUnit",
    "Body",
    "Certificate",
    "CertifiedBody",
    "Device",
    "Encoder",
    "LogFormat",
    "LogLayout",
    "Motor",
    "Mounting",
    "Pendulum",
    "PlanGuess",
    "Reference",
    "Spring",
    "Stage",
    "TimeOrigin",
    "TimeUnit",
    "TorqueUnit",
    "TrueBody",
    "load_device",
    "load_reference",
    "placed_reference",
    "require_protocol",
    "write_device",
    "write_reference",
]
