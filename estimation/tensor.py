"""The inertia tensor from the runs' balances: least squares, axis solve, physical checks.

Least squares over many turns (docs/method.md §5). With w(phi) = (lam sin phi, lam cos phi, 1),
(1 + lam^2) J_e(phi) = w^T J w = v(phi) . [Jx Jy Jz Jxy Jyz Jxz], v the design-matrix row of
the unnormalised w (docs/method.md §2: the harmonic form of M per stage written in the tensor's
entries, so that all stages share one set of unknowns; rsp_inertia.plant.model.tensor_basis
gives these rows from the model's M, rsp_inertia.plant.model.gravity_basis the gravity
columns from its Pi). Each balance angle of a run (one
stage, one direction of rotation) gives

    1/2 S v(phi) . J + 2 Gs sin phi + 2 Gc cos phi - C_run - d . R - dir e_s . Q
        = h_d W_d(phi) + h_b W_b(phi) - 2 Pi_spring - 1/2 S M_empty(phi) - 2 Pi_fixture(phi)

(rsp_inertia.estimation.balance), linear in the six entries, the gravity terms Gs = m g x_c,
Gc = m g y_c shared by all runs, one constant per run, per run the two slopes d of the
friction torque that the closed loop's tracking mismatch leaves in the balance (regressors R),
and, for a stage run in both directions, its friction asymmetry e_s (regressors Q, sign
dir = +1 forward, -1 backward: the first-order effect of a friction that differs between the
directions of rotation cancels between the runs). The right-hand side holds what the rig's
calibration knows (:class:`KnownTerms`): the drive's gains h_d, h_b on the logged motor work's
driving and back-driven parts W_d, W_b (docs/method.md §3, encoder and drive), the empty
system's reduced inertia M_empty (tare and fixture), the fixture's gravity and the encoder's
error (taken off the readings before the balances); without a calibration, device.toml's
tare as exact. The calibrated terms also join the unknowns with their calibration as prior,
and the model tests' probes look for a drive's loss and an encoder's error left in the runs
(:func:`probe_detail`). Weights, the speed-noise scale, the model tests and the uncertainty
budget: rsp_inertia.estimation.gls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from rsp_inertia.estimation.balance import StageBalance
from rsp_inertia.estimation.gls import NOISE_SOURCES, Block, Prior, solve_blocks
from rsp_inertia.estimation.model_tests import ModelTest
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.geometry import ENTRY_KEYS, design_matrix
from rsp_inertia.plant.model import gravity_basis, inertia_basis, tensor_basis
from rsp_inertia.plant.transducers import error_slope_basis

__all__ = [
    "ENTRY_KEYS",
    "HARMONIC_NAMES",
    "NOISE_SOURCES",
    "KnownTerms",
    "TensorFit",
    "axis_values",
    "balance_rhs",
    "both_directions",
    "cause_probes",
    "described",
    "encoder_columns",
    "encoder_names",
    "encoder_unknowns",
    "fit_tensor",
    "format_run",
    "gravity_rows",
    "run_columns",
    "run_key",
    "run_label",
    "run_priors",
    "tensor_block",
    "tensor_from_axes",
]




@dataclass(frozen=True)
class TensorFit:
    """Result of the least squares over every stage's balance angles."""

    entries: np.ndarray
    """[Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2 (products as tensor entries)."""
    gravity: np.ndarray
    """[Gs, Gc] = m g [x_c, y_c], N m."""
    cov: np.ndarray
    """(8, 8) joint covariance of [entries, gravity] (kg^2 m^4, kg m^2 N m, N^2 m^2): the
    least squares solves them together, so their errors correlate (a combination of
    mountings needs the whole matrix, rsp_inertia.estimation.combine)."""
    chi2_dof: float
    """Residual chi^2 per degree of freedom of the weighted fit (1 when the noise model fits)."""
    speed_noise_scale: list[float]
    """Per run, the factor on the derived speed-error covariance that makes the run's own
    fit reach chi^2/dof = 1 (rsp_inertia.estimation.gls)."""
    n_equations: int
    """Balance angles used, all runs."""
    friction_slope: np.ndarray
    """(runs, 2) [d1, d2] of D'(Omega) = d1 + d2 Omega per run (N m s, N m s^2), from the
    tracking mismatch; NaN for a run with exactly no mismatch (exact data)."""
    friction_slope_std: np.ndarray
    """(runs, 2)."""
    friction_slope_cov: np.ndarray
    """(runs, 2, 2) covariance of each run's [d1, d2] (NaN where not fitted)."""
    mismatch_terms: list[bool]
    """Per run: whether the tracking-mismatch friction terms were fitted (NaN slopes if not:
    only when the mismatch is exactly zero)."""
    cov_parts: dict[str, np.ndarray]
    """Covariance of [entries, gravity] split by noise source (rsp_inertia.estimation.gls NOISE_SOURCES
    and CALIBRATION_SOURCE); the parts sum to the whole: the uncertainty budget."""
    friction_asymmetry: np.ndarray | None = None
    """(stages, 3) e = [e1, e2, e3] of D_backward - D_forward = e1 + e2 |Omega| + e3 Omega^2
    (N m, N m s, N m s^2) for stages run in both directions; NaN rows for the others."""
    friction_asymmetry_std: np.ndarray | None = None
    """(stages, 3)."""
    tests: list[ModelTest] | None = None
    """The balance model's tests (rsp_inertia.estimation.gls): runs against each other, early against
    late turns."""
    runs: list[tuple[int, str]] | None = None
    """(stage, direction) of each run, in the order of the balances."""
    known_after: KnownTerms | None = None
    """The calibrated terms after the runs refined them (rsp_inertia.estimation.gls: the
    calibration as prior, the runs' information added); None without calibrated terms."""
    prior_warnings: list[str] = field(default_factory=list)
    """A line per run whose friction slopes' prior its balances rejected
    (rsp_inertia.estimation.gls, priors)."""

    @property
    def entries_cov(self) -> np.ndarray:
        """(6, 6) covariance of ``entries``, kg^2 m^4: the upper-left block of ``cov``."""
        return self.cov[:6, :6]

    @property
    def gravity_cov(self) -> np.ndarray:
        """(2, 2) covariance of ``gravity``, N^2 m^2: the lower-right block of ``cov``."""
        return self.cov[6:, 6:]


