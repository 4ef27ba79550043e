"""Variants of an experiment: load its files as config dataclasses, replace, write them back.

Every benchmark builds its experiments from the default one (plant/defaults/) or the demo's
rig: :func:`vary` loads ``device.toml`` and ``virtual.toml`` as :class:`Device` and
:class:`Virtual`, applies functions that return changed copies (``dataclasses.replace``), and
writes the files with :mod:`rsp_inertia.plant.config`'s writers, which ``load_device`` and
``load_virtual`` read back equal. The helpers below are such functions, each one change.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from rsp_inertia.plant.config import Device, Stage, load_device
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.virtual.config import Virtual, load_virtual

__all__ = [
    "closed_loop",
    "default_experiment",
    "drawn_reference",
    "load",
    "scale_friction",
    "seeded",
    "vary",
    "warming_motor",
    "with_com",
    "with_encoder_bits",
    "with_rig",
    "with_stage",
    "with_stages",
    "write",
]

DeviceChange = Callable[[Device], Device]
VirtualChange = Callable[[Virtual], Virtual]


def load(root: str | Path) -> tuple[Device, Virtual]:
    """An experiment folder's ``device.toml`` and ``virtual.toml``."""
    root = Path(root)
    return load_device(root / "device.toml"), load_virtual(root / "virtual.toml")


def write(root: str | Path, device: Device | None = None, virtual: Virtual | None = None) -> None:
    """Write ``device`` as ``root/device.toml`` and ``virtual`` as ``root/virtual.toml``
    (each atomically; None leaves that file as it is)."""
    from rsp_inertia.plant.config import write_device
    from rsp_inertia.virtual.config import write_virtual

    root = Path(root)
    if device is not None:
        write_device(root / "device.toml", device)
    if virtual is not None:
        write_virtual(root / "virtual.toml", virtual)


def vary(
    root: str | Path, device: DeviceChange | None = None, virtual: VirtualChange | None = None
) -> tuple[Device, Virtual]:
    """Load the folder's files, apply ``device`` and ``virtual`` (functions returning changed
    copies), write what changed; return the new pair."""
    old_device, old_virtual = load(root)
    new_device = old_device if device is None else device(old_device)
    new_virtual = old_virtual if virtual is None else virtual(old_virtual)
    write(
        root,
        None if device is None else new_device,
        None if virtual is None else new_virtual,
    )
    return new_device, new_virtual


def default_experiment(
    root: str | Path, device: DeviceChange | None = None, virtual: VirtualChange | None = None
) -> Path:
    """The default experiment (plant/defaults/) in ``root``, varied by :func:`vary`."""
    root = create_default_experiment(root)
    if device is not None or virtual is not None:
        vary(root, device, virtual)
    return root


# --- one change each -------------------------------------------------------------------------


def closed_loop(root: str | Path) -> None:
    """Run an experiment folder on the virtual device as a rig runs it: the braking (every
    stage and direction), the torque programs, the closed-loop reverse."""
    from rsp_inertia.programming import program
    from rsp_inertia.simulating import simulate

    simulate(root, part="braking")
    program(root)
    simulate(root, part="reverse")


def drawn_reference(reference: str | Path, seed: int) -> np.ndarray:
    """Make the reference folder's true body (its virtual.toml ``[body]``) one draw from its
    certificate (reference.toml's values and covariance), seeded by ``seed`` as
    benchmarks.certificate draws it; return the draw over [mass, Jx..Jxz, x, y, z]."""
    import tomlkit

    from rsp_inertia.plant.config import load_reference

    reference = Path(reference)
    nominal = load_reference(reference / "reference.toml")
    drawn = np.random.default_rng(10_000 + seed).multivariate_normal(nominal.values, nominal.cov)
    path = reference / "virtual.toml"
    doc = tomlkit.parse(path.read_text())
    doc["body"]["mass"] = float(drawn[0])
    doc["body"]["inertia"] = [float(v) for v in drawn[1:7]]
    doc["body"]["com"] = [float(v) for v in drawn[7:10]]
    path.write_text(tomlkit.dumps(doc))
    return drawn


