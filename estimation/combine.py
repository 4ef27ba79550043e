"""One body from several mountings: the tensor and the whole centre of mass in body axes.

docs/method.md §5, "Combining mountings". Each mounting k is an experiment whose result.json
holds the tensor's six entries about the rig's centre in rig axes and the gravity terms
[m g x_c, m g y_c], with their joint covariance C_k (8 x 8). The body was mounted turned by
R_k (v_rig = R_k v_body) with its frame's origin at o_k (rig axes), so for the unknowns
theta = [the entries about the body frame's origin in body axes (6), the centre of mass c in
body axes (3)] each mounting measures

    y_k = f_k(theta) = [place_body entries (6), m g (o_k + R_k c)_x, m g (o_k + R_k c)_y]

(rsp_inertia.plant.geometry.place_body: the rotation and the parallel-axis theorem), affine
in theta: f_k(theta) = b_k + H_k theta. One generalised least squares over every mounting
(weights C_k^-1) gives theta and its covariance; the residuals test whether the mountings
agree within their noise (a body not seated as the fixture drawing says is the error that
dominates real measurements). z along the shaft never enters a mounting's gravity terms, so
the centre of mass along the body direction that a mounting keeps on the shaft comes from the
other mountings: a set in which every mounting keeps the same body direction on the shaft
(and whose origins do not tell it apart through the parallel-axis terms) is refused.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import chdtrc

from rsp_inertia.estimation.coverage import (
    DEFAULT_COVERAGE_FACTOR,
    ExpandedUncertainty,
    expanded_uncertainty,
)
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.frozen import freeze_arrays, read_only
from rsp_inertia.plant.experiment import Experiment
from rsp_inertia.plant.geometry import (
    ENTRY_KEYS,
    physical_warnings,
    place_body,
    principal,
    principal_uncertainty,
)

__all__ = [
    "COM_KEYS",
    "CONSISTENCY_P",
    "MEASUREMENT_KEYS",
    "NAME_LIMIT",
    "PARAMETER_KEYS",
    "RANK_TOLERANCE",
    "RESIDUAL_FLOOR",
    "Combination",
    "MountedResult",
    "combine_mountings",
    "mounting_model",
    "read_mounting",
]

MEASUREMENT_KEYS = (*ENTRY_KEYS, "m_g_xc", "m_g_yc")
"""What one mounting measures, in the order of result.json's ``covariance``."""

COM_KEYS = ("x", "y", "z")
"""The centre of mass's coordinates in body axes."""

PARAMETER_KEYS = (*ENTRY_KEYS, *COM_KEYS)
"""The combination's unknowns, in the order of :attr:`Combination.cov`."""

CONSISTENCY_P = 0.01
"""The mountings are said to disagree when the chi^2 of the combination's residuals has
p < CONSISTENCY_P: a set of correctly described mountings, whose result.json covariances are
honest, then raises a false warning in 1 set of 100."""

NAME_LIMIT = 3.0
"""When the mountings disagree, the warning names every mounting's measured quantity whose
residual is beyond this many of its standard deviations (a Gaussian residual goes beyond 3
std with probability 0.0027)."""

RANK_TOLERANCE = 1e-9
"""A direction of the unknowns is unobservable when the least squares' (column-scaled)
singular value along it is below this fraction of the largest: exact dependence up to
rounding and the 1e-9 to which a stated rotation is orthonormal."""

RESIDUAL_FLOOR = 1e-8
"""A residual whose variance is below this fraction of its measurement's is not tested: the
other mountings do not measure that quantity, so it fits exactly (reported as None)."""