HARMONIC_NAMES = ("M0", "Mc2", "Ms2", "Ms1", "Mc1")
"""Names of the harmonics of M(phi) (rsp_inertia.plant.model.inertia_harmonics), in order."""

DRIVE_SOURCE = "calibration: drive gains"
"""Budget line of the drive's calibrated gains h_d, h_b."""
ENCODER_SOURCE = "calibration: encoder error"
"""Budget line of the encoder's calibrated error harmonics."""
EMPTY_SOURCE = "calibration: tare and fixture"
"""Budget line of the empty system's calibrated harmonics and the fixture's gravity."""

DRIVE_PROBE = "drive loss"
"""The model test of a drive that loses power by its direction of flow (probe kind)."""
ENCODER_PROBE = "encoder error"
"""The model test of a periodic error of the encoder's reading (probe kind)."""
PROBE_ORDERS = 3
"""Orders of the encoder's error the probe looks for (rsp_inertia.estimation.calibration
ENCODER_ORDERS: orders 1 and 2 bias the tensor, order 3 is still measurable)."""


@dataclass(frozen=True)
class KnownTerms:
    """What the balances take as known about the rig (docs/method.md §2-3, §5 Calibration).

    From ``calibration.toml`` (rsp_inertia.estimation.calibration), or device.toml's tares alone:
    the drive's gains by direction of power flow (h_d, h_b: the torque the body receives per
    unit of logged torque while the motor drives it and while it is back-driven,
    rsp_inertia.plant.transducers.drive_gains), the empty system's reduced inertia per stage
    (tare and fixture), the fixture's gravity terms and the encoder's error harmonics, with
    the covariance of theta = [h_d, h_b, harmonics of stage 1..n, Gs_f, Gc_f, c_1, s_1, ...]
    (:meth:`names`).
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

    def __post_init__(self) -> None:
        object.__setattr__(self, "gains", (float(self.gains[0]), float(self.gains[1])))
        object.__setattr__(self, "encoder", np.asarray(self.encoder, dtype=float).reshape(-1))
        if self.cov.shape != (len(self.names()),) * 2:
            raise ValueError(
                f"KnownTerms.cov must be {len(self.names())} x {len(self.names())} (names()), "
                f"got {self.cov.shape}"
            )

    @classmethod
    def from_tares(cls, tares) -> KnownTerms:
        """device.toml's tares as exact: M_empty = M_tare, no fixture terms, an exact torque
        constant, a lossless drive and an exact encoder."""
        tares = np.asarray(tares, dtype=float)
        exact = cls.exact(len(tares))
        exact.inertia[:, 0] = tares
        return exact

    @classmethod
    def exact(cls, stages: int, encoder=()) -> KnownTerms:
        """Nothing known about the rig yet, but its number of stages: gains 1, no empty
        system, no fixture, the encoder error ``encoder`` (coefficients), all exact."""
        encoder = np.asarray(encoder, dtype=float).reshape(-1)
        size = 2 + 5 * stages + 2 + encoder.size
        return cls((1.0, 1.0), np.zeros((stages, 5)), np.zeros(2), np.zeros((size, size)),
                   encoder=encoder)

    @property
    def theta(self) -> np.ndarray:
        """The values of theta, in the order of :meth:`names`."""
        return np.concatenate([self.gains, self.inertia.ravel(), self.gravity, self.encoder])

    def with_theta(self, theta: np.ndarray, cov: np.ndarray, calibrated: bool = True):
        """These terms' layout with the values ``theta`` and their covariance ``cov``.

        Parameters
        ----------
        theta : numpy.ndarray
            The values, in the order of :meth:`names`.
        cov : numpy.ndarray
            Their covariance.
        calibrated : bool, optional
            Whether theta carries an uncertainty to propagate.

        Returns
        -------
        KnownTerms
            The new terms.
        """
        theta = np.asarray(theta, dtype=float)
        return KnownTerms(
            gains=(float(theta[0]), float(theta[1])),
            inertia=theta[2 : self.gravity_slice.start].reshape(self.inertia.shape),
            gravity=theta[self.gravity_slice],
            cov=cov,
            calibrated=calibrated,
            encoder=theta[self.encoder_slice],
        )

    @property
    def orders(self) -> int:
        """Orders of the encoder's error series (len(encoder) / 2)."""
        return self.encoder.size // 2

    def names(self) -> list[str]:
        """The names of theta, in order: h_d, h_b, M0[1] .. Mc1[n], Gs, Gc, c1, s1, ..."""
        names = ["h_d", "h_b"]
        for s in range(1, len(self.inertia) + 1):
            names += [f"{h}[{s}]" for h in HARMONIC_NAMES]
        names += ["Gs", "Gc"]
        return names + encoder_names(self.orders)

    def harmonics_slice(self, stage: int) -> slice:
        """theta's entries of the empty system's harmonics of stage ``stage`` (from 1)."""
        return slice(2 + 5 * (stage - 1), 7 + 5 * (stage - 1))

    @property
    def gravity_slice(self) -> slice:
        """theta's entries of the fixture's gravity terms."""
        start = 2 + 5 * len(self.inertia)
        return slice(start, start + 2)

    @property
    def encoder_slice(self) -> slice:
        """theta's entries of the encoder's error coefficients."""
        start = 4 + 5 * len(self.inertia)
        return slice(start, start + self.encoder.size)

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
        g[0] = M_parts[0] / self.gains[0]
        g[1] = M_parts[1] / self.gains[1]
        g[self.harmonics_slice(stage)] = -inertia_basis(np.atleast_1d(phi))[0]
        if self.orders:
            g[self.encoder_slice] = 2 * M * error_slope_basis(phi, self.orders)
        return float(g @ self.cov @ g)

    def empty_variance(self, stage: int, phi: float) -> float:
        """Variance of M_empty(phi) of stage ``stage``, kg^2 m^4."""
        g = np.zeros(self.cov.shape[0])
        g[self.harmonics_slice(stage)] = inertia_basis(np.atleast_1d(phi))[0]
        return float(g @ self.cov @ g)

    def summary(self, after: KnownTerms | None = None) -> dict | None:
        """result.json's ``calibration``: what was applied (None when nothing was), and with
        ``after`` (the terms after the runs refined them) the drive's gains and the encoder's
        error as the runs left them (``refined``)."""
        if not self.calibrated:
            return None
        out = self._summary()
        if after is not None:
            refined = after._summary()
            out["refined"] = {
                name: refined[name]
                for name in (
                    "drive_gains", "drive_gains_std", "round_trip_efficiency",
                    "round_trip_efficiency_std", "encoder_error", "encoder_error_std",
                )
            }
        return out

    def _summary(self) -> dict:
        std = self.std
        n = len(self.inertia)
        encoder = self.encoder_slice
        return {
            "drive_gains": [float(v) for v in self.gains],
            "drive_gains_std": [float(v) for v in std[:2]],
            "round_trip_efficiency": float(self.gains[0] / self.gains[1]),
            "round_trip_efficiency_std": float(self.round_trip_std()),
            "empty_inertia": [[float(v) for v in row] for row in self.inertia],
            "empty_inertia_std": [
                [float(v) for v in std[self.harmonics_slice(s)]] for s in range(1, n + 1)
            ],
            "fixture_gravity": [float(v) for v in self.gravity],
            "fixture_gravity_std": [float(v) for v in std[self.gravity_slice]],
            "encoder_error": [float(v) for v in self.encoder],
            "encoder_error_std": [float(v) for v in std[encoder]],
        }

    def budget_groups(self) -> dict[str, list[int]]:
        """Budget lines of theta (rsp_inertia.estimation.gls), in the order they are added:
        the drive's gains, the encoder's error, the tare and fixture."""
        n = self.cov.shape[0]
        groups = {
            DRIVE_SOURCE: [0, 1],
            ENCODER_SOURCE: list(range(n)[self.encoder_slice]),
            EMPTY_SOURCE: list(range(2, self.gravity_slice.stop)),
        }
        return {name: indices for name, indices in groups.items() if indices}

    def round_trip_std(self) -> float:
        """Std of the round-trip efficiency h_d / h_b = eta_d eta_b (first order)."""
        g = np.zeros(self.cov.shape[0])
        g[0] = 1.0 / self.gains[1]
        g[1] = -self.gains[0] / self.gains[1] ** 2
        return float(np.sqrt(max(g @ self.cov @ g, 0.0)))

    def jacobian(self, bal: StageBalance) -> np.ndarray:
        """(n, p) d rhs / d theta of one run's equations (:func:`balance_rhs`), but for the
        encoder's columns, which are M(phi) times :meth:`jacobian_inertia`."""
        B = np.zeros((len(bal.phi), self.cov.shape[0]))
        B[:, :2] = bal.motor_work_parts
        B[:, self.harmonics_slice(bal.stage)] = -0.5 * bal.speed_sq[:, None] * inertia_basis(
            bal.phi
        )
        B[:, self.gravity_slice] = -gravity_rows(bal.phi)
        return B

    def jacobian_inertia(self, bal: StageBalance) -> np.ndarray | None:
        """(n, p) the part of d rhs / d theta that is the reduced inertia M(phi) times this:
        the encoder's, :func:`encoder_columns` (None without encoder terms)."""
        if not self.orders:
            return None
        B = np.zeros((len(bal.phi), self.cov.shape[0]))
        B[:, self.encoder_slice] = encoder_columns(bal, self.orders)
        return B


