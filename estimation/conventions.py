"""The rig's conventions verified from the calibration runs (docs/method.md §1, §5
Calibration).

A rig built with a sign the other way round from docs/method.md §1 does not fail: it measures
another body. A gear that turns the outer frame the other way (psi = -lambda phi) flips the
reduced inertia's first harmonics, and with them Jxz and Jyz; phi read left-handed (the shaft
read from its other end: encoder and torque both reversed) mirrors the body in x, flipping
Jxy, Jxz and x_c; an encoder zeroed half a turn off turns it about z by pi, flipping Jxz,
Jyz, x_c and y_c; an encoder zeroed a little off turns it about z by that angle. An
axisymmetric reference on the shaft's axis shows none of them. A reference whose certified
tensor has products in rig axes (mounted turned: its folder's device.toml ``[mounting]``)
shows each as the sign of its terms in the balances.

So calibrate fits, for each convention of :data:`CONVENTIONS`, a free factor k on the
reference's terms that the convention's alternative flips (the unknown
:data:`CONVENTION_FACTOR`, rsp_inertia.estimation.calibration): k = +1 where the rig keeps
the stated convention, -1 where it flips it. A factor more than :data:`EXCLUDED_STDS` stds
from +1 and nearer -1 refuses the calibration, naming the convention, the evidence and the
fix; one that many stds from -1 verifies it; one that cannot tell (a reference without the
terms) leaves it unverified, and the one line the calibration keeps
(:attr:`ConventionCheck.statement`) says so and how to verify it. These fits come before the
encoder's and the drive's terms are taken as measured, so that a sign slip is never taken
for a drive loss or an encoder's eccentricity. The encoder's small zero offset is measured
with the reference as an unknown of the fit (its column the known terms' angle slope) and
refused beyond :data:`ZERO_LIMIT_DEG`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import REFERENCE_PARAMETERS, Device, Reference, TrueBody
from rsp_inertia.plant.geometry import GRAVITY_NAMES, HARMONIC_NAMES
from rsp_inertia.plant.model import inertia_harmonics

__all__ = [
    "CERTIFIED_STDS",
    "CONVENTIONS",
    "CONVENTION_FACTOR",
    "EXCLUDED_STDS",
    "REFERENCE_TERMS",
    "ZERO_LIMIT_DEG",
    "ZERO_STD_LIMIT_DEG",
    "Convention",
    "ConventionCheck",
    "certificate_jacobian",
    "certified_terms_std",
    "check_conventions",
    "reference_terms",
    "shows_orientation",
    "significant_terms",
    "unverified_conventions",
]

CONVENTION_FACTOR = "convention"
"""The unknown k of the convention check: the factor on the reference's flipped terms."""

REFERENCE_TERMS = (*HARMONIC_NAMES, *GRAVITY_NAMES)
"""The reference's terms in a stage's balance: its reduced inertia's harmonics and its
gravity terms (:func:`reference_terms`)."""

EXCLUDED_STDS = 5.0
"""A convention's factor this many stds from one of its values (+1 stated, -1 flipped)
excludes that value."""

ZERO_LIMIT_DEG = 10.0
"""deg: an encoder zero offset beyond this is refused (the rig's encoder is zeroed elsewhere
than docs/method.md §1's phi = 0; the fit's linearisation is meant for small offsets)."""

ZERO_STD_LIMIT_DEG = 1.0
"""deg: the encoder's zero is taken as measured when its std is at most this; a reference
that shows the rig's orientation less well leaves it unmeasured (0, exact)."""

ORIENTATION_TOLERANCE = 1e-9
"""A reference shows the rig's orientation when a harmonic exceeds this fraction of its M0
or its centre of mass is off the shaft's axis (:func:`shows_orientation`)."""

CERTIFIED_STDS = 5.0
"""A reference's term shows the rig's orientation only beyond this many of its stds by the
reference's certificate (:func:`significant_terms`)."""

COMMISSIONING = "docs/real-rig.md, commissioning"
"""Where the docs say how to mount a reference that verifies the conventions."""


@dataclass(frozen=True)
class Convention:
    """One of the rig's conventions, by what its alternative flips."""

    name: str
    """What is verified, e.g. "the gear's sense"."""
    flips: tuple[str, ...]
    """The reference's terms (of :data:`REFERENCE_TERMS`) that the alternative flips."""
    entries: tuple[str, ...]
    """The body's entries those terms carry, for messages."""
    fault: str
    """The alternative, as a message states it."""
    fix: str
    """How to fix the rig."""

    @property
    def mask(self) -> np.ndarray:
        """Boolean mask over :data:`REFERENCE_TERMS` of the flipped terms."""
        return np.array([term in self.flips for term in REFERENCE_TERMS])