@dataclass(frozen=True)
class MountedResult:
    """One mounting of the body: what identify measured and how the body was mounted."""

    name: str
    """Names the mounting in messages (its experiment folder)."""
    entries: np.ndarray
    """(6,) [Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2, about the rig's centre in rig axes
    (result.json ``tensor``)."""
    gravity: np.ndarray
    """(2,) [m g x_c, m g y_c], N m, rig axes (result.json ``gravity_torque``)."""
    cov: np.ndarray
    """(8, 8) joint covariance of [entries, gravity] (result.json ``covariance``)."""
    rotation: np.ndarray
    """(3, 3) R, body axes -> rig axes: v_rig = R v_body (device.toml ``[mounting]``)."""
    origin: np.ndarray
    """(3,) m, the body frame's origin in rig axes (device.toml ``[mounting]``)."""
    mass: float
    """kg, the body's (device.toml ``[body] mass``)."""
    g: float
    """m/s^2, the gravity of the rig (device.toml ``[device] gravity``)."""

    def __post_init__(self) -> None:
        for name, shape in (
            ("entries", (6,)), ("gravity", (2,)), ("cov", (8, 8)),
            ("rotation", (3, 3)), ("origin", (3,)),
        ):
            try:
                value = np.array(getattr(self, name), dtype=float)
            except (TypeError, ValueError):
                value = np.full(0, np.nan)
            if value.shape != shape or not np.all(np.isfinite(value)):
                raise InputError(f"{self.name}: {name} must be {shape} finite numbers")
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        for name in ("mass", "g"):
            try:
                object.__setattr__(self, name, float(getattr(self, name)))
            except (TypeError, ValueError):
                raise InputError(f"{self.name}: {name} must be a number") from None

    @property
    def measured(self) -> np.ndarray:
        """(8,) y = [entries, gravity]: what the mounting measured."""
        return np.concatenate([self.entries, self.gravity])

    @classmethod
    def from_result(
        cls,
        name: str,
        document: dict,
        rotation: np.ndarray,
        origin: np.ndarray,
        mass: float,
        g: float,
    ) -> MountedResult:
        """The mounting from identify's result.json document and its ``[mounting]``, mass and
        gravity.

        Parameters
        ----------
        name : str
            Names the mounting in messages (its experiment folder).
        document : dict
            The parsed result.json (docs/files.md: ``tensor``, ``gravity_torque``,
            ``covariance``).
        rotation : numpy.ndarray, shape (3, 3)
            R, body axes -> rig axes: v_rig = R v_body (device.toml ``[mounting]``).
        origin : numpy.ndarray, shape (3,)
            m, the body frame's origin in rig axes (device.toml ``[mounting]``).
        mass : float
            kg, the body's (device.toml ``[body] mass``).
        g : float
            m/s^2, the gravity of the rig (device.toml ``[device] gravity``).

        Returns
        -------
        MountedResult
            What the mounting measured and how the body was mounted.

        Raises
        ------
        InputError
            A document without these keys (one line naming ``name`` and the key; a
            result.json without ``covariance`` is an older identify's: run identify again).
        """
        try:
            entries = [document["tensor"][key] for key in ENTRY_KEYS]
            torque = document["gravity_torque"]
            gravity = [torque["m_g_xc"], torque["m_g_yc"]]
        except (KeyError, TypeError) as missing:
            raise InputError(f"{name}: result.json has no {missing}") from None
        if "covariance" not in document:
            raise InputError(
                f"{name}: result.json has no covariance (an older identify wrote it): run "
                "identify on it again"
            )
        return cls(name, entries, gravity, document["covariance"], rotation, origin, mass, g)