def encoder_names(orders: int) -> list[str]:
    """The encoder's coefficients' names, c1, s1, c2, ... (KnownTerms.names)."""
    return [f"{kind}{n}" for n in range(1, orders + 1) for kind in ("c", "s")]


def described(
    tests: list[ModelTest], known: KnownTerms, one_direction: bool = False
) -> list[ModelTest]:
    """The model tests with their probes' :func:`probe_detail` filled in (their warnings').

    Parameters
    ----------
    tests : list of ModelTest
        The fit's model tests.
    known : KnownTerms
        The rig's known terms the fit applied.
    one_direction : bool, optional
        Some stage was run in one direction only.

    Returns
    -------
    list of ModelTest
        The tests, the probes' with their ``detail``.
    """
    return [
        replace(test, detail=probe_detail(test, known, one_direction))
        if test.kind in (DRIVE_PROBE, ENCODER_PROBE)
        else test
        for test in tests
    ]


def probe_detail(test: ModelTest, known: KnownTerms, one_direction: bool = False) -> str:
    """What a probe test's fitted terms say, in words and numbers (its warning's text).

    drive loss: the driving work's gain came out h_d + dh_d against h_b's, so the runs call
    for the round-trip efficiency (h_d + dh_d) / h_b (the common scale of both gains the
    tensor takes up). encoder error: each order's amplitude sqrt(c_n^2 + s_n^2), first-order
    std, in arcseconds. What to do depends on what is known: a calibration of the drive or of
    the encoder that the runs contradict (the rig changed since), or none (calibrate). In a
    stage run one way only, friction that differs between the directions of rotation leaves
    the same shape as a drive's loss (the braking turns one way, the reverse the other),
    so the drive's warning names it too.

    Parameters
    ----------
    test : ModelTest
        A model test, its ``estimate`` and ``estimate_cov`` the probe's fitted terms.
    known : KnownTerms
        The rig's known terms the fit applied (a calibration or none).
    one_direction : bool, optional
        Some stage was run in one direction only.

    Returns
    -------
    str
        The warning's text; empty for a test that is no probe.
    """
    x, cov = test.estimate, test.estimate_cov
    gains = known.gains
    std = known.std if known.calibrated else np.zeros(known.cov.shape[0])
    if test.kind == DRIVE_PROBE:
        ratio = (gains[0] + x[0]) / gains[1]
        ratio_std = math.sqrt(max(cov[0, 0], 0.0)) / gains[1]
        if np.any(std[:2] > 0):
            cause = (
                "the calibrated gains do not fit these runs: a drive whose losses changed "
                "since the calibration (calibrate again)"
            )
        else:
            cause = (
                "a transmission that loses power by its direction of flow; rsp-inertia "
                "calibrate with a reference run measures h_d and h_b"
            )
        if one_direction:
            cause += (
                ", or friction that differs between the directions of rotation, which in a "
                "stage run one way looks the same (run the stages both ways: directions = "
                '["forward", "backward"])'
            )
        return (
            "the work the drive delivers while it drives the body and while the body drives "
            "it back do not share one scale: the balances call for a round-trip efficiency "
            f"h_d / h_b = {ratio:.4f} +- {ratio_std:.1g} where {gains[0] / gains[1]:.4f} is "
            f"applied ({cause})"
        )
    if test.kind == ENCODER_PROBE:
        parts = []
        for n in range(len(x) // 2):
            c, s_ = x[2 * n : 2 * n + 2]
            a = math.hypot(c, s_)
            g = np.array([c, s_]) / a if a > 0 else np.zeros(2)
            a_std = math.sqrt(max(g @ cov[2 * n : 2 * n + 2, 2 * n : 2 * n + 2] @ g, 0.0))
            arcsec = math.degrees(1.0) * 3600
            parts.append(f"order {n + 1} {a * arcsec:.2g} +- {a_std * arcsec:.1g}")
        if np.any(std[known.encoder_slice] > 0):
            cause = (
                "left after the calibrated correction: an encoder that moved or was remounted "
                "since the calibration (calibrate again)"
            )
        else:
            cause = (
                "an eccentric or running-out encoder; rsp-inertia calibrate with a reference "
                "run measures it, or state the maker's certificate in device.toml [encoder] "
                "error_cos, error_sin, error_std"
            )
        return (
            "the balances carry a periodic error of the encoder's reading: "
            + ", ".join(parts)
            + f" arcsec ({cause})"
        )
    return ""


def encoder_unknowns(bal: StageBalance, orders: int) -> dict[str, np.ndarray]:
    """The encoder coefficients' columns on the unknowns' side, per unit of M(phi), by name
    (:func:`encoder_columns` negated: an error left in the readings raises the kinetic
    energy's share)."""
    return dict(zip(encoder_names(orders), -encoder_columns(bal, orders).T))


def cause_probes(bal: StageBalance) -> tuple[dict, dict]:
    """(probes, probes_per_inertia) of one run's block (rsp_inertia.estimation.gls Block):
    the drive loss's column (the driving work's gain freed) and the encoder error's (orders
    1 to PROBE_ORDERS, per unit of M)."""
    return (
        {DRIVE_PROBE: {"dh_d": -bal.motor_work_parts[:, 0]}},
        {ENCODER_PROBE: encoder_unknowns(bal, PROBE_ORDERS)},
    )


def encoder_columns(bal: StageBalance, orders: int) -> np.ndarray:
    """(n, 2 orders) how an error of the encoder's coefficients moves one run's balance, per
    unit of M(phi) (docs/method.md §5 Calibration).

    A reading error e left in the logs scales both passes' speeds at an angle by 1 + e'(phi),
    so 1/2 M S reads 1/2 M S (1 + 2 e'): the balance gains M S e'_theta(phi) per unit of each
    coefficient (rsp_inertia.plant.transducers.error_slope_basis, at the body's angle). The
    error's smaller effects (the angle's own shift in M, the potential and the work: a few
    percent of this at order 1) are left out: calibrate iterates on the corrected logs.
    """
    return bal.speed_sq[:, None] * error_slope_basis(bal.phi, orders)


def gravity_rows(phi: np.ndarray) -> np.ndarray:
    """(n, 2) 2 dPi/d[Gs, Gc]: the gravity potential's share of the balance, twice for the
    two passes (docs/method.md §3, rsp_inertia.plant.model.gravity_basis)."""
    return 2 * gravity_basis(phi)


def balance_rhs(bal: StageBalance, known: KnownTerms) -> np.ndarray:
    """The known side of one run's equations: h_d W_d + h_b W_b - 2 Pi_spring - 1/2 S M_empty
    - 2 Pi_f.

    W_d, W_b the driving and back-driven parts of the logged motor work of both passes,
    M_empty(phi) the empty system's reduced inertia and Pi_f the fixture's gravity potential
    (docs/method.md §5, with the rig's terms of :class:`KnownTerms`).
    """
    M_empty = inertia_basis(bal.phi) @ known.inertia[bal.stage - 1]
    spring = 0.0 if bal.spring is None else bal.spring
    received = bal.work if known.gains == (1.0, 1.0) else bal.received_work(known.gains) - spring
    return received - 0.5 * bal.speed_sq * M_empty - gravity_rows(bal.phi) @ known.gravity


def run_key(bal: StageBalance) -> tuple[int, Direction]:
    """(stage, direction) of a run."""
    return bal.stage, Direction.of_sign(bal.direction)


def format_run(key: tuple[int, str]) -> str:
    """"stage N forward" or "stage N backward" from (stage, direction)."""
    stage, direction = key
    return f"stage {stage} {direction}"


def run_label(bal: StageBalance) -> str:
    """"stage N forward" or "stage N backward"."""
    return format_run(run_key(bal))


def run_columns(
    bal: StageBalance, key: str, both_directions: bool, group: str | None = None
) -> dict[str, np.ndarray]:
    """The columns every run has whatever the question: its constant, the tracking mismatch's
    friction slopes (rsp_inertia.estimation.balance; left out when the mismatch is exactly zero, exact
    data), and the friction asymmetry of a stage run in both directions.

    Parameters
    ----------
    bal : StageBalance
        The run's balance.
    key : str
        Names the run's own unknowns (``C[key]``, ``d1[key]``, ``d2[key]``).
    both_directions : bool
        The run's stage is run in both directions: the friction asymmetry's columns join.
    group : str, optional
        Names the friction asymmetry's unknowns, shared by the runs of ``group``; by default
        the stage.

    Returns
    -------
    dict of str to numpy.ndarray
        Name -> column, one entry per balance angle.
    """
    group = str(bal.stage) if group is None else group
    n = len(bal.phi)
    cols = {f"C[{key}]": -np.ones(n)}
    if np.any(bal.mismatch != 0.0):
        cols[f"d1[{key}]"] = -bal.mismatch[:, 0]
        cols[f"d2[{key}]"] = -bal.mismatch[:, 1]
    if both_directions:
        for k in range(3):
            cols[f"e{k + 1}[{group}]"] = -bal.direction * bal.friction_shape[:, k]
    return cols


def run_priors(bal: StageBalance, columns: dict[str, np.ndarray], key: str) -> tuple[Prior, ...]:
    """The run's priors on its own unknowns: its friction slopes' from its passes' dynamics
    (rsp_inertia.estimation.balance.friction_slope_prior), when it has slope columns and the
    prior was made.

    Parameters
    ----------
    bal : StageBalance
        The run's balance (its ``slope_prior``).
    columns : dict of str to numpy.ndarray
        The run's columns (:func:`run_columns`).
    key : str
        Names the run's own unknowns.

    Returns
    -------
    tuple of Prior
        The friction slopes' prior, or none.
    """
    names = (f"d1[{key}]", f"d2[{key}]")
    if bal.slope_prior is None or not all(name in columns for name in names):
        return ()
    return (Prior(names, *bal.slope_prior),)


def both_directions(balances: list[StageBalance]) -> set[int]:
    """Stages with runs in both directions."""
    seen: dict[int, set[int]] = {}
    for bal in balances:
        seen.setdefault(bal.stage, set()).add(bal.direction)
    return {stage for stage, dirs in seen.items() if len(dirs) == 2}


def tensor_block(bal: StageBalance, run: str, known: KnownTerms, asymmetry: bool) -> Block:
    """One run's equations in the tensor's unknowns (module docstring).

    Parameters
    ----------
    bal : StageBalance
        The run's balance.
    run : str
        Names the run's own unknowns (its constant and friction slopes).
    known : KnownTerms
        The rig's known terms: the right-hand side and, when calibrated, their Jacobians.
    asymmetry : bool
        The run's stage is run in both directions, so its friction asymmetry is an unknown.

    Returns
    -------
    Block
        The run's equations for rsp_inertia.estimation.gls.solve_blocks.
    """
    v = tensor_basis(bal.phi, bal.gear_ratio)
    probes = cause_probes(bal)
    half_s = 0.5 * bal.speed_sq
    cols = {name: half_s * v[:, i] for i, name in enumerate(ENTRY_KEYS)}
    cols["Gs"], cols["Gc"] = gravity_rows(bal.phi).T
    cols.update(run_columns(bal, run, asymmetry))
    return Block(
        balance=bal,
        label=run_label(bal),
        columns=cols,
        rhs=balance_rhs(bal, known),
        inertia_columns={name: v[:, i] for i, name in enumerate(ENTRY_KEYS)},
        inertia_known=inertia_basis(bal.phi) @ known.inertia[bal.stage - 1],
        work_scales=bal.work_scales(known.gains),
        known_jacobian=known.jacobian(bal) if known.calibrated else None,
        known_jacobian_inertia=known.jacobian_inertia(bal) if known.calibrated else None,
        probes=probes[0],
        probes_per_inertia=probes[1],
        groups={name: run_label(bal) for name in ENTRY_KEYS},
        joint_only=frozenset(name for name in cols if name.startswith("e")),
        priors=run_priors(bal, cols, run),
    )


def fit_tensor(
    balances: list[StageBalance],
    known: KnownTerms | None = None,
    predict: bool = False,
    tests: bool = True,
) -> TensorFit:
    """Generalised least squares for the tensor and the gravity terms (module docstring).

    Unknowns: the six entries and the gravity terms (shared by every run), one constant and
    the tracking mismatch's two friction slopes per run, and the friction asymmetry
    e = [e1, e2, e3] per stage run in both directions. Solved, weighted and checked by
    :func:`rsp_inertia.estimation.gls.solve_blocks`.

    Parameters
    ----------
    balances : list of StageBalance
        Every run's balance.
    known : KnownTerms, optional
        The rig's known terms; device.toml's tares as exact by default.
    predict : bool, optional
        Noise-free balances of a planned run, whose covariance is then the noise model's
        alone (rsp_inertia.estimation.predict).
    tests : bool, optional
        False: no model tests (a rehearsal of a plan, rsp_inertia.design.rehearsal).

    Returns
    -------
    TensorFit
        The entries and gravity terms with their covariance and budget, the runs' speed-noise
        scales and friction terms, and the model tests.
    """
    if known is None:
        tares = {bal.stage: bal.tare_inertia for bal in balances}
        known = KnownTerms.from_tares([tares.get(s, 0.0) for s in range(1, max(tares) + 1)])
    both = both_directions(balances)
    blocks = [tensor_block(bal, str(k), known, bal.stage in both) for k, bal in enumerate(balances)]
    fit = solve_blocks(
        blocks,
        known.cov if known.calibrated else None,
        predict=predict,
        tests=tests,
        known_groups=known.budget_groups(),
    )
    one_direction = len(both) < len({bal.stage for bal in balances})
    model_tests = described(fit.tests, known, one_direction)
    shared = [fit.index(name) for name in (*ENTRY_KEYS, "Gs", "Gc")]
    n_runs, stages = len(balances), sorted({bal.stage for bal in balances})
    slope = np.full((n_runs, 2), np.nan)
    slope_std = np.full((n_runs, 2), np.nan)
    slope_cov = np.full((n_runs, 2, 2), np.nan)
    for k in range(n_runs):
        for j in range(2):
            slope[k, j], slope_std[k, j] = fit.value(f"d{j + 1}[{k}]")
        names = [f"d1[{k}]", f"d2[{k}]"]
        if all(name in fit.names for name in names):
            i = [fit.index(name) for name in names]
            slope_cov[k] = fit.cov[np.ix_(i, i)]
    asym = np.full((max(stages), 3), np.nan)
    asym_std = np.full((max(stages), 3), np.nan)
    for s in both:
        for j in range(3):
            asym[s - 1, j], asym_std[s - 1, j] = fit.value(f"e{j + 1}[{s}]")
    sub = np.ix_(shared, shared)
    # The sum of the sources' parts is symmetric up to rounding (4e-10 of the smallest
    # products); result.json and a combination of mountings take it exactly symmetric.
    cov = (fit.cov[sub] + fit.cov[sub].T) / 2
    return TensorFit(
        entries=fit.x[shared[:6]],
        gravity=fit.x[shared[6:]],
        cov=cov,
        chi2_dof=fit.chi2_dof,
        speed_noise_scale=fit.scales,
        n_equations=fit.n_equations,
        friction_slope=slope,
        friction_slope_std=slope_std,
        friction_slope_cov=slope_cov,
        mismatch_terms=[bool(np.any(bal.mismatch != 0.0)) for bal in balances],
        cov_parts={name: part[sub] for name, part in fit.cov_parts.items()},
        friction_asymmetry=asym,
        friction_asymmetry_std=asym_std,
        tests=model_tests,
        runs=[run_key(bal) for bal in balances],
        known_after=(
            None
            if fit.known_shift is None
            else known.with_theta(known.theta + fit.known_shift, fit.known_shift_cov)
        ),
        prior_warnings=list(fit.prior_warnings),
    )


def axis_values(entries: np.ndarray, cov: np.ndarray, directions: np.ndarray):
    """J_k = e_k^T J e_k for unit directions, with standard deviations (docs/method.md §5 (8)).

    Parameters
    ----------
    entries : numpy.ndarray, shape (6,)
        kg m^2, the tensor's entries [Jx, Jy, Jz, Jxy, Jyz, Jxz].
    cov : numpy.ndarray, shape (6, 6)
        Their covariance.
    directions : numpy.ndarray, shape (k, 3)
        The axes' unit directions e_k.

    Returns
    -------
    values, stds : numpy.ndarray
        kg m^2, J_k and its std per axis.
    """
    V = design_matrix(directions)
    values = V @ entries
    # v^T C v of a covariance is >= 0; a source that leaves an axis untouched (a tare std of
    # 0 on its stage) gives 0, which rounding can turn into -1e-30 (a NaN std otherwise).
    stds = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", V, cov, V), 0.0))
    return values, stds


def tensor_from_axes(values: np.ndarray, stds: np.ndarray, directions: np.ndarray):
    """Tensor entries from axis moments through V: solve (6 axes) or weighted least squares.

    Parameters
    ----------
    values : numpy.ndarray
        kg m^2, the axis moments J_k.
    stds : numpy.ndarray
        kg m^2, their standard deviations (the weights).
    directions : numpy.ndarray, shape (k, 3)
        The axes' unit directions.

    Returns
    -------
    entries : numpy.ndarray, shape (6,)
        kg m^2, [Jx, Jy, Jz, Jxy, Jyz, Jxz].
    cov : numpy.ndarray, shape (6, 6)
        Their covariance (the design's cond(V): rsp_inertia.plant.geometry.device_design).
    """
    V = design_matrix(directions)
    W = 1 / np.asarray(stds)
    x, *_ = np.linalg.lstsq(V * W[:, None], values * W, rcond=None)
    cov = np.linalg.pinv((V * W[:, None]).T @ (V * W[:, None]))
    return x, cov