_GEAR_FIX = (
    "the outer frame must turn positively about the vertical (up) when phi turns positively "
    "(docs/method.md §1): reverse the gear's sense"
)
_HANDED_FIX = (
    "reverse both the encoder's counting direction and the torque's sign in the drive, so "
    "that phi turns right-handed about the body's +z (docs/method.md §1)"
)

CONVENTIONS = (
    Convention(
        "the gear's sense",
        ("Ms1", "Mc1"),
        ("Jxz", "Jyz"),
        "the gear turns the outer frame the other way (psi = -lambda phi, where device.toml's "
        "gear_ratio states +lambda)",
        _GEAR_FIX,
    ),
    Convention(
        "phi's handedness",
        ("Ms2", "Ms1", "Gs"),
        ("Jxy", "Jxz", "x_c"),
        "phi is read left-handed (the encoder and the torque both reversed: the shaft read "
        "from its other end)",
        _HANDED_FIX,
    ),
    Convention(
        "the gear's sense and phi's handedness together",
        ("Ms2", "Mc1", "Gs"),
        ("Jxy", "Jyz", "x_c"),
        "the gear turns the outer frame the other way and phi is read left-handed",
        f"{_GEAR_FIX}; and {_HANDED_FIX}",
    ),
    Convention(
        "the encoder's zero to the half turn",
        ("Ms1", "Mc1", "Gs", "Gc"),
        ("Jxz", "Jyz", "x_c", "y_c"),
        "the encoder's zero is half a turn off (it reads 0 where the body's y points down)",
        "zero the encoder where the body frame's y points up (docs/method.md §1)",
    ),
)
"""The conventions the check verifies, each by the terms its alternative flips."""


def reference_terms(reference: TrueBody, gear_ratio: float, gravity: float) -> np.ndarray:
    """The reference body's terms of one stage, :data:`REFERENCE_TERMS`: its reduced
    inertia's harmonics (no tare) and its gravity terms m g x_c, m g y_c, in rig axes
    (docs/method.md §2-3).

    Parameters
    ----------
    reference : TrueBody
        The reference as it sits on the rig (rsp_inertia.plant.config.placed_reference).
    gear_ratio : float
        The stage's lambda.
    gravity : float
        m/s^2, device.toml's.

    Returns
    -------
    numpy.ndarray, shape (7,)
        [M0, Mc2, Ms2, Ms1, Mc1] (kg m^2), [Gs, Gc] (N m).
    """
    weight = reference.mass * gravity
    return np.concatenate(
        [inertia_harmonics(reference.inertia, gear_ratio, 0.0), weight * reference.com[:2]]
    )


def significant_terms(
    reference: TrueBody, terms: np.ndarray, terms_std: np.ndarray | None = None
) -> np.ndarray:
    """Boolean mask over :data:`REFERENCE_TERMS` of one stage's ``terms``: those beyond
    :data:`ORIENTATION_TOLERANCE` of the reference's M0 (harmonics) or of its mass in kg
    times 1 N m (gravity: a centre of mass off the axis by more than about 1e-10 m), and
    beyond :data:`CERTIFIED_STDS` of their std ``terms_std`` by the reference's certificate
    (a product certified as 5e-6 +- 5e-6 shows nothing): the ones that can show the rig's
    orientation (M0 never does).

    Parameters
    ----------
    reference : TrueBody
        The reference as it sits on the rig.
    terms : numpy.ndarray, shape (7,)
        Its terms in one stage (:func:`reference_terms`).
    terms_std : numpy.ndarray, shape (7,), optional
        Their stds by the certificate; None: the certificate's values exact.

    Returns
    -------
    numpy.ndarray of bool, shape (7,)
    """
    scale = np.array([np.inf] + [terms[0]] * 4 + [reference.mass] * 2)
    shown = np.abs(terms) > ORIENTATION_TOLERANCE * scale
    if terms_std is not None:
        shown &= np.abs(terms) > CERTIFIED_STDS * np.asarray(terms_std)
    return shown