@dataclass(frozen=True)
class Combination:
    """The body in its own axes from several mountings; :meth:`to_json` is body.json's text,
    :meth:`to_dict` its document.

    The tensor is about the body frame's origin, in body axes (products as tensor entries,
    Jxy = -integral of x y dm), the centre of mass in body axes; ``cov`` their joint
    covariance from the generalised least squares (docs/method.md §5, "Combining
    mountings").
    """

    entries: np.ndarray
    """(6,) [Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2."""
    com: np.ndarray
    """(3,) [x_c, y_c, z_c], m."""
    cov: np.ndarray
    """(9, 9) covariance of [entries, com], order :data:`PARAMETER_KEYS` (kg^2 m^4, kg m^3,
    m^2)."""
    names: tuple[str, ...]
    """The mountings, in the order of ``residuals``."""
    residuals: np.ndarray
    """(mountings, 8) each measured quantity's residual (measured - fitted) over the std of
    the residual, order :data:`MEASUREMENT_KEYS`; NaN where the other mountings do not
    measure the quantity (it fits exactly)."""
    chi2: float
    """The weighted sum of squared residuals."""
    dof: int
    """8 x mountings - 9."""
    p: float
    """P(chi^2 >= the value found) for mountings that agree within their covariances."""
    warnings: list[str] = field(default_factory=list)
    """The mountings' disagreement (statistic and the entries that disagree), a tensor that
    is not a physical one."""
    mass: float | None = None
    """kg, the body's mass as the mountings' device.toml ``[body] mass`` states it (the rig
    measures m g x_c, not m: the centre of mass is computed with this mass); body.json's
    ``mass``."""
    provenance: dict | None = None
    """body.json's ``provenance`` (``rsp-inertia combine``: when, by which software, the
    sha256 of each mounting's result.json); None: not recorded (the library alone)."""
    coverage_factor: float = DEFAULT_COVERAGE_FACTOR
    """k of the expanded uncertainties U = k u (``combine --coverage-factor``)."""

    @cached_property
    def expanded_uncertainty(self) -> ExpandedUncertainty:
        """The GUM statement: U = k u of the entries and of x_c, y_c, z_c, the principal
        moments' and axes' Monte Carlo intervals (rsp_inertia.estimation.coverage; computed
        once, when first read)."""
        return expanded_uncertainty(
            self.entries, self.cov[:6, :6], self.coverage_factor, com_std=self.com_std,
            com_keys=COM_KEYS,
        )

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen

    @property
    def entries_std(self) -> np.ndarray:
        """(6,) kg m^2."""
        return read_only(np.sqrt(np.diag(self.cov)[:6]))

    @property
    def com_std(self) -> np.ndarray:
        """(3,) m."""
        return read_only(np.sqrt(np.diag(self.cov)[6:]))

    @property
    def principal_moments(self) -> np.ndarray:
        """(3,) kg m^2, ascending (rsp_inertia.plant.geometry.principal)."""
        return read_only(principal(self.entries)[0])

    @property
    def principal_axes(self) -> np.ndarray:
        """(3, 3) unit axes in body axes, one per row, in the order of the moments."""
        return read_only(principal(self.entries)[1])

    @property
    def principal_moments_std(self) -> np.ndarray:
        """(3,) kg m^2, to first order (rsp_inertia.plant.geometry.principal_uncertainty)."""
        return read_only(principal_uncertainty(self.entries, self.cov[:6, :6])[0])

    @property
    def principal_axes_tilt_std(self) -> np.ndarray:
        """(3,) rad, each principal axis's rms tilt (infinite for two equal moments)."""
        return read_only(principal_uncertainty(self.entries, self.cov[:6, :6])[1])

    def to_json(self) -> str:
        """The text of body.json: :meth:`to_dict` indented, with a final newline."""
        return json.dumps(self.to_dict(), indent=2) + "\n"

    def to_dict(self) -> dict:
        """body.json's document (docs/files.md): ``tensor``, ``tensor_std`` (keys Jx ... Jxz,
        kg m^2), ``com``, ``com_std`` (keys x, y, z, m), ``covariance`` (9 x 9, order
        Jx, Jy, Jz, Jxy, Jyz, Jxz, x, y, z), the principal moments and axes with their stds,
        per mounting its residuals in stds (None: not tested), the consistency test, the
        warnings, the mass the centre of mass was computed with and, when recorded, the
        provenance."""
        tilt = self.principal_axes_tilt_std
        return {
            "tensor": dict(zip(ENTRY_KEYS, map(float, self.entries))),
            "tensor_std": dict(zip(ENTRY_KEYS, map(float, self.entries_std))),
            "com": dict(zip(COM_KEYS, map(float, self.com))),
            "com_std": dict(zip(COM_KEYS, map(float, self.com_std))),
            "covariance": [[float(c) for c in row] for row in self.cov],
            "principal_moments": [float(m) for m in self.principal_moments],
            "principal_moments_std": [float(m) for m in self.principal_moments_std],
            "principal_axes": [[float(c) for c in v] for v in self.principal_axes],
            "principal_axes_tilt_std_deg": [
                float(np.degrees(t)) if np.isfinite(t) else None for t in tilt
            ],
            "expanded_uncertainty": self.expanded_uncertainty.to_dict(),
            "mountings": [
                {
                    "name": name,
                    "residuals": {
                        key: float(z) if np.isfinite(z) else None
                        for key, z in zip(MEASUREMENT_KEYS, row)
                    },
                }
                for name, row in zip(self.names, self.residuals)
            ],
            "consistency": {"chi2": float(self.chi2), "dof": int(self.dof), "p": float(self.p)},
            "warnings": list(self.warnings),
            "mass": None if self.mass is None else float(self.mass),
        } | ({} if self.provenance is None else {"provenance": self.provenance})

    def __str__(self) -> str:
        lines = [
            (
                f"body from {len(self.names)} mountings ({', '.join(self.names)}): body axes, "
                "tensor about the body frame's origin"
            ),
            f"{'':8}{'estimate':>16}{'std':>10}",
        ]
        for key, value, std in zip(ENTRY_KEYS, self.entries, self.entries_std):
            lines.append(f"{key:<8}{value:>16.8g}{std:>10.2g}  kg m^2")
        for key, value, std in zip(COM_KEYS, self.com, self.com_std):
            lines.append(f"{key + '_c':<8}{value * 1e3:>16.8g}{std * 1e3:>10.2g}  mm")
        lines.append("principal moments (kg m^2) and axes (body axes), tilt std (deg):")
        for moment, std, axis, tilt in zip(
            self.principal_moments, self.principal_moments_std, self.principal_axes,
            np.degrees(self.principal_axes_tilt_std),
        ):
            axis_text = ", ".join(f"{c:+.6f}" for c in axis)
            lines.append(f"  {moment:.8g} +- {std:.2g}  [{axis_text}]  {tilt:.2g}")
        width = max(8, *(len(n) for n in self.names)) + 2
        lines.append(
            "residuals (std):".ljust(width) + "".join(f"{k:>8}" for k in MEASUREMENT_KEYS)
        )
        for name, row in zip(self.names, self.residuals):
            cells = "".join(f"{z:>+8.2f}" if np.isfinite(z) else f"{'-':>8}" for z in row)
            lines.append(f"  {name}".ljust(width) + cells)
        lines.append(
            f"consistency: chi^2 = {self.chi2:.4g} on {self.dof} dof, {_p_text(self.p)}"
            f" (warns below p = {CONSISTENCY_P})"
        )
        lines += self.expanded_uncertainty.lines()
        # The warnings are not in the text: the command line prints them on stderr.
        return "\n".join(lines)