def scale_friction(virtual: Virtual, factor: float) -> Virtual:
    """The Coulomb (a1) and viscous (a2) friction times ``factor``; the quadratic (a3) kept.

    Quadratic drag takes the fraction 1 - exp(-4 pi a3 / M) of the kinetic energy every turn
    whatever the speed (25% on the default stage 1 at the paper's a3, 95% at ten times it), so
    no multi-turn braking pass exists at a scaled a3.
    """
    friction = virtual.friction
    return replace(
        virtual,
        friction=replace(
            friction, coulomb=friction.coulomb * factor, viscous=friction.viscous * factor
        ),
    )


def seeded(virtual: Virtual, seed: int, jitter: bool = True) -> Virtual:
    """The noise seed ``seed``; with ``jitter``, the release angle moved by U(-1, 1) deg drawn
    from the seed, which changes the encoder's quantization pattern too (the noise seed alone
    leaves it the same from run to run)."""
    run = replace(virtual.run, seed=seed)
    if jitter:
        move = np.random.default_rng(seed).uniform(-1.0, 1.0)
        run = replace(run, release_angle_deg=float(run.release_angle_deg + move))
    return replace(virtual, run=run)


def with_com(virtual: Virtual, com_mm: float) -> Virtual:
    """The body's centre of mass ``com_mm`` mm from the fixed point, along its direction."""
    com = np.asarray(virtual.body.com, dtype=float)
    com = [float(v) for v in com / np.linalg.norm(com) * com_mm * 1e-3]
    return replace(virtual, body=replace(virtual.body, com=com))


def with_encoder_bits(device: Device, bits: int) -> Device:
    """An encoder of 2**bits counts per revolution."""
    return replace(device, encoder=replace(device.encoder, counts_per_rev=2**bits))


def with_rig(virtual: Virtual, **changes) -> Virtual:
    """The rig's imperfections (virtual.toml ``[rig]``, :class:`rsp_inertia.virtual.config.Rig`)
    with the given fields changed."""
    return replace(virtual, rig=replace(virtual.rig, **changes))


WARMING_MOTORS = {2e-4: 2.93, 1e-3: 14.65}
"""Winding resistance (ohm) of :func:`warming_motor` per mean drift between the passes
(benchmarks.thermal measures it on the default experiment, closed loop)."""


def warming_motor(virtual: Virtual, drift: float = 2e-4, lag: float = 5.0) -> Virtual:
    """A small servo motor with NdFeB magnets that warms through the passes (virtual.toml
    ``[rig]``, rsp_inertia.virtual.thermal): alpha = -0.0011/K; 0.5 N m/A at phi (a 0.05 N m/A
    motor behind a 10:1 gear); the winding 4 K/W to the ambient with a 60 s time constant
    (15 J/K: the winding and the stator it sits in); the magnets ``lag`` s behind; the
    winding's resistance chosen (:data:`WARMING_MOTORS`) so that the torque scale's mean
    differs by ``drift`` between the braking and the reverse pass of stage 2 (benchmarks.thermal).
    """
    return with_rig(
        virtual,
        torque_constant_tempco=-0.0011,
        torque_constant=0.5,
        winding_resistance=WARMING_MOTORS[drift],
        thermal_resistance=4.0,
        winding_time_constant=60.0,
        magnet_lag=lag,
    )


def with_stage(device: Device, stage: int, **changes) -> Device:
    """Stage ``stage`` (from 1) with the given fields changed."""
    stages = list(device.stages)
    stages[stage - 1] = replace(stages[stage - 1], **changes)
    return replace(device, stages=tuple(stages))


def with_stages(device: Device, change: Callable[[Stage], Stage]) -> Device:
    """Every stage through ``change``."""
    return replace(device, stages=tuple(change(st) for st in device.stages))