def shows_orientation(
    reference: TrueBody, device: Device, certificate: Reference | None = None
) -> bool:
    """Whether the reference's balances depend on the angle: a harmonic of its reduced
    inertia or a gravity term, on some stage (:func:`significant_terms`, beyond its
    ``certificate``'s stds when it states them; else no zero offset and no convention can
    show in them).

    Parameters
    ----------
    reference : TrueBody
        The reference as it sits on the rig.
    device : Device
        The calibrated experiment's device (its stages, gravity).
    certificate : Reference, optional
        The reference's certificate, whose stds a term must exceed.

    Returns
    -------
    bool
    """
    for st in device.stages:
        terms = reference_terms(reference, st.gear_ratio, device.gravity)
        terms_std = None
        if certificate is not None and certificate.stated:
            D = certificate_jacobian(certificate, st.gear_ratio, device.gravity)
            terms_std = certified_terms_std(D, certificate.cov)
        if significant_terms(reference, terms, terms_std).any():
            return True
    return False


def certified_terms_std(jacobian: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """(7,) the stds of one stage's reference terms by the certificate: sqrt(diag(D C D^T)),
    D its :func:`certificate_jacobian`, C the certificate's covariance.

    Parameters
    ----------
    jacobian : numpy.ndarray, shape (7, 10)
        D.
    cov : numpy.ndarray, shape (10, 10)
        C (rsp_inertia.plant.config.Reference.cov).

    Returns
    -------
    numpy.ndarray, shape (7,)
    """
    return np.sqrt(np.einsum("ij,jk,ik->i", jacobian, cov, jacobian))


def certificate_jacobian(certificate: Reference, gear_ratio: float, gravity: float) -> np.ndarray:
    """(7, 10) d terms / d value: how one stage's reference terms (:func:`reference_terms`: its
    reduced inertia's harmonics and its gravity terms, in rig axes) move with the certificate's values (rsp_inertia.plant.config.REFERENCE_PARAMETERS: mass, the
    tensor about the body's origin, the centre of mass, in the body's own axes), the body
    placed by the reference folder's ``[mounting]``.

    The terms are at most quadratic in the values (the parallel-axis terms are m times the
    centre of mass; docs/method.md §2, "Mountings"), so central differences are exact but for
    rounding; the steps are the values' own sizes (1e-3 of them, 1e-6 m for a centre of mass
    at the origin).

    Parameters
    ----------
    certificate : Reference
        The reference's certificate, with its folder's mounting.
    gear_ratio : float
        The stage's lambda.
    gravity : float
        m/s^2, device.toml's.

    Returns
    -------
    numpy.ndarray, shape (7, 10)
        Rows [M0, Mc2, Ms2, Ms1, Mc1, Gs, Gc], columns the certificate's values.
    """
    values = certificate.values
    scale = np.abs(values)
    scale[7:] = np.maximum(scale[7:], 1e-3)
    scale[1:7] = np.maximum(scale[1:7], np.abs(values[1:4]).max())
    D = np.empty((len(REFERENCE_TERMS), len(REFERENCE_PARAMETERS)))
    for i, step in enumerate(1e-3 * scale):
        up, down = values.copy(), values.copy()
        up[i] += step
        down[i] -= step
        D[:, i] = (
            reference_terms(certificate.placed_at(up), gear_ratio, gravity)
            - reference_terms(certificate.placed_at(down), gear_ratio, gravity)
        ) / (2.0 * step)
    return D


@dataclass(frozen=True)
class ConventionCheck:
    """What the reference showed of the rig's conventions."""

    factors: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Convention name -> (k, std) of its factor; (nan, inf) where the reference has none of
    the convention's terms."""
    zero_measured: bool = False
    """Whether the reference measured the encoder's zero offset."""
    zero: float = 0.0
    """rad, the zero offset measured (0 when not)."""
    zero_std: float = 0.0
    """rad, its std."""
    reference: bool = True
    """Whether a reference was calibrated with (else nothing was verified)."""

    def with_zero(self, known: KnownTerms) -> ConventionCheck:
        """This check with the zero offset of the calibration's final terms ``known``."""
        if not self.zero_measured:
            return self
        return replace(self, zero=known.zero, zero_std=float(known.std[known.zero_slice][0]))

    def verified(self) -> list[str]:
        """The conventions whose alternative the reference excludes."""
        return [
            name for name, (k, std) in self.factors.items() if (k + 1.0) / std >= EXCLUDED_STDS
        ]

    @property
    def statement(self) -> str:
        """The calibration's one line on the conventions (module docstring)."""
        if not self.reference:
            return (
                "conventions not verified: no reference body, so the gear's sense, phi's "
                "handedness and the encoder's zero are taken as docs/method.md §1 states them; "
                "calibrate with a reference mounted turned, its certified tensor with products "
                f"in rig axes, to verify them ({COMMISSIONING})"
            )
        verified = self.verified()
        missing = [c for c in CONVENTIONS if c.name not in verified]
        zero = (
            f"the encoder's zero offset {math.degrees(self.zero):+.4f} +- "
            f"{math.degrees(self.zero_std):.4f} deg, measured and applied"
            if self.zero_measured
            else "the encoder's zero offset not measured"
        )
        if not missing:
            apart = min((k + 1.0) / std for k, std in self.factors.values())
            return (
                "conventions verified by the reference: the gear's sense, phi's handedness "
                f"and the encoder's zero (each alternative at least {apart:.0f} stds away; "
                f"{zero})"
            )
        # A combination is named only when both its conventions are verified alone.
        named = [c for c in missing if " together" not in c.name] or missing
        entries = list(dict.fromkeys(e for c in missing for e in c.entries))
        shown = f"; verified: {_listed(verified)}" if verified else ""
        return (
            f"conventions not verified: {_listed([c.name for c in named])} (the reference "
            f"has too little {_listed(entries, 'or')} in rig axes to show "
            f"{'them' if len(named) > 1 else 'it'}){shown}; {zero}; to verify them, mount the "
            "reference turned (its folder's device.toml [mounting]; "
            f"{COMMISSIONING})"
        )


def _listed(items, conjunction: str = "and") -> str:
    """"a, b and c" of ``items``."""
    items = list(items)
    if len(items) < 2:
        return "".join(items)
    return f"{', '.join(items[:-1])} {conjunction} {items[-1]}"


def unverified_conventions() -> ConventionCheck:
    """The check of a calibration without a reference: nothing verified."""
    return ConventionCheck(reference=False)


def check_conventions(
    fitter: Callable[..., tuple[KnownTerms, object]], known: KnownTerms, source: str | None
) -> ConventionCheck:
    """The conventions the reference shows (module docstring), refusing a flipped one or an
    encoder zero beyond :data:`ZERO_LIMIT_DEG`.

    Parameters
    ----------
    fitter : callable
        ``fitter(flip=mask)`` -> (KnownTerms, BalanceFit): the calibration fit of the first
        pass's balances with the reference's terms of ``mask`` under the free factor
        :data:`CONVENTION_FACTOR` (rsp_inertia.estimation.calibration.fit_calibration).
    known : KnownTerms
        That fit's terms without the factor: the encoder's zero offset and its std (a std of
        0: the zero is no unknown of the fit).
    source : str or None
        The reference experiment's name, for messages.

    Returns
    -------
    ConventionCheck
        The factors and whether the zero is measured.

    Raises
    ------
    InputError
        A convention flipped (naming it, the evidence and the fix), or the encoder's zero
        beyond the bound; one line each.
    """
    where = f"{source}: " if source else ""
    factors = {}
    for convention in CONVENTIONS:
        _, fit = fitter(flip=convention.mask)
        if CONVENTION_FACTOR in fit.names:
            i = fit.index(CONVENTION_FACTOR)
            factors[convention.name] = (float(fit.x[i]), float(math.sqrt(fit.cov[i, i])))
        else:
            factors[convention.name] = (math.nan, math.inf)
    flipped = [
        convention
        for convention in CONVENTIONS
        if factors[convention.name][0] < 0.0
        and (1.0 - factors[convention.name][0]) / factors[convention.name][1] >= EXCLUDED_STDS
    ]
    if flipped:
        worst = min(flipped, key=lambda c: abs(factors[c.name][0] + 1.0) / factors[c.name][1])
        k, std = factors[worst.name]
        raise InputError(
            f"{where}the rig's conventions: {worst.fault}: the reference's "
            f"{_listed(worst.entries)} "
            f"come out at {k:+.3f} +- {std:.3f} times their certified values in rig axes, where "
            f"the stated conventions give +1 ({(1.0 - k) / std:.0f} stds away); {worst.fix}; "
            "nothing written"
        )
    zero_std = float(known.std[known.zero_slice][0])
    measured = 0.0 < zero_std <= math.radians(ZERO_STD_LIMIT_DEG)
    if measured and abs(known.zero) > math.radians(ZERO_LIMIT_DEG):
        raise InputError(
            f"{where}the rig's conventions: the encoder's zero is off by about "
            f"{math.degrees(known.zero):+.1f} deg (+- {math.degrees(zero_std):.1g}) from phi = 0 "
            "where the body frame's y points up (the reference's harmonics come out turned by "
            f"it), beyond the {ZERO_LIMIT_DEG:g} deg calibrate measures and applies: zero the "
            "encoder there (docs/method.md §1); nothing written"
        )
    return ConventionCheck(
        factors=factors,
        zero_measured=measured,
        zero=known.zero if measured else 0.0,
        zero_std=zero_std if measured else 0.0,
    )