def mounting_model(theta: np.ndarray, mounting: MountedResult) -> np.ndarray:
    """What a mounting measures of the body theta (docs/method.md §5, "Combining mountings").

    Parameters
    ----------
    theta : numpy.ndarray, shape (9,)
        [Jx, Jy, Jz, Jxy, Jyz, Jxz] (kg m^2) about the body frame's origin in body axes and
        the centre of mass [x, y, z] (m) in body axes.
    mounting : MountedResult
        Its rotation, origin, mass and g.

    Returns
    -------
    numpy.ndarray, shape (8,)
        [the entries about the rig's centre in rig axes (kg m^2), m g x_c, m g y_c (N m) with
        the centre of mass in rig axes]: rsp_inertia.plant.geometry.place_body, then the
        gravity terms of docs/method.md §3.

    Examples
    --------
    >>> m = MountedResult("A", np.zeros(6), np.zeros(2), np.eye(8), np.eye(3), np.zeros(3),
    ...                   2.0, 10.0)
    >>> mounting_model(np.array([1, 2, 3, 0, 0, 0, 0.1, 0.2, 0.3]), m)
    array([1., 2., 3., 0., 0., 0., 2., 4.])
    """
    inertia, com = place_body(
        theta[:6], theta[6:], mounting.mass, mounting.rotation, mounting.origin
    )
    return np.concatenate([inertia, mounting.mass * mounting.g * com[:2]])


