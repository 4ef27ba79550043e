"""``reference.toml``: a reference body's certificate, and the rigid body it describes.

:class:`TrueBody` is a rigid body's mass properties (mass, inertia about O, centre of mass,
in its own frame): a calibration's reference body, read from ``reference.toml``, and the
virtual device's body and fixture (virtual.toml's ``[body]`` and ``[fixture]``,
rsp_inertia.virtual.config). :class:`Reference` is what a reference's certificate states:
the certified body, the covariance of its values (:data:`REFERENCE_PARAMETERS`; from
``body.mass_std``, ``body.inertia_std`` or ``body.inertia_cov`` and ``body.com_std``) and
the certificate's identification (``[certificate]``). docs/files.md documents every key;
the config classes below declare them (rsp_inertia.infra.toml_schema).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.toml_schema import (
    ContentError,
    config_class,
    iso_date,
    key,
    read_file,
    read_table,
)
from rsp_inertia.infra.toml_writer import write_file
from rsp_inertia.plant.geometry import physical_margins, place_body, tensor_from_entries

if TYPE_CHECKING:
    from rsp_inertia.plant.device_config import Mounting

__all__ = [
    "REFERENCE_PARAMETERS",
    "Certificate",
    "CertifiedBody",
    "Reference",
    "TrueBody",
    "load_reference",
    "placed_reference",
    "write_reference",
]

_INERTIA_NAMES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")

REFERENCE_PARAMETERS = ("mass", *_INERTIA_NAMES, "x", "y", "z")
"""The certified values, in the order of :attr:`Reference.cov`: the mass (kg), the tensor's
entries about the body frame's origin (kg m^2) and the centre of mass (m)."""


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



def _covariance_6(rows: tuple[tuple[float, ...], ...], key: str) -> None:
    """Refuse a 6 x 6 matrix that is no covariance (symmetric, positive semi-definite)."""
    matrix = np.array(rows, dtype=float)
    if matrix.shape != (6, 6):
        raise ContentError(key, f"must be 6 x 6 (rows and columns {', '.join(_INERTIA_NAMES)})")
    if not np.allclose(matrix, matrix.T, rtol=1e-9, atol=0.0):
        raise ContentError(key, "must be symmetric")
    smallest = float(np.linalg.eigvalsh(matrix).min())
    if smallest < -1e-9 * max(float(np.abs(matrix).max()), np.finfo(float).tiny):
        raise ContentError(
            key, f"not a covariance: not positive semi-definite (eigenvalue {smallest:.3g})"
        )


def _issued(text: str, key: str) -> None:
    """Refuse a date of issue that is not an ISO date ``YYYY-MM-DD`` (or empty: not stated)."""
    if text:
        iso_date(text, key)


@config_class
class CertifiedBody(TrueBody):
    """A reference body as its certificate states it: the keys of :class:`TrueBody` and
    their standard uncertainties (JCGM 100: the std of each certified value; a certificate
    that states an expanded uncertainty U with a coverage factor k states the std U / k).
    Every std left out is zero: that value is taken as exact."""

    mass_std: float = key(0.0, unit="kg", bound=">= 0", doc="Std of ``mass``.")
    inertia_std: tuple[float, ...] | None = key(
        None,
        unit="kg m^2",
        names=_INERTIA_NAMES,
        bound=">= 0",
        doc="Stds of ``inertia``'s six entries, independent; or give ``inertia_cov``.",
    )
    inertia_cov: tuple[tuple[float, ...], ...] | None = key(
        None,
        unit="kg^2 m^4",
        check=_covariance_6,
        doc="The 6 x 6 covariance of ``inertia``'s entries, in its order (a certificate that "
        "states correlations); instead of ``inertia_std``.",
    )
    com_std: tuple[float, ...] | None = key(
        None, unit="m", names=("x", "y", "z"), bound=">= 0", doc="Stds of ``com``."
    )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CertifiedBody):
            return NotImplemented
        return TrueBody.__eq__(self, other) and all(
            np.array_equal(
                np.asarray(getattr(self, name), dtype=float),
                np.asarray(getattr(other, name), dtype=float),
            )
            for name in ("mass_std", "inertia_std", "inertia_cov", "com_std")
        )


@config_class
class Certificate:
    """The reference body's calibration certificate, for the records (``[certificate]``)."""

    id: str = key(doc="The certificate's number.")
    issuer: str = key("", doc="The laboratory that issued it.")
    date: str = key("", check=_issued, doc="Its date of issue, YYYY-MM-DD.")


@config_class
class _ReferenceFile:
    """``reference.toml``: the reference body's certified data."""

    body: CertifiedBody = key(
        doc="The reference body, with the keys of virtual.toml's ``[body]`` and their stds."
    )
    certificate: Certificate | None = key(doc="The certificate's identification.")


