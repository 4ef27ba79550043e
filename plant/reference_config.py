"""``reference.toml``: a reference body's certified data, and the rigid body it describes.

:class:`TrueBody` is a rigid body's mass properties (mass, inertia about O, centre of mass,
in its own frame): a calibration's reference body, read from ``reference.toml``, and the
virtual device's body and fixture (virtual.toml's ``[body]`` and ``[fixture]``,
rsp_inertia.virtual.config). docs/files.md documents every key; the config class below
declares them (rsp_inertia.infra.toml_schema).
"""

from __future__ import annotations

import os

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.toml_schema import ContentError, config_class, key, read_file, read_table
from rsp_inertia.infra.toml_writer import write_file
from rsp_inertia.plant.geometry import physical_margins, place_body, tensor_from_entries

__all__ = ["TrueBody", "load_reference", "placed_reference", "write_reference"]

_INERTIA_NAMES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")


def _physical_inertia(inertia: tuple[float, ...], key: str) -> None:
    """Refuse an inertia that is not the tensor of a physical body (docs/method.md §2)."""
    for name, value in zip(_INERTIA_NAMES[:3], inertia[:3], strict=True):
        if not value > 0.0:
            raise ContentError(key, f"{name} must be > 0, got {value!r}")
    smallest, triangle = physical_margins(inertia)
    # A flat plate has I3 = I1 + I2 exactly, hence the rounding margin on the triangle.
    if smallest <= 0.0 or triangle < -1e-12 * sum(inertia[:3]):
        moments = np.linalg.eigvalsh(tensor_from_entries(inertia))
        listed = ", ".join(f"{moment:.6g}" for moment in moments)
        fault = (
            "not positive definite"
            if smallest <= 0.0
            else "the largest exceeds the sum of the other two (triangle inequality)"
        )
        raise ContentError(
            key, f"not a physical inertia tensor: principal moments [{listed}] kg m^2, {fault}"
        )


@config_class
class TrueBody:
    """A rigid part a virtual device carries on its shaft: the body under test (the truth
    that identification should recover) or the fixture that holds it.

    Two bodies are equal when their mass and arrays are."""

    mass: float = key(unit="kg", bound="> 0", doc="Mass.")
    inertia: np.ndarray = key(
        unit="kg m^2",
        names=_INERTIA_NAMES,
        check=_physical_inertia,
        doc="[Jx, Jy, Jz, Jxy, Jyz, Jxz] about O in the body frame, products as tensor "
        "entries (Jxy = -integral of x y dm); shape (6,), read-only.",
    )
    com: np.ndarray = key(
        unit="m",
        names=("x", "y", "z"),
        doc="Centre of mass [x, y, z] in the body frame; shape (3,), read-only.",
    )

    def __post_init__(self) -> None:
        # Own read-only copies, so that a frozen body stays frozen however it was built.
        for name, size in (("inertia", 6), ("com", 3)):
            array = np.array(getattr(self, name), dtype=float)
            if array.shape != (size,):
                raise ValueError(f"TrueBody.{name} must have shape ({size},), got {array.shape}")
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TrueBody):
            return NotImplemented
        return (
            self.mass == other.mass
            and np.array_equal(self.inertia, other.inertia)
            and np.array_equal(self.com, other.com)
        )

    @property
    def tensor(self) -> np.ndarray:
        """The inertia tensor J, kg m^2, shape (3, 3) (docs/method.md §2)."""
        return tensor_from_entries(self.inertia)



@config_class
class _ReferenceFile:
    """``reference.toml``: the reference body's certified data."""

    body: TrueBody = key(doc="The reference body, with the keys of virtual.toml's ``[body]``.")



def load_reference(path: str | os.PathLike) -> TrueBody:
    """Read a calibration's ``reference.toml``: the reference body's ``[body]`` table.

    The same keys as virtual.toml's ``[body]``: ``mass`` (kg), ``inertia = [Jx, Jy, Jz, Jxy,
    Jyz, Jxz]`` (kg m^2, body frame about O) and ``com = [x, y, z]`` (m).

    Raises
    ------
    InputError
        The file is missing or is not TOML; a key is missing, unknown or out of range; the
        inertia is not that of a physical body.
    """
    doc = read_file(path)
    try:
        return read_table(_ReferenceFile, doc).body
    except ContentError as error:
        raise InputError(f"{path}: {error}") from None


def placed_reference(body: TrueBody, mounting) -> TrueBody:
    """A reference body as it sits on the rig: reference.toml's tensor and centre of mass
    (in its own axes, about its own origin) placed by its folder's device.toml
    ``[mounting]`` (rotation R, origin o; docs/method.md §2, "Mountings";
    rsp_inertia.plant.geometry.place_body), exactly as identify's body is placed. Without
    ``[mounting]`` (``mounting`` None) the body itself: its axes are the rig's.

    Parameters
    ----------
    body : TrueBody
        The certified body (:func:`load_reference`).
    mounting : rsp_inertia.plant.device_config.Mounting or None
        The reference folder's ``[mounting]``.

    Returns
    -------
    TrueBody
        The same mass; the tensor about O and the centre of mass in rig axes.
    """
    if mounting is None:
        return body
    inertia, com = place_body(body.inertia, body.com, body.mass, mounting.rotation, mounting.origin)
    return TrueBody(mass=body.mass, inertia=inertia, com=com)


def write_reference(path: str | os.PathLike, body: TrueBody) -> None:
    """Write ``body`` to ``path`` as a ``reference.toml`` that :func:`load_reference` reads
    back equal; atomically.

    Raises
    ------
    ValueError
        ``body`` is no physical body (load_reference's message, with ``path`` in front).
    """
    header = "reference.toml: written by rsp_inertia.plant.config.write_reference"
    write_file(path, _ReferenceFile(body), header, lambda doc: read_table(_ReferenceFile, doc))