def _linear_model(mounting: MountedResult) -> tuple[np.ndarray, np.ndarray]:
    """(H, b) with mounting_model(theta) = b + H theta, from the model at 0 and at each basis
    vector (the model is exactly affine; its one formula stays in place_body)."""
    b = mounting_model(np.zeros(9), mounting)
    H = np.column_stack([mounting_model(e, mounting) - b for e in np.eye(9)])
    return H, b


def _check(mountings: Sequence[MountedResult]) -> None:
    """Refuse what cannot be one body on one rig (InputError, one line)."""
    if len(mountings) < 1:
        raise InputError("combine needs at least one mounting, got none")
    for m in mountings:
        R = m.rotation
        if (
            np.abs(R @ R.T - np.eye(3)).max() > 1e-9
            or abs(np.linalg.det(R) - 1.0) > 1e-9
        ):
            raise InputError(
                f"{m.name}: the mounting's rotation is not orthonormal with determinant +1 "
                "to 1e-9"
            )
        if not (math.isfinite(m.mass) and m.mass > 0 and math.isfinite(m.g) and m.g > 0):
            raise InputError(f"{m.name}: mass and g must be > 0, got {m.mass} kg, {m.g} m/s^2")
    for attribute, what, unit in (("mass", "masses", "kg"), ("g", "gravity", "m/s^2")):
        values = [getattr(m, attribute) for m in mountings]
        if any(abs(v - values[0]) > 1e-9 * abs(values[0]) for v in values):
            listed = ", ".join(f"{m.name} {v:g} {unit}" for m, v in zip(mountings, values))
            raise InputError(
                f"the mountings' {what} differ ({listed}): one body on one rig has one"
            )


def _unobservable(
    null: np.ndarray, scale: np.ndarray, mountings: Sequence[MountedResult]
) -> InputError:
    """The refusal of a set that cannot give the centre of mass along the direction of the
    unknowns ``null / scale`` (unit ``null`` in the column-scaled system), with the rotation
    of a mounting that would."""
    if np.linalg.norm(null[6:]) < 1e-6:
        return InputError(
            "the mountings do not determine the body's tensor (the least squares is singular)"
        )
    com = null[6:] / scale[6:]
    d = com / np.linalg.norm(com)
    d = d * np.sign(d[np.argmax(np.abs(d))])
    axis = int(np.argmax(np.abs(d)))
    what = (
        f"{COM_KEYS[axis]}_c" if abs(d[axis]) > 1 - 1e-9
        else "the centre of mass along body direction [" + ", ".join(f"{c:.3g}" for c in d) + "]"
    )
    # A quarter turn about the rig's horizontal x axis, across the shaft, takes the body
    # direction on the shaft (R^T z) to R^T y, perpendicular to it. Printed to 12 digits:
    # orthonormal to 1e-9, as device.toml's [mounting] must be.
    first = mountings[0]
    quarter = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    turned = quarter @ first.rotation
    rows = ", ".join(
        "[" + ", ".join(f"{c:.12g}" for c in np.round(row, 12) + 0.0) + "]" for row in turned
    )
    return InputError(
        f"the mountings cannot give {what}: every one keeps that body direction on the shaft, "
        f"where gravity does not see it; mount the body again turned 90 deg about the rig's x "
        f"axis from {first.name}: rotation = [{rows}]"
    )