@dataclass(frozen=True)
class Reference:
    """A reference body's certificate (``reference.toml``): the certified body, the
    covariance of its values and the certificate's identification; placed on the rig by
    the reference folder's ``[mounting]``."""

    body: TrueBody
    """The certified values, in the body's own axes about its own origin."""
    cov: np.ndarray = field(default_factory=lambda: np.zeros((10, 10)))
    """(10, 10) covariance of the certified values, in the order of
    :data:`REFERENCE_PARAMETERS`; read-only. Zero: taken as exact."""
    certificate: Certificate | None = None
    """The certificate's id, issuer and date, when reference.toml states them."""
    mounting: Mounting | None = None
    """The reference folder's device.toml ``[mounting]``
    (rsp_inertia.plant.device_config.Mounting), or None: the body's axes are the rig's."""

    def __post_init__(self) -> None:
        cov = np.array(self.cov, dtype=float)
        if cov.shape != (10, 10):
            raise ValueError(f"Reference.cov must have shape (10, 10), got {cov.shape}")
        cov.flags.writeable = False
        object.__setattr__(self, "cov", cov)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Reference):
            return NotImplemented
        return (
            self.body == other.body
            and np.array_equal(self.cov, other.cov)
            and self.certificate == other.certificate
            and self.mounting == other.mounting
        )

    @property
    def stated(self) -> bool:
        """Whether the certificate states an uncertainty for any of its values."""
        return bool(np.any(np.diag(self.cov) > 0.0))

    @property
    def values(self) -> np.ndarray:
        """(10,) the certified values, in the order of :data:`REFERENCE_PARAMETERS`."""
        return np.concatenate([[self.body.mass], self.body.inertia, self.body.com])

    @property
    def placed(self) -> TrueBody:
        """The body as it sits on the rig (:func:`placed_reference`)."""
        return placed_reference(self.body, self.mounting)

    def placed_at(self, values: np.ndarray) -> TrueBody:
        """The body of certified values ``values`` (order of :data:`REFERENCE_PARAMETERS`)
        as it sits on the rig: for the derivatives of what depends on the certificate."""
        values = np.asarray(values, dtype=float)
        body = TrueBody(mass=values[0], inertia=values[1:7], com=values[7:10])
        return placed_reference(body, self.mounting)


def _reference(read: _ReferenceFile) -> Reference:
    """The Reference of a read reference.toml: its stds as a block-diagonal covariance."""
    body = read.body
    cov = np.zeros((10, 10))
    cov[0, 0] = body.mass_std**2
    if body.inertia_cov is not None:
        cov[1:7, 1:7] = np.array(body.inertia_cov, dtype=float)
    elif body.inertia_std is not None:
        cov[1:7, 1:7] = np.diag(np.square(body.inertia_std))
    if body.com_std is not None:
        cov[7:10, 7:10] = np.diag(np.square(body.com_std))
    plain = TrueBody(mass=body.mass, inertia=body.inertia, com=body.com)
    return Reference(body=plain, cov=cov, certificate=read.certificate)


def load_reference(path: str | os.PathLike) -> Reference:
    """Read a calibration's ``reference.toml``: the reference body's certificate.

    ``[body]`` has the same keys as virtual.toml's: ``mass`` (kg), ``inertia = [Jx, Jy, Jz,
    Jxy, Jyz, Jxz]`` (kg m^2, body frame about O) and ``com = [x, y, z]`` (m); and their
    standard uncertainties, ``mass_std``, ``inertia_std`` (or the 6 x 6 ``inertia_cov``)
    and ``com_std`` (:class:`CertifiedBody`). ``[certificate]`` (optional): ``id``,
    ``issuer``, ``date``.

    Returns
    -------
    Reference
        The certified body, the covariance of its values, the certificate; no mounting
        (the reference folder's device.toml places it: ``dataclasses.replace(reference,
        mounting=...)``).

    Raises
    ------
    InputError
        The file is missing or is not TOML; a key is missing, unknown or out of range; the
        inertia is not that of a physical body; both ``inertia_std`` and ``inertia_cov``;
        a covariance that is not one.
    """
    doc = read_file(path)
    try:
        read = read_table(_ReferenceFile, doc)
    except ContentError as error:
        raise InputError(f"{path}: {error}") from None
    if read.body.inertia_std is not None and read.body.inertia_cov is not None:
        raise InputError(
            f"{path}: body.inertia_cov: give either body.inertia_std or body.inertia_cov, "
            "not both"
        )
    return _reference(read)


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


def write_reference(path: str | os.PathLike, reference: Reference | TrueBody) -> None:
    """Write ``reference`` to ``path`` as a ``reference.toml`` that :func:`load_reference`
    reads back equal (a TrueBody: a certificate without stds); atomically.

    Raises
    ------
    ValueError
        ``reference`` is no physical body (load_reference's message, with ``path`` in
        front), or its covariance couples the mass, the tensor and the centre of mass,
        which reference.toml cannot state.
    """
    if isinstance(reference, TrueBody):
        reference = Reference(body=reference)
    cov = reference.cov
    coupled = cov.copy()
    for block in (slice(0, 1), slice(1, 7), slice(7, 10)):
        coupled[block, block] = 0.0
    if np.any(coupled != 0.0):
        raise ValueError("reference.toml states no covariance between mass, tensor and com")
    inertia_cov = cov[1:7, 1:7]
    diagonal = not np.any(inertia_cov - np.diag(np.diag(inertia_cov)))
    com_var = np.diag(cov)[7:10]
    body = CertifiedBody(
        mass=reference.body.mass,
        inertia=reference.body.inertia,
        com=reference.body.com,
        mass_std=float(np.sqrt(cov[0, 0])),
        inertia_std=tuple(np.sqrt(np.diag(inertia_cov))) if diagonal and inertia_cov.any() else None,
        inertia_cov=None if diagonal else tuple(tuple(row) for row in inertia_cov),
        com_std=tuple(np.sqrt(com_var)) if com_var.any() else None,
    )
    header = "reference.toml: written by rsp_inertia.plant.config.write_reference"
    write_file(
        path,
        _ReferenceFile(body, reference.certificate),
        header,
        lambda doc: read_table(_ReferenceFile, doc),
    )
