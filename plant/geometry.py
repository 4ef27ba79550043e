"""Axis geometry: instantaneous axes, the design matrix V and the axis designs.

Pure numpy (plus one bounded scalar search from scipy). Every formula cites docs/method.md:
the axis direction is §1, the tensor convention and a body's mounting (its tensor and centre
of mass carried from body axes to the rig's) §2, the design matrix and the two designs of the
paper (icosahedron, one cone plus the z axis) §5 "Axis designs".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.frozen import read_only

__all__ = [
    "ENTRY_KEYS",
    "GRAVITY_NAMES",
    "HARMONIC_NAMES",
    "AxisDesign",
    "axis_angles_deg",
    "axis_direction",
    "axis_nodes_deg",
    "bilinear_gradient",
    "condition_number",
    "cone_condition",
    "cone_plus_z_design",
    "design_matrix",
    "device_design",
    "entries_from_tensor",
    "icosahedron_design",
    "physical_margins",
    "physical_warnings",
    "place_body",
    "principal",
    "principal_uncertainty",
    "rcond_curve",
    "relative_errors",
    "small_rotation",
    "tensor_from_entries",
    "turns_past_last_node",
]

ENTRY_KEYS = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")
"""Names of the tensor entries, in the order of every 6-vector."""

HARMONIC_NAMES = ("M0", "Mc2", "Ms2", "Ms1", "Mc1")
"""Names of the harmonics of a stage's reduced inertia M(phi), in the order of
rsp_inertia.plant.model.inertia_harmonics (and of the model's parameter vector)."""

GRAVITY_NAMES = ("Gs", "Gc")
"""Names of the gravity terms [m g x_c, m g y_c] (rsp_inertia.plant.model.gravity_basis)."""


def axis_direction(phi: ArrayLike, gear_ratio: ArrayLike) -> np.ndarray:
    """Unit vector of the instantaneous axis in body coordinates (docs/method.md §1).

    With psi = lambda * phi and nutation pi/2 the body turns about

        e(phi) = (lambda sin phi, lambda cos phi, 1) / sqrt(1 + lambda^2),

    a line on the cone of half-opening beta = arctan(lambda) about the shaft z.

    Parameters
    ----------
    phi : array_like
        Proper-rotation angle (rad), scalar or array.
    gear_ratio : array_like
        Gear ratio lambda = tan(beta) (dimensionless); broadcast against ``phi``.
        ``lambda = 0`` gives the z axis whatever ``phi``.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(phi, gear_ratio).shape + (3,)``, unit vectors (ex, ey, ez).

    Examples
    --------
    >>> axis_direction(0.3, 0.0)
    array([0., 0., 1.])
    """
    phi, lam = np.broadcast_arrays(np.asarray(phi, float), np.asarray(gear_ratio, float))
    e = np.stack([lam * np.sin(phi), lam * np.cos(phi), np.ones_like(phi)], axis=-1)
    return e / np.sqrt(1.0 + lam**2)[..., None]


def design_matrix(directions: ArrayLike) -> np.ndarray:
    """Design matrix V of a set of axes (docs/method.md §5, the paper's (8)).

    Row k is V_k = (ex^2, ey^2, ez^2, 2 ex ey, 2 ey ez, 2 ex ez), so that
    V_k . [Jx, Jy, Jz, Jxy, Jyz, Jxz] = e_k^T J e_k = J_e about axis k, with the products
    of inertia as tensor entries (docs/method.md §2).

    Parameters
    ----------
    directions : array_like
        Shape ``(n, 3)`` (or ``(..., 3)``), unit axis vectors.

    Returns
    -------
    numpy.ndarray
        Shape ``(n, 6)`` (or ``(..., 6)``).
    """
    e = np.asarray(directions, float)
    if e.shape[-1:] != (3,):
        raise ValueError(f"directions must have shape (n, 3), got {e.shape}")
    x, y, z = e[..., 0], e[..., 1], e[..., 2]
    return np.stack([x * x, y * y, z * z, 2 * x * y, 2 * y * z, 2 * x * z], axis=-1)


def condition_number(V: ArrayLike) -> float:
    """Condition number of V in the 2-norm: largest over smallest singular value.

    Parameters
    ----------
    V : array_like
        Shape ``(n, 6)``, ``n >= 6`` (a design matrix, docs/method.md §5).

    Returns
    -------
    float
        ``sigma_max / sigma_min``; ``inf`` when V is rank-deficient.

    Notes
    -----
    The paper quotes "rcond" values (Fig. 1) without naming the norm; this module uses the
    2-norm throughout, which reproduces its 1.58 (icosahedron) and, to 6e-4, its 1.4899.
    """
    s = np.linalg.svd(np.asarray(V, float), compute_uv=False)
    if s[-1] <= s[0] * np.finfo(float).eps * max(np.shape(V)):
        return float("inf")
    return float(s[0] / s[-1])


def axis_angles_deg(directions: ArrayLike) -> np.ndarray:
    """Angles between the axes taken as lines (not as vectors), in degrees.

    An axis and its opposite are the same line (J_e is even in e), so the angle is
    arccos|e_i . e_j|, in [0, 90] deg.

    Parameters
    ----------
    directions : array_like
        Shape ``(n, 3)``, axis vectors (normalised here).

    Returns
    -------
    numpy.ndarray
        Shape ``(n, n)``, symmetric, zero on the diagonal.
    """
    e = np.asarray(directions, float)
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    # Rounding can push |cos| a hair above 1; clip so arccos never returns NaN.
    cos = np.clip(np.abs(e @ e.T), 0.0, 1.0)
    angles = np.degrees(np.arccos(cos))
    np.fill_diagonal(angles, 0.0)
    return angles


def tensor_from_entries(j6: ArrayLike) -> np.ndarray:
    """Inertia tensor from its six entries (docs/method.md §2).

    Parameters
    ----------
    j6 : array_like
        ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]`` (kg m^2), products as tensor entries
        (Jxy = -integral of x y dm), shape ``(6,)`` or ``(..., 6)``.

    Returns
    -------
    numpy.ndarray
        Shape ``(3, 3)`` (or ``(..., 3, 3)``), symmetric.
    """
    jx, jy, jz, jxy, jyz, jxz = np.moveaxis(np.asarray(j6, float), -1, 0)
    return np.stack(
        [
            np.stack([jx, jxy, jxz], axis=-1),
            np.stack([jxy, jy, jyz], axis=-1),
            np.stack([jxz, jyz, jz], axis=-1),
        ],
        axis=-2,
    )


def entries_from_tensor(J: ArrayLike) -> np.ndarray:
    """Six entries ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]`` of an inertia tensor (docs/method.md §2).

    Inverse of :func:`tensor_from_entries`. Each product is the mean of the two mirror
    entries, so a tensor that is symmetric only up to rounding gives its symmetric part.

    Parameters
    ----------
    J : array_like
        Shape ``(3, 3)`` (or ``(..., 3, 3)``), kg m^2.

    Returns
    -------
    numpy.ndarray
        Shape ``(6,)`` (or ``(..., 6)``).
    """
    J = np.asarray(J, float)
    if J.shape[-2:] != (3, 3):
        raise ValueError(f"J must have shape (3, 3), got {J.shape}")
    return np.stack(
        [
            J[..., 0, 0],
            J[..., 1, 1],
            J[..., 2, 2],
            0.5 * (J[..., 0, 1] + J[..., 1, 0]),
            0.5 * (J[..., 1, 2] + J[..., 2, 1]),
            0.5 * (J[..., 0, 2] + J[..., 2, 0]),
        ],
        axis=-1,
    )


def place_body(
    inertia: ArrayLike,
    com: ArrayLike,
    mass: float,
    rotation: ArrayLike,
    origin: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """A body's tensor and centre of mass carried from its own axes to the rig's
    (docs/method.md §2, "Mountings").

    The body frame is mounted with its origin at ``o`` (rig axes, from the rig's centre O)
    and turned by R (v_rig = R v_body). With c_r = R c, the centre of mass in rig axes is
    ``o + c_r``, and the parallel-axis theorem, applied once from the body's origin to its
    centre of mass and once from there to O, gives the tensor about O in rig axes:

        J_rig = R J R^T + m [(|o|^2 + 2 o.c_r) I - (o o^T + o c_r^T + c_r o^T)]

    For given R, o and m the map is affine in (``inertia``, ``com``), exactly: a linear model
    may be built by evaluating it on basis vectors.

    Parameters
    ----------
    inertia : array_like
        ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]`` (kg m^2), shape ``(6,)``: the tensor about the body
        frame's origin in body axes, products as tensor entries (Jxy = -integral of x y dm).
    com : array_like
        Centre of mass (m) in body axes, shape ``(3,)``.
    mass : float
        kg.
    rotation : array_like
        R, shape ``(3, 3)``, a rotation: body axes -> rig axes.
    origin : array_like
        o (m), the body frame's origin in rig axes, shape ``(3,)``.

    Returns
    -------
    (inertia_rig, com_rig) : numpy.ndarray
        Shapes ``(6,)`` and ``(3,)``: the entries about O in rig axes (the axes and the
        centre of result.json's tensor) and the centre of mass in rig axes.

    Examples
    --------
    >>> place_body([1.0, 2.0, 3.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 1.0, np.eye(3), [0, 0, 0])
    (array([1., 2., 3., 0., 0., 0.]), array([0., 0., 0.]))
    """
    R = np.asarray(rotation, float)
    o = np.asarray(origin, float)
    c = R @ np.asarray(com, float)
    J = R @ tensor_from_entries(inertia) @ R.T
    cross = np.outer(o, o) + np.outer(o, c) + np.outer(c, o)
    shift = (o @ o + 2.0 * (o @ c)) * np.eye(3) - cross
    return entries_from_tensor(J + mass * shift), o + c


def small_rotation(angles_deg: ArrayLike) -> np.ndarray:
    """The rotation by small angles about the rig's x, y and z axes: Rx(ax) Ry(ay) Rz(az),
    exact (not linearised) (docs/method.md §2, "Mountings").

    Parameters
    ----------
    angles_deg : array_like
        ``[ax, ay, az]`` (deg), shape ``(3,)``.

    Returns
    -------
    numpy.ndarray
        Shape ``(3, 3)``, orthonormal with determinant +1; the identity for zero angles.

    Examples
    --------
    >>> small_rotation([0.0, 0.0, 90.0]).round(12)
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    ax, ay, az = np.radians(np.asarray(angles_deg, float))
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return rx @ ry @ rz


def physical_margins(j6: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """How far a tensor is from the limits of a rigid body's (docs/method.md §5, physical checks).

    A body's tensor is positive definite and its principal moments I1 <= I2 <= I3 obey the
    triangle inequality I1 + I2 >= I3.

    Parameters
    ----------
    j6 : array_like
        ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]`` (kg m^2), shape ``(6,)`` or ``(..., 6)``.

    Returns
    -------
    (smallest, triangle) : numpy.ndarray
        Shape ``j6.shape[:-1]``, kg m^2: the smallest principal moment I1 (> 0 when positive
        definite) and I1 + I2 - I3 (>= 0 when the triangle inequality holds).
    """
    m = np.linalg.eigvalsh(tensor_from_entries(j6))
    return m[..., 0], m[..., 0] + m[..., 1] - m[..., 2]


def principal(entries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and axes (rows, unit vectors) of the tensor."""
    moments, vectors = np.linalg.eigh(tensor_from_entries(entries))
    return moments, vectors.T


def bilinear_gradient(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """d(a^T J b) / d(entries): the gradient of a bilinear form of the tensor in its six
    entries ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]`` (the tensor holds Jxy at (0, 1) and (1, 0)).

    Parameters
    ----------
    a : numpy.ndarray, shape (3,)
        A vector (a unit principal axis, for the moments' and axes' first-order changes).
    b : numpy.ndarray, shape (3,)
        Another, or the same.

    Returns
    -------
    numpy.ndarray, shape (6,)
    """
    return np.array([
        a[0] * b[0], a[1] * b[1], a[2] * b[2],
        a[0] * b[1] + a[1] * b[0], a[1] * b[2] + a[2] * b[1], a[0] * b[2] + a[2] * b[0],
    ])


def principal_uncertainty(
    entries: np.ndarray, cov: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Standard deviations of the principal moments and of the principal axes' directions,
    to first order in the entries' errors (docs/method.md §5, principal moments and axes).

    With J v_i = I_i v_i, a small change dJ of the tensor moves I_i by v_i^T dJ v_i and turns
    v_i by sum_{j != i} (v_j^T dJ v_i) / (I_i - I_j) v_j. Both are linear in the six entries
    ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]`` (the tensor holds Jxy at (0, 1) and (1, 0)), so their
    variances are quadratic forms in ``cov``.

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2.
    cov : numpy.ndarray, shape (6, 6)
        kg^2 m^4, covariance of ``entries``.

    Returns
    -------
    moments_std : numpy.ndarray, shape (3,)
        kg m^2, in the order of :func:`principal` (ascending moments).
    axes_tilt_std : numpy.ndarray, shape (3,)
        rad, root mean square angle by which each principal axis is uncertain (the two
        tilts towards the other axes added in quadrature); infinite for an axis whose moment
        equals another's (its direction is then not defined).
    """
    moments, vectors = principal(entries)
    moments_std = np.empty(3)
    tilt_std = np.empty(3)
    for i in range(3):
        g = bilinear_gradient(vectors[i], vectors[i])
        moments_std[i] = math.sqrt(max(float(g @ cov @ g), 0.0))
        variance = 0.0
        for j in range(3):
            if j == i:
                continue
            gap = moments[i] - moments[j]
            h = bilinear_gradient(vectors[j], vectors[i])
            spread = max(float(h @ cov @ h), 0.0)
            variance += math.inf if gap == 0.0 and spread > 0 else spread / gap**2 if gap else 0.0
        tilt_std[i] = math.sqrt(variance)
    return moments_std, tilt_std


def physical_warnings(entries: np.ndarray, cov: np.ndarray, samples: int = 2000) -> list[str]:
    """Warnings when the tensor is not a physical one within its uncertainty.

    A rigid body's tensor is positive definite and its principal moments obey the triangle
    inequality I1 + I2 >= I3 (rsp_inertia.plant.geometry.physical_margins). A violation is
    reported when it holds beyond two standard deviations of the margin, estimated by
    sampling the entries' covariance (seeded, deterministic).

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2, the tensor's entries ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]``.
    cov : numpy.ndarray, shape (6, 6)
        (kg m^2)^2, their covariance.
    samples : int, optional
        How many draws of the entries estimate the margins' standard deviations.

    Returns
    -------
    list of str
        One warning per violated condition (positive definiteness, triangle inequality);
        empty for a physical tensor.
    """
    rng = np.random.default_rng(0)
    draws = rng.multivariate_normal(entries, cov, size=samples, check_valid="ignore")
    smallest, triangle = physical_margins(entries)
    std_small, std_tri = np.column_stack(physical_margins(draws)).std(axis=0)
    warnings = []
    if smallest < -2 * std_small:
        warnings.append(
            f"the tensor is not positive definite: smallest principal moment "
            f"{smallest:.6g} +- {std_small:.2g} kg m^2"
        )
    if triangle < -2 * std_tri:
        warnings.append(
            f"the principal moments break the triangle inequality I1 + I2 >= I3 by "
            f"{-triangle:.6g} +- {std_tri:.2g} kg m^2"
        )
    return warnings


def relative_errors(j6: ArrayLike, true_j6: ArrayLike) -> np.ndarray:
    """Errors of a tensor's entries against the true ones, relative to the true tensor's
    largest principal moment (the scale of every entry, products included).

    Parameters
    ----------
    j6, true_j6 : array_like
        ``[Jx, Jy, Jz, Jxy, Jyz, Jxz]`` (kg m^2), shape ``(6,)``: an estimate and the truth.

    Returns
    -------
    numpy.ndarray
        Shape ``(6,)``, ``(j6 - true_j6) / max |principal moment of true_j6|``.
    """
    true_j6 = np.asarray(true_j6, float)
    scale = np.abs(np.linalg.eigvalsh(tensor_from_entries(true_j6))).max()
    return (np.asarray(j6, float) - true_j6) / scale


def _frozen_array(values: ArrayLike, dtype: type) -> np.ndarray:
    """1-D read-only copy, so a frozen design cannot be changed through its arrays."""
    a = np.array(values, dtype=dtype).reshape(-1)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class AxisDesign:
    """A set of instantaneous axes in the body, one per (stage, node) (docs/method.md §5).

    Axis k is ``axis_direction(phis[k], gear_ratios[k])``. The arrays are copied and made
    read-only. Equality is identity (arrays have no single truth value).
    """

    name: str
    """Label used in reports."""
    gear_ratios: np.ndarray
    """(n,) gear ratio lambda = tan(beta) of each axis (dimensionless)."""
    phis: np.ndarray
    """(n,) node angle phi of each axis (rad)."""
    stages: np.ndarray
    """(n,) 1-based index of the stage (gear ratio) that realises each axis."""

    def __post_init__(self) -> None:
        lam = _frozen_array(self.gear_ratios, float)
        phi = _frozen_array(self.phis, float)
        stage = _frozen_array(self.stages, int)
        if not lam.size == phi.size == stage.size:
            raise ValueError(
                f"{self.name}: gear_ratios, phis and stages differ in length "
                f"({lam.size}, {phi.size}, {stage.size})"
            )
        object.__setattr__(self, "gear_ratios", lam)
        object.__setattr__(self, "phis", phi)
        object.__setattr__(self, "stages", stage)

    @property
    def n_axes(self) -> int:
        """Number of axes n."""
        return int(self.phis.size)

    @property
    def directions(self) -> np.ndarray:
        """(n, 3) unit axis vectors in body coordinates (docs/method.md §1), read-only."""
        return read_only(axis_direction(self.phis, self.gear_ratios))

    @property
    def matrix(self) -> np.ndarray:
        """(n, 6) design matrix V (docs/method.md §5), read-only."""
        return read_only(design_matrix(self.directions))

    @property
    def condition(self) -> float:
        """2-norm condition number of V."""
        return condition_number(self.matrix)

    @property
    def angles_deg(self) -> np.ndarray:
        """(n, n) angles between the axes as lines (deg), read-only."""
        return read_only(axis_angles_deg(self.directions))


def icosahedron_design() -> AxisDesign:
    """The paper's two-stage design: the six axes of a regular icosahedron (docs/method.md §5).

    Stage 1: lambda1 = 3 - sqrt 5 (0.7639), nodes phi = 0, 120, 240 deg.
    Stage 2: lambda2 = 3 + sqrt 5 (5.2361), nodes phi = 60, 180, 300 deg.
    All 15 angles between the axes are arccos(1/sqrt 5) = 63.43 deg, cond(V) = sqrt(5/2).

    Returns
    -------
    AxisDesign
        Six axes named "icosahedron".
    """
    s5 = np.sqrt(5.0)
    return AxisDesign(
        name="icosahedron",
        gear_ratios=np.repeat([3.0 - s5, 3.0 + s5], 3),
        phis=np.radians([0.0, 120.0, 240.0, 60.0, 180.0, 300.0]),
        stages=np.repeat([1, 2], 3),
    )


def _cone_gear_ratio(opening_deg: float) -> float:
    """Gear ratio lambda = tan(beta) of a cone of opening 2 beta (deg) (docs/method.md §1)."""
    if not 0.0 <= opening_deg < 180.0:
        raise InputError(f"cone opening angle {opening_deg} deg: must lie in [0, 180)")
    return float(np.tan(np.radians(opening_deg) / 2.0))


def cone_plus_z_design(opening_deg: float) -> AxisDesign:
    """Five axes 72 deg apart on one cone plus the z axis (docs/method.md §5, paper Fig. 1).

    Parameters
    ----------
    opening_deg : float
        Opening angle 2 beta of the cone (deg), in [0, 180); lambda = tan(beta).

    Returns
    -------
    AxisDesign
        Stage 1: the cone, nodes phi = 0, 72, 144, 216, 288 deg. Stage 2: lambda = 0,
        the z axis (phi = 0).

    Raises
    ------
    InputError
        If the opening angle is outside [0, 180) deg.
    """
    lam = _cone_gear_ratio(opening_deg)
    return AxisDesign(
        name=f"cone+z (2beta = {opening_deg:.3f} deg)",
        gear_ratios=np.append(np.full(5, lam), 0.0),
        phis=np.radians(np.append(72.0 * np.arange(5), 0.0)),
        stages=np.array([1, 1, 1, 1, 1, 2]),
    )


def cone_condition(opening_deg: float) -> float:
    """cond(V) of the cone-plus-z design at one opening angle (deg)."""
    return cone_plus_z_design(opening_deg).condition


def rcond_curve(openings_deg: ArrayLike) -> np.ndarray:
    """Reciprocal condition number 1/cond(V) of the cone-plus-z design (paper Fig. 1).

    Parameters
    ----------
    openings_deg : array_like
        Opening angles 2 beta (deg), each in [0, 180).

    Returns
    -------
    numpy.ndarray
        Same shape as ``openings_deg``; 0 where V is singular (2 beta = 0).
    """
    openings = np.asarray(openings_deg, float)
    flat = [1.0 / cone_condition(float(o)) for o in openings.reshape(-1)]
    return np.array(flat, float).reshape(openings.shape)



def axis_nodes_deg(stage: Any) -> list[float]:
    """The nodes (deg) at which a stage realises its axes: its ``nodes_deg``, or the one node
    0 when its ``gear_ratio`` is 0 (it spins about z, the same axis at every node)."""
    if float(stage.gear_ratio) == 0.0:
        return [0.0]
    return [float(n) for n in stage.nodes_deg]


def device_design(device: Any) -> AxisDesign:
    """Axes that a device's stages realise, in stage order (docs/method.md §1, §5).

    Parameters
    ----------
    device : object
        Has ``stages``, each with ``gear_ratio`` (lambda, float) and ``nodes_deg``
        (node angles phi, deg). A stage with ``gear_ratio == 0`` spins about z: it gives
        one axis (phi = 0) whatever its nodes, since every node would give the same axis
        (:func:`axis_nodes_deg`).

    Returns
    -------
    AxisDesign
        Named "device"; stage indices are 1-based positions in ``device.stages``. Whether
        the axes determine the tensor (rank, cond(V)) is checked elsewhere.
    """
    lams: list[float] = []
    phis: list[float] = []
    stages: list[int] = []
    for index, stage in enumerate(device.stages, start=1):
        lam = float(stage.gear_ratio)
        nodes = axis_nodes_deg(stage)
        lams += [lam] * len(nodes)
        phis += list(np.radians(nodes))
        stages += [index] * len(nodes)
    return AxisDesign(name="device", gear_ratios=lams, phis=phis, stages=stages)


def turns_past_last_node(phi: ArrayLike, nodes: ArrayLike) -> float:
    """Turns from the first passage of the last node (in order of passage) to the end.

    ``phi``: the pass's angles (rad) in time order, at least its first and last; ``nodes``
    in rad. Measured along the motion, so phi may increase (forward) or decrease (backward);
    negative if the pass ends before it reaches every node.
    """
    phi = np.asarray(phi, dtype=float)
    first = phi[0]
    s = 1.0 if phi[-1] >= first else -1.0
    ahead = np.mod(s * (np.asarray(nodes, dtype=float) - first), 2 * math.pi)
    return float(s * (phi[-1] - (first + s * ahead.max())) / (2 * math.pi))