def combine_mountings(mountings: Sequence[MountedResult]) -> Combination:
    """The body's tensor and centre of mass in body axes from several mountings
    (docs/method.md §5, "Combining mountings").

    One generalised least squares for theta = [entries (6) about the body frame's origin in
    body axes, centre of mass (3) in body axes] over y_k = b_k + H_k theta
    (:func:`mounting_model`), weights C_k^-1 (each covariance's Cholesky factor whitens its
    mounting), solved by the SVD of the whitened, column-scaled system. The residuals'
    chi^2 on 8 K - 9 degrees of freedom tests the mountings' agreement; below
    :data:`CONSISTENCY_P` a warning gives the statistic and names the quantities beyond
    :data:`NAME_LIMIT` stds (each residual over its own std, from cov_k - H_k Cov H_k^T).

    Parameters
    ----------
    mountings : sequence of MountedResult
        At least two in practice; one body (equal masses) on one rig (equal g).

    Returns
    -------
    Combination

    Raises
    ------
    InputError
        No mounting, a rotation that is not one, masses or g that differ (named), a
        covariance that is not positive definite (named), or a set that cannot give the
        centre of mass along the body direction every mounting keeps on the shaft (with the
        rotation of a mounting that would).

    Examples
    --------
    >>> body = combine_mountings([bench_a, bench_b])       # doctest: +SKIP
    >>> body.com, body.com_std                              # doctest: +SKIP
    (array([ 0.003, -0.002,  0.004]), array([5.1e-08, 5.1e-08, 5.1e-08]))
    """
    _check(mountings)
    parts = [_whitened(m) for m in mountings]
    theta, cov, chi2 = _fit(parts, mountings)
    residuals = np.full((len(mountings), 8), np.nan)
    for k, (m, (H, b, C, _, _)) in enumerate(zip(mountings, parts)):
        r = m.measured - b - H @ theta
        var = np.diag(C) - np.einsum("ij,jk,ik->i", H, cov, H)
        tested = var > RESIDUAL_FLOOR * np.diag(C)
        residuals[k, tested] = r[tested] / np.sqrt(var[tested])
    dof = 8 * len(mountings) - 9
    p = float(chdtrc(dof, chi2))
    names = tuple(m.name for m in mountings)
    warnings = []
    if p < CONSISTENCY_P:
        warnings.append(
            _disagreement(chi2, dof, p, names, residuals, _odd_ones(parts, mountings))
        )
    warnings += physical_warnings(theta[:6], cov[:6, :6])
    return Combination(
        entries=theta[:6],
        com=theta[6:],
        cov=cov,
        names=names,
        residuals=residuals,
        chi2=chi2,
        dof=dof,
        p=p,
        warnings=warnings,
        mass=mountings[0].mass,
    )


def _whitened(m: MountedResult) -> tuple[np.ndarray, ...]:
    """(H, b, C, L^-1 H, L^-1 (y - b)) of a mounting, C = L L^T its covariance."""
    H, b = _linear_model(m)
    C = (m.cov + m.cov.T) / 2
    try:
        L = np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        raise InputError(f"{m.name}: the covariance is not positive definite") from None
    return (
        H, b, C,
        solve_triangular(L, H, lower=True), solve_triangular(L, m.measured - b, lower=True),
    )


def _fit(
    parts: list[tuple[np.ndarray, ...]], mountings: Sequence[MountedResult]
) -> tuple[np.ndarray, np.ndarray, float]:
    """theta, its covariance and the residuals' chi^2 of the whitened mountings."""
    A = np.vstack([part[3] for part in parts])
    z = np.concatenate([part[4] for part in parts])
    theta, cov = _solve(A, z, mountings)
    return theta, cov, float(np.sum((z - A @ theta) ** 2))


def _odd_ones(
    parts: list[tuple[np.ndarray, ...]], mountings: Sequence[MountedResult]
) -> list[tuple[str, float, int, float]]:
    """(name, chi^2, dof, p) of each mounting without which the others agree (p >=
    CONSISTENCY_P): the likely culprit of a disagreement, when there is one. Needs three
    mountings or more (two others that still give the whole body)."""
    found = []
    for k, m in enumerate(mountings):
        rest = [part for j, part in enumerate(parts) if j != k]
        others = [n for j, n in enumerate(mountings) if j != k]
        if len(rest) < 2:
            continue
        try:
            _, _, chi2 = _fit(rest, others)
        except InputError:
            continue
        dof = 8 * len(rest) - 9
        p = float(chdtrc(dof, chi2))
        if p >= CONSISTENCY_P:
            found.append((m.name, chi2, dof, p))
    return found


