"""What the balances take as known about the rig: the calibration's terms theta.

The drive's gains by direction of power flow, the empty system's reduced inertia per stage
(tare and fixture), the fixture's gravity terms and the encoder's error (docs/method.md §2-3,
§5 Calibration), with their covariance: from ``calibration.toml``
(rsp_inertia.estimation.calibration), or device.toml's tares alone. theta's layout is
rsp_inertia.estimation.layout.theta_layout; the budget lines its groups give the
uncertainty budget (rsp_inertia.estimation.gls) are named here.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from rsp_inertia.estimation.balance import StageBalance
from rsp_inertia.estimation.calibration_summary import CalibrationSummary
from rsp_inertia.estimation.columns import encoder_columns, gravity_rows
from rsp_inertia.estimation.layout import Layout, theta_layout
from rsp_inertia.infra.frozen import freeze_arrays
from rsp_inertia.plant.model import inertia_basis
from rsp_inertia.plant.transducers import error_slope_basis

__all__ = [
    "CERTIFICATE_SOURCE",
    "DRIVE_SOURCE",
    "EMPTY_SOURCE",
    "ENCODER_SOURCE",
    "ZERO_SOURCE",
    "KnownTerms",
]

CERTIFICATE_SOURCE = "reference certificate"
"""Budget line of the reference body's certified values (reference.toml's stds), which the
calibration carries into every calibrated term (rsp_inertia.estimation.calibration)."""

DRIVE_SOURCE = "calibration: drive gains"
"""Budget line of the drive's calibrated gains h_d, h_b."""
ENCODER_SOURCE = "calibration: encoder error"
"""Budget line of the encoder's calibrated error harmonics."""
ZERO_SOURCE = "calibration: encoder zero"
"""Budget line of the encoder's calibrated zero offset (the rig axes' turn about z)."""
EMPTY_SOURCE = "calibration: tare and fixture"
"""Budget line of the empty system's calibrated harmonics and the fixture's gravity."""