def _solve(
    A: np.ndarray, z: np.ndarray, mountings: Sequence[MountedResult]
) -> tuple[np.ndarray, np.ndarray]:
    """theta and its covariance from the whitened system A theta = z (least squares), or the
    refusal of an unobservable direction."""
    # Entries (kg m^2), centre of mass (m): columns of very different size; scaled to unit
    # norm, the singular values measure dependence rather than units. Rows of zeros make a
    # single mounting's 8 equations a square system whose SVD shows the missing direction.
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    short = max(A.shape[1] - A.shape[0], 0)
    A = np.vstack([A / scale, np.zeros((short, A.shape[1]))])
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    if s[-1] < RANK_TOLERANCE * s[0]:
        raise _unobservable(Vt[-1], scale, mountings)
    theta = Vt.T @ ((U.T @ np.concatenate([z, np.zeros(short)])) / s) / scale
    root = (Vt.T / s) / scale[:, None]
    return theta, root @ root.T


def _disagreement(
    chi2: float,
    dof: int,
    p: float,
    names: tuple[str, ...],
    residuals: np.ndarray,
    odd_ones: list[tuple[str, float, int, float]],
) -> str:
    """The warning of mountings that disagree: the statistic, per mounting the quantities
    beyond NAME_LIMIT stds (largest first), and the mountings without which the others
    agree."""
    named = []
    for name, row in zip(names, residuals):
        far = [i for i in np.argsort(-np.abs(np.nan_to_num(row))) if abs(row[i]) > NAME_LIMIT]
        if far:
            named.append(
                f"{name}: " + ", ".join(f"{MEASUREMENT_KEYS[i]} {row[i]:+.1f} std" for i in far)
            )
    where = "; ".join(named) if named else f"no single quantity beyond {NAME_LIMIT:g} std"
    culprit = "".join(
        f"; without {name} the others agree (chi^2 = {c:.4g} on {d} dof, {_p_text(q)})"
        for name, c, d, q in odd_ones
    )
    return (
        f"the mountings disagree beyond their noise: chi^2 = {chi2:.4g} on {dof} dof, "
        f"{_p_text(p)} < {CONSISTENCY_P} ({where}){culprit}; a body not seated as its "
        "[mounting] says, or a mounting's rotation or origin misstated"
    )


def _p_text(p: float) -> str:
    """``p = ...``; a p that underflows double precision as ``p < 1e-300``."""
    return f"p = {p:.2g}" if p > 1e-300 else "p < 1e-300"


def read_mounting(exp: Experiment) -> MountedResult:
    """One mounting for ``combine``: the experiment's result.json (its entries, gravity terms
    and their joint covariance) with device.toml's ``[mounting]`` (identity and 0 without
    it), ``[body] mass`` and gravity (rsp_inertia.estimation.combine.MountedResult.from_result).

    Raises
    ------
    InputError
        No result.json (identify first), one that is not JSON or lacks the keys (an older
        rsp-inertia's: identify again), no ``[body] mass``.
    """
    path = exp.result_path
    if not path.is_file():
        raise InputError(f"{path}: not found: run rsp-inertia identify {exp.root} first")
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputError(f"{path}: not a result.json written by identify ({error})") from None
    device = exp.device
    if device.body is None:
        raise InputError(
            f"{exp.root / 'device.toml'}: body.mass: missing: combining mountings needs the "
            "body's mass (the centre of mass comes from the gravity terms m g x_c, m g y_c)"
        )
    mounting = device.mounting
    return MountedResult.from_result(
        str(exp.root),
        document,
        np.eye(3) if mounting is None else mounting.rotation,
        np.zeros(3) if mounting is None else mounting.origin,
        device.body.mass,
        device.gravity,
    )