@dataclass(frozen=True)
class KnownTerms:
    """What the balances take as known about the rig (docs/method.md §2-3, §5 Calibration).

    From ``calibration.toml`` (rsp_inertia.estimation.calibration), or device.toml's tares alone:
    the drive's gains by direction of power flow (h_d, h_b: the torque the body receives per
    unit of logged torque while the motor drives it and while it is back-driven,
    rsp_inertia.plant.transducers.drive_gains), the empty system's reduced inertia per stage
    (tare and fixture), the fixture's gravity terms and the encoder's error harmonics, with
    the covariance of theta = [h_d, h_b, harmonics of stage 1..n, Gs_f, Gc_f, zero, c_1, s_1,
    ...] (:attr:`layout`, rsp_inertia.estimation.layout.theta_layout).

    The empty system's harmonics and the fixture's gravity are functions of the angle as the
    readings corrected with :attr:`zero` give it (where calibrate measured them), so a change
    of the zero turns only what identify measures, the body (and the spring, whose zero angle
    device.toml states in the rig's phi): :meth:`jacobian` and :meth:`jacobian_angle`.
    """

    gains: tuple[float, float]
    """(h_d, h_b); (1, 1) for an exact torque constant and a lossless drive."""
    inertia: np.ndarray
    """(stages, 5) harmonics [M0, Mc2, Ms2, Ms1, Mc1] of the empty system, kg m^2."""
    gravity: np.ndarray
    """(2,) the fixture's [m g x_c, m g y_c], N m."""
    cov: np.ndarray
    """Covariance of theta (class docstring); zero when nothing was calibrated."""
    calibrated: bool = False
    """Whether theta carries an uncertainty to propagate: a calibration, or the stds that
    device.toml states for its tares, torque constant and encoder (else they are exact)."""
    encoder: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """theta_e = [c_1, s_1, c_2, s_2, ...], rad: the encoder's reading error e(phi)
    (rsp_inertia.plant.transducers); identify takes every log's readings back to the true
    angle with it. Empty: an exact encoder."""
    zero: float = 0.0
    """z, rad: the encoder's zero offset, what it reads at the rig's phi = 0 (body y up,
    docs/method.md §1; rsp_inertia.plant.transducers); identify takes it off every reading
    with the error. 0: the encoder zeroed there (exact unless a calibration measured it)."""
    certificate_cov: np.ndarray | None = None
    """The reference certificate's share of :attr:`cov` (the part its stated uncertainty
    adds through the calibration fit; its own budget line, :data:`CERTIFICATE_SOURCE`), or
    None: a reference certificate without stds, or no reference."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "gains", (float(self.gains[0]), float(self.gains[1])))
        object.__setattr__(self, "encoder", np.asarray(self.encoder, dtype=float).reshape(-1))
        object.__setattr__(self, "zero", float(self.zero))
        size = self.layout.size
        if self.cov.shape != (size, size):
            raise ValueError(
                f"KnownTerms.cov must be {size} x {size} (names()), got {self.cov.shape}"
            )
        freeze_arrays(self)  # its arrays read-only, as the record is frozen

    @classmethod
    def from_tares(cls, tares) -> KnownTerms:
        """device.toml's tares as exact: M_empty = M_tare, no fixture terms, an exact torque
        constant, a lossless drive and an exact encoder."""
        tares = np.asarray(tares, dtype=float)
        exact = cls.exact(len(tares))
        inertia = np.zeros_like(exact.inertia)
        inertia[:, 0] = tares
        return replace(exact, inertia=inertia)

    @classmethod
    def exact(cls, stages: int, encoder=()) -> KnownTerms:
        """Nothing known about the rig yet, but its number of stages: gains 1, no empty
        system, no fixture, the encoder error ``encoder`` (coefficients), all exact."""
        encoder = np.asarray(encoder, dtype=float).reshape(-1)
        size = theta_layout(stages, encoder.size // 2).size
        return cls((1.0, 1.0), np.zeros((stages, 5)), np.zeros(2), np.zeros((size, size)),
                   encoder=encoder)

    @property
    def layout(self) -> Layout:
        """theta's layout: segments "gains", "harmonics" (per stage), "gravity", "encoder"
        (rsp_inertia.estimation.layout.theta_layout)."""
        return theta_layout(len(self.inertia), self.orders)

    @property
    def theta(self) -> np.ndarray:
        """The values of theta, in the order of :meth:`names`."""
        theta = np.empty(self.layout.size)
        for name, values in (
            ("gains", self.gains),
            ("harmonics", self.inertia.ravel()),
            ("gravity", self.gravity),
            ("zero", (self.zero,)),
            ("encoder", self.encoder),
        ):
            theta[self.layout.slice(name)] = values
        return theta

    def with_theta(
        self,
        theta: np.ndarray,
        cov: np.ndarray,
        calibrated: bool = True,
        certificate_cov: np.ndarray | None = None,
    ):
        """These terms' layout with the values ``theta`` and their covariance ``cov``.

        Parameters
        ----------
        theta : numpy.ndarray
            The values, in the order of :meth:`names`.
        cov : numpy.ndarray
            Their covariance.
        calibrated : bool, optional
            Whether theta carries an uncertainty to propagate.
        certificate_cov : numpy.ndarray, optional
            The reference certificate's share of ``cov``.

        Returns
        -------
        KnownTerms
            The new terms.
        """
        theta = np.asarray(theta, dtype=float)
        h_d, h_b = theta[self.gains_slice]
        return KnownTerms(
            gains=(float(h_d), float(h_b)),
            inertia=theta[self.layout.slice("harmonics")].reshape(self.inertia.shape),
            gravity=theta[self.gravity_slice],
            cov=cov,
            calibrated=calibrated,
            encoder=theta[self.encoder_slice],
            zero=float(theta[self.zero_slice][0]),
            certificate_cov=certificate_cov,
        )

    @property
    def orders(self) -> int:
        """Orders of the encoder's error series (len(encoder) / 2)."""
        return self.encoder.size // 2

    def names(self) -> list[str]:
        """The names of theta, in order: h_d, h_b, M0[1] .. Mc1[n], Gs, Gc, zero, c1, s1, ..."""
        return self.layout.names()

    @property
    def gains_slice(self) -> slice:
        """theta's entries of the drive's gains h_d, h_b (:attr:`layout`'s "gains")."""
        return self.layout.slice("gains")

    def harmonics_slice(self, stage: int) -> slice:
        """theta's entries of the empty system's harmonics of stage ``stage`` (from 1)."""
        return self.layout.slice("harmonics", stage)

    @property
    def gravity_slice(self) -> slice:
        """theta's entries of the fixture's gravity terms."""
        return self.layout.slice("gravity")

    @property
    def zero_slice(self) -> slice:
        """theta's entry of the encoder's zero offset."""
        return self.layout.slice("zero")

    @property
    def encoder_slice(self) -> slice:
        """theta's entries of the encoder's error coefficients."""
        return self.layout.slice("encoder")

    @property
    def std(self) -> np.ndarray:
        """Standard deviations of theta."""
        return np.sqrt(np.maximum(np.diag(self.cov), 0.0))

    def empty_inertia(self, stage: int, phi) -> np.ndarray | float:
        """M_empty(phi) of stage ``stage`` (from 1), kg m^2."""
        value = inertia_basis(np.atleast_1d(phi)) @ self.inertia[stage - 1]
        return float(value[0]) if np.ndim(phi) == 0 else value

    def node_variance(self, stage: int, phi: float, M_parts, M: float) -> float:
        """Variance the known terms give a node's J (1 + lam^2)^2, kg^2 m^4.

        J = (M - M_empty(phi)) / (1 + lam^2). The encoder's error scales both passes'
        squared speeds at the node by 1 + 2 e'(phi) alike, so dM/dtheta_e = 2 M e'_theta(phi);
        dM_empty = basis(phi) d(the stage's harmonics).

        Parameters
        ----------
        stage : int
            The stage number, from 1.
        phi : float
            rad, the node's angle.
        M_parts : sequence of float
            kg m^2, M's shares from the driving and the back-driven work (h_d and h_b times
            the works' parts, so dM/dh_d = M_parts[0] / h_d and likewise for h_b; a spring's
            potential, exact, is in neither).
        M : float
            kg m^2, the node formula's reduced inertia.

        Returns
        -------
        float
            kg^2 m^4, the variance.
        """
        g = np.zeros(self.cov.shape[0])
        g[self.gains_slice] = (M_parts[0] / self.gains[0], M_parts[1] / self.gains[1])
        g[self.harmonics_slice(stage)] = -inertia_basis(np.atleast_1d(phi))[0]
        if self.orders:
            g[self.encoder_slice] = 2 * M * error_slope_basis(phi, self.orders)
        return float(g @ self.cov @ g)

    def empty_variance(self, stage: int, phi: float) -> float:
        """Variance of M_empty(phi) of stage ``stage``, kg^2 m^4."""
        g = np.zeros(self.cov.shape[0])
        g[self.harmonics_slice(stage)] = inertia_basis(np.atleast_1d(phi))[0]
        return float(g @ self.cov @ g)

    def summary(
        self, after: KnownTerms | None = None, conventions: str = ""
    ) -> CalibrationSummary | None:
        """result.json's ``calibration``: what was applied (None when nothing was), and with
        ``after`` (the terms after the runs refined them) the drive's gains and the encoder's
        error as the runs left them (``refined``); ``conventions``, the calibration's line on
        the rig's conventions."""
        if not self.calibrated:
            return None
        out = replace(self._summary(), conventions=conventions)
        if after is not None:
            out = replace(out, refined=after._summary().refinable())
        return out

    def _summary(self) -> CalibrationSummary:
        std = self.std
        n = len(self.inertia)
        encoder = self.encoder_slice
        return CalibrationSummary(
            drive_gains=tuple(float(v) for v in self.gains),
            drive_gains_std=tuple(float(v) for v in std[self.gains_slice]),
            round_trip_efficiency=float(self.gains[0] / self.gains[1]),
            round_trip_efficiency_std=float(self.round_trip_std()),
            empty_inertia=tuple(tuple(float(v) for v in row) for row in self.inertia),
            empty_inertia_std=tuple(
                tuple(float(v) for v in std[self.harmonics_slice(s)]) for s in range(1, n + 1)
            ),
            fixture_gravity=tuple(float(v) for v in self.gravity),
            fixture_gravity_std=tuple(float(v) for v in std[self.gravity_slice]),
            encoder_error=tuple(float(v) for v in self.encoder),
            encoder_error_std=tuple(float(v) for v in std[encoder]),
            encoder_zero=self.zero,
            encoder_zero_std=float(std[self.zero_slice][0]),
        )

    def budget_groups(self) -> dict[str, list[int]]:
        """Budget lines of theta (rsp_inertia.estimation.gls), in the order they are added:
        the drive's gains, the encoder's error, its zero, the tare and fixture."""
        layout = self.layout
        groups = {
            DRIVE_SOURCE: layout.indices("gains"),
            ENCODER_SOURCE: layout.indices("encoder"),
            ZERO_SOURCE: layout.indices("zero"),
            EMPTY_SOURCE: layout.indices("harmonics", "gravity"),
        }
        return {name: indices for name, indices in groups.items() if indices}

    def budget_shares(self) -> dict[str, np.ndarray]:
        """Budget lines that are parts of :attr:`cov` rather than groups of theta
        (rsp_inertia.estimation.gls.assemble_blocks): the reference certificate's, when the
        calibration carries one."""
        if self.certificate_cov is None or not np.any(self.certificate_cov):
            return {}
        return {CERTIFICATE_SOURCE: self.certificate_cov}

    def common_scale(self) -> np.ndarray:
        """(p,) the direction of theta along which the logged torque's scale changes as a
        whole: the gains' own values in their slots (a relative change of both), zero
        elsewhere. The balances cannot measure it (rsp_inertia.estimation.gls propagates it)."""
        out = np.zeros(self.cov.shape[0])
        out[self.gains_slice] = self.gains
        return out

    def round_trip_std(self) -> float:
        """Std of the round-trip efficiency h_d / h_b = eta_d eta_b (first order)."""
        g = np.zeros(self.cov.shape[0])
        g[self.gains_slice] = (1.0 / self.gains[1], -self.gains[0] / self.gains[1] ** 2)
        return float(np.sqrt(max(g @ self.cov @ g, 0.0)))

    def jacobian(self, bal: StageBalance) -> np.ndarray:
        """(n, p) d rhs / d theta of one run's equations (:func:`balance_rhs`), but for the
        encoder's columns, which are M(phi) times :meth:`jacobian_inertia`."""
        B = np.zeros((len(bal.phi), self.cov.shape[0]))
        B[:, self.gains_slice] = bal.motor_work_parts
        B[:, self.harmonics_slice(bal.stage)] = -0.5 * bal.speed_sq[:, None] * inertia_basis(
            bal.phi
        )
        B[:, self.gravity_slice] = -gravity_rows(bal.phi)
        if bal.spring_slope is not None:  # the spring's phi0 is the rig's: it turns with z
            B[:, self.zero_slice.start] = bal.spring_slope
        return B

    def jacobian_inertia(self, bal: StageBalance) -> np.ndarray | None:
        """(n, p) the part of d rhs / d theta that is the reduced inertia M(phi) times this:
        the encoder's, :func:`encoder_columns` (None without encoder terms)."""
        if not self.orders:
            return None
        B = np.zeros((len(bal.phi), self.cov.shape[0]))
        B[:, self.encoder_slice] = encoder_columns(bal, self.orders)
        return B

    def jacobian_angle(self, bal: StageBalance) -> np.ndarray:
        """(n, p) the part of d rhs / d theta that is the angle slope of the balance's unknown
        side (sum over the unknowns of x d column / d phi, rsp_inertia.estimation.gls) times
        this: the zero's. The true angle is the corrected one less a change dz of the zero, so
        the body's terms move by -dz times their slope; on the right-hand side, +dz times it."""
        B = np.zeros((len(bal.phi), self.cov.shape[0]))
        B[:, self.zero_slice.start] = 1.0
        return B
