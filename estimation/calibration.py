"""Calibration of the rig: the empty fixture (tare) and a reference body (torque gain).

Like every mass-properties instrument, the gimbal is calibrated with runs of its own:

- an **empty** experiment, the fixture without a body: its balances give, per stage, the
  empty system's reduced inertia M_empty(phi) in harmonic form (docs/method.md §2: the tare
  M_tare(lambda) and an unbalanced mounting plate's own harmonics, five coefficients), and
  the fixture's gravity terms Gs_f = m_f g x_f, Gc_f = m_f g y_f (docs/method.md §3);
- a **reference** experiment, the fixture with a body whose tensor, mass and centre of mass
  are known (``reference.toml``): the same balances with the known body's M_ref(phi) and
  gravity added fix the scale of the logged torque, and with it the drive's two gains
  h_d, h_b (docs/method.md §3: the torque the body receives per unit of logged torque while
  the motor drives it and while the body drives the motor back) and the encoder's error
  harmonics.

One generalised least squares over every run of both experiments (rsp_inertia.estimation.gls), per
balance angle of a run of stage s:

    1/2 S M_s(phi) . [basis] + 2 Pi_f(phi) - h_d W_d(phi) - h_b W_b(phi) - M S e'(phi) . dtheta_e
        - C_run - (slopes, asymmetry)
        = - 2 Pi_spring(phi) - [reference runs: 1/2 S M_ref(phi) + 2 Pi_ref(phi)]

with the harmonics of M_empty of stage s, the fixture's gravity, h_d, h_b and the encoder's
coefficients as unknowns. The drive's gains and the encoder come only with a reference: its
known M_ref sets the scale that separates h_d and h_b (through the friction's share of the
work, which differs between stages, runs and turns), and its added M0 separates the
encoder's once- and twice-per-revolution error (which scales with the whole M) from the
fixture's harmonics (which do not). Without a reference, h_d = h_b = 1 and the encoder's
error is device.toml's, exact unless stated with a std.

The encoder's error enters through the readings, so its column (the kinetic energy's share,
rsp_inertia.estimation.columns.encoder_columns) is its first-order effect: the fit is
repeated on the logs corrected with the estimate so far (:data:`ENCODER_ITERATIONS`), until
the correction moves by less than :data:`ENCODER_TOLERANCE` of its std.

The estimates and their covariance are the calibration (:class:`KnownTerms`), written to
``EXP/calibration.toml`` and applied by identify: there the loaded run's readings are
corrected, its right-hand side is h_d W_d + h_b W_b - 2 Pi_spring - 1/2 S M_empty - 2 Pi_f,
and the calibration's covariance reaches the tensor as its own budget line.

The reference body's certified values (mass, tensor, centre of mass) are known terms of
the fit with their certificate's covariance as a prior (reference.toml's stds;
rsp_inertia.plant.config.Reference), as identify takes the calibration's terms
(rsp_inertia.estimation.gls, known terms): their columns are the reference runs' d rhs / d
value (rsp_inertia.estimation.conventions.certificate_jacobian), so the runs refine them where they carry information,
the model tests take an error of the certificate within its stds for the certificate's and
not for a fault of the rig, and the certificate's uncertainty reaches every calibrated term
through the whole fit (tares and their harmonics, fixture, drive gains, encoder). The
certificate's common scale (mass and tensor together) is the logged torque's: the runs
carry no information on it, so it is propagated, never fitted (the ``consider`` direction of
rsp_inertia.estimation.gls). Its share of the calibration's covariance is kept apart
(KnownTerms.certificate_cov) for identify's budget line :data:`CERTIFICATE_SOURCE`. A
certificate without stds is taken as exact, with a warning. Friction may differ between
the calibration runs and the loaded ones (it cancels within each run).

With a reference, device.toml's torque constant's tempco and its std, and logs that carry
the temperature, the tempco's change from the stated value is one more unknown of the last
fit, with the stated std as its prior (rsp_inertia.estimation.tempco): kept, and written to
calibration.toml, where the runs measure it; otherwise that fit is made again without it.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2 as chi2_distribution

from rsp_inertia.estimation.calibration_file import (
    CalibrationFile,
    calibration_file,
    calibration_text,
)
from rsp_inertia.estimation.columns import (
    WARMING_UNKNOWN,
    both_directions,
    cause_probes,
    encoder_unknowns,
    gravity_row_slopes,
    gravity_rows,
    probe_bounds,
    run_columns,
    run_label,
    run_priors,
)
from rsp_inertia.estimation.conventions import (
    CONVENTION_FACTOR,
    certificate_jacobian,
    certified_terms_std,
    check_conventions,
    reference_terms,
    shows_orientation,
    significant_terms,
    unverified_conventions,
)
from rsp_inertia.estimation.gls import (
    BalanceFit,
    Block,
    Prior,
    assemble_blocks,
    block_model_tests,
    solve_blocks,
    speed_noise_scales,
)
from rsp_inertia.estimation.known_terms import CERTIFICATE_SOURCE, KnownTerms
from rsp_inertia.estimation.layout import ZERO_NAME, theta_layout
from rsp_inertia.estimation.model_tests import (
    WARMING_PROBE,
    ModelTest,
    described,
    model_warnings,
)
from rsp_inertia.estimation.runs import ExperimentLogs, balance_runs, corrected_log
from rsp_inertia.estimation.stiffness import StiffnessCalibration, calibrate_stiffness
from rsp_inertia.estimation.tempco import TEMPCO_NAME, TempcoFit
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.progress import drop, lines_to, say
from rsp_inertia.plant.config import (
    REFERENCE_PARAMETERS,
    Certificate,
    Device,
    Reference,
    TrueBody,
)
from rsp_inertia.plant.experiment import CALIBRATION_FILE
from rsp_inertia.plant.geometry import HARMONIC_NAMES
from rsp_inertia.plant.model import inertia_basis, inertia_basis_slope

__all__ = [
    "Calibration",
    "calibrate_logs",
    "calibrated_known_terms",
    "device_known_terms",
    "fit_calibration",
]

STIFFNESS_CHI2_WARN = 4.0
"""chi^2/dof of the nodes' pendulum stiffnesses above which calibrate warns."""

ENCODER_ORDERS = 3
"""Orders of the encoder's error that calibrate measures (with a reference). Orders 1 and 2
(an eccentric disc, runout) are the ones that bias the tensor: they read as M's own
harmonics; order 3 and above are orthogonal to M's harmonics, so they cannot bias it, but
they raise the residuals (and with them the stds and the model tests) and order 3 is still
tens of 1e-6 rad on ordinary encoders. Higher orders are smaller and left to the residuals."""

ENCODER_ITERATIONS = 4
"""Fits at most on logs corrected with the encoder's estimate so far (module docstring)."""

ENCODER_TOLERANCE = 0.02
"""The iteration stops when the correction moves by less than this fraction of its std."""


@dataclass(frozen=True)
class Calibration:
    """What ``rsp-inertia calibrate`` finds, as written to calibration.toml."""

    device_name: str
    """[device] name of the experiment it was made for."""
    counts_per_rev: int
    """The encoder's, to recognise the device."""
    gear_ratios: tuple[float, ...]
    """Per stage."""
    nodes_deg: tuple[tuple[float, ...], ...]
    """Per stage."""
    known: KnownTerms
    """The calibrated terms and their covariance."""
    reference: bool
    """Whether a reference experiment fixed the torque gain (else gain 1, exact)."""
    inputs: dict[str, str] = field(default_factory=dict)
    """Input file -> sha256 of its bytes."""
    chi2_dof: float = math.nan
    """Residual chi^2 per degree of freedom of the calibration fit."""
    tests: list[ModelTest] = field(default_factory=list)
    """The calibration fit's model tests (rsp_inertia.estimation.gls)."""
    warnings: list[str] = field(default_factory=list)
    """What the calibration's own checks found."""
    stiffness: StiffnessCalibration | None = None
    """The pendulum's torsion stiffness, when both folders have pendulum runs at a node."""
    conventions: str = ""
    """One line on the rig's conventions: verified by the reference, or not and how to
    (rsp_inertia.estimation.conventions)."""
    certificate: Certificate | None = None
    """The reference body's certificate (reference.toml ``[certificate]``), for the records."""
    date: str | None = None
    """The day of the calibration, ``YYYY-MM-DD`` in UTC (set by the calibrate command;
    calibration.toml ``[calibration] date``)."""
    tempco: str = ""
    """One line on the torque constant's tempco when device.toml states one: measured by the
    runs, or device.toml's kept and why, with the calibration runs' magnet temperatures
    (rsp_inertia.estimation.reading.tempco_line; docs/method.md §3, "Temperature"); printed
    with the result, not a warning. '' without a tempco."""
    warming: tuple[float, float] | None = None
    """(c, std), 1/(N^2 m^2): the warming motor's coefficient the calibration runs gave, fitted
    with the gains where device.toml models the warming (``[motor] winding_time_constant``;
    rsp_inertia.estimation.columns.WARMING_UNKNOWN); None: not modelled. identify fits its own
    from the body's runs (the gains here are those of the motor at rest)."""
    tempco_fit: TempcoFit | None = None
    """What the fit found of the tempco alpha, when it took it as an unknown (a reference,
    device.toml's tempco with its std, logs with a temperature; rsp_inertia.estimation.tempco):
    calibration.toml carries it when the runs measured it (:attr:`TempcoFit.informed`)."""

    def to_file(self) -> CalibrationFile:
        """The calibration as calibration.toml holds it
        (rsp_inertia.estimation.calibration_file.calibration_file): what
        rsp_inertia.estimation.calibration_file.write_calibration_file writes, equal to what
        its reader gives back from the file."""
        return calibration_file(self)

    def to_toml(self) -> str:
        """The calibration.toml text (rsp_inertia.estimation.calibration_file): deterministic,
        the same calibration gives the same bytes, and checked to read back equal."""
        return calibration_text(self.to_file())

    def __str__(self) -> str:
        k = self.known
        std = k.std
        gains_std = std[k.gains_slice]
        out = []
        if self.reference:
            rt, rt_std = k.gains[0] / k.gains[1], k.round_trip_std()
            out.append(
                f"drive: gain driving h_d = {k.gains[0]:.6f} +- {gains_std[0]:.1e}, "
                f"back-driven h_b = {k.gains[1]:.6f} +- {gains_std[1]:.1e} (body torque / "
                "logged torque); "
                f"round-trip efficiency eta_d eta_b = h_d / h_b = {rt:.6f} +- {rt_std:.1e}"
            )
            out.append(
                "  with the logged torque's scale exact, eta_d = h_d and eta_b = 1 / h_b: "
                f"eta_d = {k.gains[0]:.5f} +- {gains_std[0]:.1e}, "
                f"eta_b = {1 / k.gains[1]:.5f} +- {gains_std[1] / k.gains[1] ** 2:.1e} "
                "(a work balance measures only h_d and h_b: "
                "the torque constant and the two efficiencies are not separable)"
            )
        else:
            out.append(
                "drive: gains 1 (no reference experiment: torque constant and transmission "
                "taken as exact)"
            )
        if k.orders:
            enc = k.encoder_slice
            amplitude = np.hypot(k.encoder[0::2], k.encoder[1::2])
            out.append(
                "encoder error: "
                + ", ".join(
                    f"order {n + 1}: {np.degrees(a) * 3600:.2f} arcsec "
                    f"(cos {c:+.2e} +- {sc:.0e}, sin {s_:+.2e} +- {ss:.0e} rad)"
                    for n, (a, c, s_, sc, ss) in enumerate(
                        zip(
                            amplitude, k.encoder[0::2], k.encoder[1::2],
                            std[enc][0::2], std[enc][1::2],
                        )
                    )
                )
            )
        for s in range(1, len(self.gear_ratios) + 1):
            M = k.inertia[s - 1]
            Ms = std[k.harmonics_slice(s)]
            out.append(
                f"stage {s}: empty M0 = {M[0]:.8f} +- {Ms[0]:.1e} kg m^2, harmonics "
                + ", ".join(
                    f"{name} {v:+.2e} +- {e:.0e}"
                    for name, v, e in zip(HARMONIC_NAMES[1:], M[1:], Ms[1:])
                )
            )
        g_std = std[k.gravity_slice]
        out.append(
            f"fixture gravity: m g x_c = {k.gravity[0]:+.3e} +- {g_std[0]:.0e} N m, "
            f"m g y_c = {k.gravity[1]:+.3e} +- {g_std[1]:.0e} N m"
        )
        if self.stiffness is not None:
            c = self.stiffness
            out.append(
                f"pendulum stiffness: {c.stiffness:.6f} +- {c.stiffness_std:.1e} N m/rad from "
                f"{len(c.per_node)} node(s) with an empty and a reference run"
                + ("" if math.isnan(c.chi2_dof) else f" (chi2/dof {c.chi2_dof:.2f})")
            )
        if self.conventions:
            out.append(self.conventions)
        if self.tempco:
            out.append(self.tempco)
        if self.warming is not None:
            out.append(
                f"warming motor: c = {self.warming[0]:.3e} +- {self.warming[1]:.1e} /(N^2 m^2) "
                "in the calibration runs, fitted with the gains (the gains of the motor at rest)"
            )
        # The warnings are not in the text: the command line prints them on stderr.
        return "\n".join(out)


def _blocks(
    device: Device,
    balances,
    role: str,
    reference: TrueBody | None,
    has_gain: bool,
    encoder_orders: int,
    orientation: bool = False,
    flip: np.ndarray | None = None,
    certificate: Reference | None = None,
    tempco_gains: tuple[float, float] | None = None,
    warming_gains: tuple[float, float] = (1.0, 1.0),
):
    """The calibration equations of one experiment's runs (module docstring).

    ``orientation``: the encoder's zero offset is an unknown (a reference that shows the
    rig's orientation is in the fit): its column is the angle slope of the known terms (the
    reference's and the spring's), the empty system's own terms being measured in the
    corrected angle (rsp_inertia.estimation.known_terms.KnownTerms). ``flip``: a mask over
    the reference's terms [M0, Mc2, Ms2, Ms1, Mc1, Gs, Gc] whose share gets a free factor,
    the unknown :data:`CONVENTION_FACTOR` (+1 where the rig keeps the stated conventions,
    -1 where a convention flips them, :data:`CONVENTIONS`). ``certificate``: the reference's
    certified values are known terms of the fit with their stated covariance (module
    docstring); each reference run's block carries their d rhs / d value. ``tempco_gains``:
    the tempco alpha is an unknown (rsp_inertia.estimation.tempco), its column the work parts'
    response times these gains (h_d, h_b). ``warming_gains``: the gains (h_d, h_b) the warming
    motor's column is linearised at (rsp_inertia.estimation.columns.WARMING_UNKNOWN, where
    device.toml models it; the runs' balances carry its StageBalance.warming_parts)."""
    # The unknowns are theta's, by theta's names (rsp_inertia.estimation.layout).
    theta = theta_layout(len(device.stages), encoder_orders)
    gains = theta.names("gains")
    both = both_directions(balances)
    blocks = []
    hottest = max((bal.heat_gap for bal in balances), default=0.0)
    for k, bal in enumerate(balances):
        s = bal.stage
        harmonics = theta.names("harmonics", s)
        basis = inertia_basis(bal.phi)
        half_s = 0.5 * bal.speed_sq
        cols = {name: half_s * basis[:, j] for j, name in enumerate(harmonics)}
        cols.update(zip(theta.names("gravity"), gravity_rows(bal.phi).T))
        cols.update(run_columns(bal, f"{role}{k}", s in both, group=f"{role} {s}"))
        if has_gain:
            cols.update(zip(gains, -bal.motor_work_parts.T))
            if tempco_gains is not None and bal.tempco_work_parts is not None:
                cols[TEMPCO_NAME] = -(bal.tempco_work_parts @ np.asarray(tempco_gains))
            rhs = -bal.spring
        else:
            rhs = bal.work.copy()
        if bal.warming_parts is not None:  # one motor: c shared by every run and experiment
            gain = warming_gains if has_gain else (1.0, 1.0)
            cols[WARMING_UNKNOWN] = -(bal.warming_parts @ np.asarray(gain))
        # The encoder's remaining error, per unit of M(phi) (the first pass gives M).
        scaled = encoder_unknowns(bal, encoder_orders) if encoder_orders else {}
        # Without a reference the drive and the encoder cannot be measured, but the model
        # tests can still say whether the runs call for them (the probes of identify); with
        # one, they are measured, and a motor warming between the passes is still a probe.
        probes, probes_per_inertia = cause_probes(bal, hottest)
        if has_gain:
            probes = {c: cols for c, cols in probes.items() if c == WARMING_PROBE}
            probes_per_inertia = {}
        known_M = np.zeros(len(bal.phi))
        slope = np.zeros(len(bal.phi)) if bal.spring_slope is None else -bal.spring_slope
        known_jacobian = terms_std = None
        if reference is not None and certificate is not None:
            D = certificate_jacobian(certificate, device.stages[s - 1].gear_ratio, device.gravity)
            known_jacobian = -np.column_stack(
                [_reference_balance(bal, column) for column in D.T]
            )
            terms_std = certified_terms_std(D, certificate.cov)
        if reference is not None:
            terms = reference_terms(reference, device.stages[s - 1].gear_ratio, device.gravity)
            known_M = basis @ terms[:5]
            # A convention's factor only on terms that can show it (an axisymmetric
            # reference's products are zero: no factor, the convention unverified).
            mask = np.zeros(len(terms), dtype=bool) if flip is None else flip
            mask = mask & significant_terms(reference, terms, terms_std)
            rhs = rhs - _reference_balance(bal, np.where(mask, 0.0, terms))
            if mask.any():
                cols[CONVENTION_FACTOR] = _reference_balance(bal, np.where(mask, terms, 0.0))
            slope = slope - _reference_balance(bal, terms, slope=True)
        if orientation and np.any(slope):
            cols[ZERO_NAME] = slope
        blocks.append(
            Block(
                balance=bal,
                label=f"{role} {run_label(bal)}",
                columns=cols,
                rhs=rhs,
                inertia_columns={name: basis[:, j] for j, name in enumerate(harmonics)},
                inertia_known=known_M,
                # The gains scale the logged work, a smooth function as the kinetic energy is:
                # alone in one run they would stand in for the noisy speeds
                # (rsp_inertia.estimation.gls); the encoder's orders 1 and 2 are known only from
                # the runs together (reference against empty).
                joint_only=frozenset(
                    name
                    for name in (*cols, *scaled)
                    if name.startswith("e")
                    or name in gains
                    or name in scaled
                    or name in (ZERO_NAME, CONVENTION_FACTOR, TEMPCO_NAME, WARMING_UNKNOWN)
                ),
                groups={name: f"{role} {run_label(bal)}" for name in harmonics},
                fixed_in_tests=frozenset((*gains, TEMPCO_NAME)),
                inertia_scaled_columns=scaled,
                probes=probes,
                probes_per_inertia=probes_per_inertia,
                probe_bounds={} if has_gain else probe_bounds((1.0, 1.0)),
                priors=run_priors(bal, cols, f"{role}{k}"),
                known_jacobian=known_jacobian,
            )
        )
    return blocks


TEMPCO_REJECTED = (
    "the calibration runs disagree with device.toml's torque_constant_tempco beyond its "
    "torque_constant_tempco_std (chi2 = {stat} for {dof}, p = {p}): the tempco is taken from "
    "the runs alone (a tempco stated for another magnet, or its std stated too small)"
)
"""The warning when the runs reject the stated tempco's prior (rsp_inertia.estimation.gls,
priors); the tempco is then the runs' alone."""


def _with_tempco_prior(blocks: list[Block], std: float) -> list[Block]:
    """``blocks`` with the tempco's prior N(0, std^2) on its change from the stated value,
    carried once, by the first block with its column (rsp_inertia.estimation.gls, priors)."""
    for k, block in enumerate(blocks):
        if TEMPCO_NAME in block.columns:
            prior = Prior(
                (TEMPCO_NAME,), np.zeros(1), np.array([[std**2]]), rejection=TEMPCO_REJECTED
            )
            blocks[k] = dataclasses.replace(block, priors=(*block.priors, prior))
            break
    return blocks


def _tempco_unknown(
    motor, balances: list, known: KnownTerms
) -> tuple[float, tuple[float, float]] | None:
    """``(std, gains)`` of :func:`fit_calibration`'s ``tempco`` when the runs can take alpha as
    an unknown: a reference's ``balances``, device.toml's tempco with a std > 0, logs
    compensated with it; None otherwise (alpha exact, as today)."""
    std = motor.torque_constant_tempco_std
    if motor.torque_constant_tempco is None or not std:
        return None
    if all(bal.tempco_work_parts is None for bal in balances):
        return None
    return std, (float(known.gains[0]), float(known.gains[1]))


def _tempco_fit(motor, fit: BalanceFit, known: KnownTerms) -> TempcoFit:
    """alpha as the fit found it: the stated value plus the fitted change, its std and its
    covariance with theta's terms (rsp_inertia.estimation.tempco.TempcoFit)."""
    j = fit.index(TEMPCO_NAME)
    covariance = tuple(
        float(fit.cov[j, fit.index(name)]) if name in fit.names else 0.0
        for name in known.names()
    )
    rejected = any(line.startswith(TEMPCO_REJECTED[:40]) for line in fit.prior_warnings)
    return TempcoFit(
        stated=float(motor.torque_constant_tempco),
        stated_std=float(motor.torque_constant_tempco_std),
        estimate=float(motor.torque_constant_tempco + fit.x[j]),
        std=float(math.sqrt(fit.cov[j, j])),
        covariance=covariance,
        reference_temperature=float(motor.reference_temperature),
        prior_rejected=rejected,
    )


def _certificate_scale(certificate: Reference, device: Device) -> np.ndarray:
    """(10,) the change of the certificate's values along which every reference term of
    every stage scales as a whole, the most probable one under the certificate's covariance
    C: dv = C D^T (D C D^T)^+ t, D the terms' d / d value (rsp_inertia.estimation.conventions.certificate_jacobian) and
    t the terms, stacked over the stages. The terms are homogeneous of degree one in the
    mass and the tensor (the centre of mass fixed), so D v_(m, J) = t and the scale is
    reachable wherever C lets the mass or the tensor move. It is the logged torque's common
    scale, which the runs cannot measure (module docstring): their information on what is
    orthogonal to it in C's metric is then no scale's."""
    D = np.vstack(
        [certificate_jacobian(certificate, st.gear_ratio, device.gravity) for st in device.stages]
    )
    t = np.concatenate(
        [reference_terms(certificate.placed, st.gear_ratio, device.gravity) for st in device.stages]
    )
    C = certificate.cov
    return C @ D.T @ np.linalg.pinv(D @ C @ D.T, rcond=1e-12, hermitian=True) @ t


def _reference_balance(bal, terms: np.ndarray, slope: bool = False) -> np.ndarray:
    """The share in one run's balance of reference terms ``terms`` ([M0 .. Mc1, Gs, Gc]):
    1/2 S M(phi) + 2 Pi(phi), or its slope d/dphi with ``slope``."""
    if slope:
        return 0.5 * bal.speed_sq * (inertia_basis_slope(bal.phi) @ terms[:5]) + (
            gravity_row_slopes(bal.phi) @ terms[5:]
        )
    return 0.5 * bal.speed_sq * (inertia_basis(bal.phi) @ terms[:5]) + (
        gravity_rows(bal.phi) @ terms[5:]
    )


def fit_calibration(
    device: Device,
    empty: list,
    reference: list | None = None,
    reference_body: TrueBody | None = None,
    encoder: np.ndarray | None = None,
    scales: list[float] | None = None,
    tests: bool = True,
    zero: float | None = None,
    flip: np.ndarray | None = None,
    certificate: Reference | None = None,
    tempco: tuple[float, tuple[float, float]] | None = None,
    warming_gains: tuple[float, float] = (1.0, 1.0),
) -> tuple[KnownTerms, BalanceFit]:
    """The calibrated terms from the empty runs' and the reference runs' balances.

    Parameters
    ----------
    device : Device
        The loaded experiment's device (its stages and gravity, the encoder error it states).
    empty, reference : list of StageBalance
        The runs of the empty experiment and of the reference experiment (optional).
    reference_body : TrueBody
        The reference body (with ``reference``).
    encoder : array, optional
        With a reference: the encoder's error coefficients (ENCODER_ORDERS orders) already
        taken off the logs of the balances; the fit measures what is left and adds it.
        Without a reference the encoder is device.toml's (:func:`device_known_terms`).
    scales : list of float, optional
        The runs' speed-noise scales when an earlier fit found them (else
        rsp_inertia.estimation.gls.speed_noise_scales finds them).
    tests : bool
        Whether to make the model tests (rsp_inertia.estimation.gls.block_model_tests).
    zero : float, optional
        With a reference that shows the rig's orientation: the encoder's zero offset (rad)
        already taken off the logs; the fit measures what is left and adds it. None: the
        zero is not measured (0, exact).
    flip : array of bool, optional
        A convention's mask over the reference's terms (:data:`CONVENTIONS`): their share
        gets the free factor :data:`CONVENTION_FACTOR` (the convention check).
    certificate : Reference, optional
        With a reference: its certificate, whose stated covariance the fit carries (module
        docstring); None, or one without stds: the reference's values exact.
    tempco : (float, (float, float)), optional
        With a reference: the tempco alpha is an unknown, its change from the value that
        compensated the logs with the prior N(0, std^2), ``(std, (h_d, h_b))`` the stated std
        (1/K) and the gains its column is linearised at (rsp_inertia.estimation.tempco).
        None: alpha exact, as the logs were compensated.
    warming_gains : (float, float), optional
        With a reference and a warming device.toml models: the gains (h_d, h_b) the warming's
        column is linearised at (the previous fit's; 1 at first).

    Returns
    -------
    (KnownTerms, BalanceFit)
        The calibration and the fit it comes from.
    """
    has_gain = reference is not None
    orders = ENCODER_ORDERS if has_gain else 0
    orientation = has_gain and zero is not None
    certificate = certificate if has_gain and certificate is not None and certificate.stated else None
    gains = None if tempco is None or not has_gain else tempco[1]
    blocks = _blocks(
        device, empty, "empty", None, has_gain, orders, orientation, tempco_gains=gains,
        warming_gains=warming_gains,
    )
    if has_gain:
        blocks += _blocks(
            device, reference, "reference", reference_body, has_gain, orders, orientation, flip,
            certificate, gains, warming_gains,
        )
    if gains is not None:
        blocks = _with_tempco_prior(blocks, tempco[0])
    if certificate is None:
        equations = assemble_blocks(blocks)
    else:
        equations = assemble_blocks(
            blocks,
            certificate.cov,
            {CERTIFICATE_SOURCE: list(range(len(REFERENCE_PARAMETERS)))},
            consider=_certificate_scale(certificate, device),
        )
    fit = solve_blocks(equations, speed_noise_scales(equations) if scales is None else scales)
    if tests:
        fit = dataclasses.replace(fit, tests=block_model_tests(equations, fit))
    # What the fit does not measure stays as it was: without a reference, gains 1 and the
    # encoder error device.toml states (with its std); with one, the encoder error already
    # taken off the logs, to which the fit adds what it finds left.
    if has_gain:
        applied = np.zeros(2 * orders) if encoder is None else np.asarray(encoder, dtype=float)
        start = dataclasses.replace(
            KnownTerms.exact(len(device.stages), applied), zero=zero or 0.0
        )
        measured = [n for n in start.names() if orientation or n != ZERO_NAME]
    else:
        stated, _ = device_known_terms(device)
        start = KnownTerms.exact(len(device.stages), stated.encoder)
        cov = start.cov.copy()
        cov[start.encoder_slice, start.encoder_slice] = stated.cov[
            stated.encoder_slice, stated.encoder_slice
        ]
        start = start.with_theta(start.theta, cov)
        measured = start.layout.names("harmonics") + start.layout.names("gravity")
    missing = [n for n in measured if n not in fit.names]
    if missing:
        raise InputError(f"the calibration runs leave {', '.join(missing)} undetermined")
    names = start.names()
    theta, cov = start.theta, start.cov.copy()
    which = [names.index(n) for n in measured]
    where = [fit.index(n) for n in measured]
    # The encoder's error and zero: what is left, added to what the logs had taken off.
    added = {*start.layout.names("encoder"), ZERO_NAME}
    for i, j, name in zip(which, where, measured):
        theta[i] = theta[i] + fit.x[j] if name in added else fit.x[j]
    cov[np.ix_(which, which)] = fit.cov[np.ix_(where, where)]
    certificate_cov = None
    if CERTIFICATE_SOURCE in fit.cov_parts:
        certificate_cov = np.zeros_like(cov)
        certificate_cov[np.ix_(which, which)] = fit.cov_parts[CERTIFICATE_SOURCE][
            np.ix_(where, where)
        ]
    return start.with_theta(theta, cov, certificate_cov=certificate_cov), fit


def calibrate_logs(
    device: Device,
    empty: ExperimentLogs,
    reference: ExperimentLogs | None = None,
    certificate: Reference | None = None,
) -> Calibration:
    """Calibrate the rig of ``device`` from the empty-fixture and reference experiments' logs.

    With a reference the fit repeats on the logs corrected with the encoder's error found so
    far (module docstring). The torsion stiffness comes from the nodes with a pendulum log in
    both. Its lines (rsp_inertia.infra.progress.say): each run balanced, in the first fit
    only, and each repetition of the fit.

    Parameters
    ----------
    device : Device
        The calibrated experiment's device.
    empty : ExperimentLogs
        The empty-fixture experiment's logs.
    reference : ExperimentLogs, optional
        The reference experiment's logs.
    certificate : Reference, optional
        The reference body's certificate (reference.toml, placed by the reference folder's
        ``[mounting]``), with ``reference``.

    Returns
    -------
    Calibration
        What calibrate found; ``inputs`` is left empty: the reader of the files records them.

    Raises
    ------
    InputError
        Bad logs; a pendulum run the best-practice fit cannot take.
    """
    encoder = np.zeros(2 * ENCODER_ORDERS) if reference is not None else None
    reference_body = None if certificate is None else certificate.placed
    # The encoder's zero is measured when the reference shows the rig's orientation.
    zero = (
        0.0 if reference is not None and shows_orientation(reference_body, device, certificate)
        else None
    )
    scales = None
    conventions = None
    warming_gains = (1.0, 1.0)  # the warming's column linearised at the last fit's gains
    for iteration in range(ENCODER_ITERATIONS if reference is not None else 1):
        warnings: list[str] = []
        # What the logs are corrected with: the encoder's error and zero found so far.
        applied, zero_applied = (() if encoder is None else encoder), zero
        # The runs' lines from the first balancing only: the repetitions would repeat them.
        with lines_to(None if iteration == 0 else drop):
            empty_bal, _ = balance_runs(empty, warnings, applied, zero=zero or 0.0)
            ref_bal = None
            if reference is not None:
                ref_bal, _ = balance_runs(reference, warnings, applied, zero=zero or 0.0)
        # The runs' speed-noise scales come from the first fit (taken with the encoder's
        # terms off each run's own fit); the model tests from the fit that is kept.
        known, fit = fit_calibration(
            device, empty_bal, ref_bal, reference_body, encoder, scales, tests=False, zero=zero,
            certificate=certificate, warming_gains=warming_gains,
        )
        scales = fit.scales
        if encoder is None:
            break
        if iteration == 0:
            # The rig's conventions first, before anything is taken for a drive loss or an
            # encoder's error (rsp_inertia.estimation.conventions): a flip is refused here.
            fitter = functools.partial(
                fit_calibration, device, empty_bal, ref_bal, reference_body, encoder, scales,
                tests=False, zero=zero, certificate=certificate, warming_gains=warming_gains,
            )
            conventions = check_conventions(fitter, known, reference.sources.experiment)
            if not conventions.zero_measured:
                zero = zero_applied = None
                known, fit = fit_calibration(
                    device, empty_bal, ref_bal, reference_body, encoder, scales, tests=False,
                    certificate=certificate, warming_gains=warming_gains,
                )
        warming_gains = known.gains
        step = np.append(known.encoder - encoder, known.zero - (zero or 0.0))
        step_std = np.append(known.std[known.encoder_slice], known.std[known.zero_slice])
        encoder = known.encoder
        zero = None if zero is None else known.zero
        if np.all(np.abs(step) <= ENCODER_TOLERANCE * step_std):
            break
        largest = float(np.max(np.abs(step) / np.where(step_std > 0, step_std, 1.0)))
        say(
            f"encoder error and zero: correction moved by up to {largest:.2g} std; the logs "
            f"corrected with it are balanced again (fit {iteration + 2})"
        )
    final = functools.partial(
        fit_calibration, device, empty_bal, ref_bal, reference_body,
        applied if len(applied) else None, scales, zero=zero_applied, certificate=certificate,
        warming_gains=warming_gains,
    )
    # The tempco as an unknown when the runs can take it; kept only where they measure it
    # (rsp_inertia.estimation.tempco: otherwise the fit without it, alpha device.toml's).
    motor = empty.device.motor
    tempco = None
    if reference is not None:
        tempco = _tempco_unknown(motor, empty_bal + ref_bal, known)
    known, fit = final(tempco=tempco)
    tempco_fit = None if tempco is None else _tempco_fit(motor, fit, known)
    if tempco_fit is not None and not tempco_fit.informed:
        known, fit = final()
    if conventions is None:
        conventions = unverified_conventions()
    else:
        conventions = conventions.with_zero(known)
    one_direction = any(
        len(both_directions(runs)) < len({bal.stage for bal in runs})
        for runs in (empty_bal, ref_bal or [])
        if runs
    )
    compensated = any(bal.compensated for runs in (empty_bal, ref_bal or []) for bal in runs)
    tests = described(fit.tests, known, one_direction, compensated)
    warnings += model_warnings(tests, fit.scales, fit.labels)
    warnings += fit.prior_warnings
    if certificate is not None:
        warnings += _certificate_warnings(certificate, fit)
    stiffness = None
    if reference is not None:
        stiffness = calibrate_stiffness(
            _corrected_pendulum(empty, known.encoder, known.zero, warnings),
            _corrected_pendulum(reference, known.encoder, known.zero, warnings),
            reference_body,
            known.gravity,
            known.cov[known.gravity_slice, known.gravity_slice],
            known.inertia,
        )
        if stiffness is not None and stiffness.chi2_dof > STIFFNESS_CHI2_WARN:
            warnings.append(
                f"pendulum stiffness: the nodes' values disagree beyond their stds (chi2/dof "
                f"{stiffness.chi2_dof:.1f}); its std is scaled up to their scatter"
            )
    return Calibration(
        device_name=device.name,
        counts_per_rev=device.encoder.counts_per_rev,
        gear_ratios=tuple(st.gear_ratio for st in device.stages),
        nodes_deg=tuple(tuple(st.nodes_deg) for st in device.stages),
        known=known,
        reference=reference is not None,
        chi2_dof=fit.chi2_dof,
        tests=tests,
        warnings=warnings,
        stiffness=stiffness,
        conventions=conventions.statement,
        certificate=None if certificate is None else certificate.certificate,
        tempco_fit=tempco_fit,
        warming=fit.value(WARMING_UNKNOWN) if WARMING_UNKNOWN in fit.names else None,
    )


CERTIFICATE_ALPHA = 1e-3
"""The runs disagree with the reference's certificate when the chi^2 of how far they move
its values, in the certificate's stds, has a p-value below this (:func:`calibrate_logs`)."""


CERTIFICATE_INFORMED = 0.01
"""The certificate test (:data:`CERTIFICATE_ALPHA`) takes the directions of its values on
which the runs carry at least this fraction of the information its stds give."""


def _certificate_warnings(certificate: Reference, fit: BalanceFit) -> list[str]:
    """What the certificate calls for: a warning when it states no stds (its uncertainty
    is then left out of every std), and one when the runs move its values further than its
    stds allow (the fit's standardised shift z of the certificate's prior: chi^2 = z^T
    (I - cov z)^-1 z on as many degrees of freedom as it has stds; gls, priors)."""
    if not certificate.stated:
        return [
            (
                "reference.toml states no uncertainty for the reference body's values: they "
                "are taken as exact, and the certificate's uncertainty is left out of every "
                "std (state body.mass_std, body.inertia_std or body.inertia_cov and "
                "body.com_std from its certificate)"
            )
        ]
    z = fit.z
    if z.size == 0:
        return []
    # The pseudo-equations' residuals -z have covariance I - cov z (gls, priors); the
    # directions the runs carry no information on (the common scale) or next to none (less
    # than CERTIFICATE_INFORMED of the certificate's) drop out.
    values, vectors = np.linalg.eigh(np.eye(z.size) - fit.z_cov)
    informed = values > CERTIFICATE_INFORMED
    if not informed.any():
        return []
    projected = vectors[:, informed].T @ z
    stat = float(np.sum(projected**2 / values[informed]))
    dof = int(informed.sum())
    p_value = float(chi2_distribution.sf(stat, dof))
    if p_value >= CERTIFICATE_ALPHA:
        return []
    std = np.sqrt(np.diag(certificate.cov))
    shift = fit.known_shift
    stated = std > 0
    worst = int(np.argmax(np.where(stated, np.abs(shift) / np.where(stated, std, 1.0), 0.0)))
    return [
        (
            "the reference runs disagree with the reference body's certificate beyond its "
            f"stds (chi2 = {stat:.3g} for {dof}, p = {p_value:.2g}; the largest move, "
            f"{REFERENCE_PARAMETERS[worst]} by {shift[worst] / std[worst]:+.2g} std): a "
            "certificate of another body, a reference mounted otherwise than its device.toml "
            "[mounting] states, or stds stated too small"
        )
    ]


def _corrected_pendulum(
    logs: ExperimentLogs, encoder: np.ndarray, zero: float, warnings: list[str]
) -> ExperimentLogs:
    """``logs`` with its pendulum logs' readings taken back to the true angle: the pendulum
    reads the same encoder (rsp_inertia.estimation.runs.corrected_log); the glitches their
    reader left out (rsp_inertia.plant.logs.Log.warnings) go to ``warnings``."""
    pendulum = {}
    for key in logs.pendulum:
        log = logs.pendulum[key]  # read from its file at every lookup: once here
        warnings.extend(log.warnings)
        pendulum[key] = corrected_log(log, encoder, zero)
    return dataclasses.replace(logs, pendulum=pendulum)


def calibrated_known_terms(
    calibration: CalibrationFile, device: Device, source: str
) -> tuple[KnownTerms, list[str]]:
    """A calibration.toml's terms, checked to be made for ``device``.

    Parameters
    ----------
    calibration : CalibrationFile
        The file as its reader gives it
        (rsp_inertia.estimation.calibration_file.read_calibration_file).
    device : Device
        The experiment's device: its name, encoder and stages must be the calibration's.
    source : str
        The file's name in messages.

    Returns
    -------
    (KnownTerms, list of str)
        The calibrated terms (:meth:`CalibrationFile.known_terms`) and the warnings they
        give: a file of an older rsp-inertia, without the drive's gains and the encoder's
        error, is applied with a lossless drive and an exact encoder (its torque_gain as
        both gains), and says so.

    Raises
    ------
    InputError
        A calibration made for another device (name, encoder or stages differ).
    """
    path = source
    head = calibration.calibration
    if head.device != device.name:
        raise InputError(
            f"{path}: made for device {head.device!r}, not {device.name!r} "
            "(run rsp-inertia calibrate for this device)"
        )
    if head.counts_per_rev != device.encoder.counts_per_rev:
        raise InputError(f"{path}: made for another device (encoder counts_per_rev differ)")
    stages = calibration.stages
    if len(stages) != len(device.stages):
        raise InputError(
            f"{path}: made for another device: {len(stages)} stage(s), device.toml has "
            f"{len(device.stages)}"
        )
    for k, (entry, st) in enumerate(zip(stages, device.stages), 1):
        if not math.isclose(entry.gear_ratio, st.gear_ratio, rel_tol=1e-9) or (
            entry.nodes_deg != tuple(st.nodes_deg)
        ):
            raise InputError(
                f"{path}: stage[{k}]: made for another device (gear ratio or nodes differ "
                "from device.toml's)"
            )
    warnings = []
    if calibration.legacy:
        warnings.append(
            f"{path}: written by an older rsp-inertia, without the drive's gains by direction "
            "of power flow and the encoder's error: the drive is taken as lossless (its "
            "torque_gain for both) and the encoder as exact, and their errors are not in the "
            "stds (calibrate again)"
        )
    return calibration.known_terms(), warnings


def device_known_terms(
    device: Device, calibration_source: str = CALIBRATION_FILE
) -> tuple[KnownTerms, list[str]]:
    """The rig's known terms without a calibration: device.toml's tares, a torque gain of 1, a
    lossless drive and the encoder's error as device.toml states it (none: exact).

    The tares and the torque gain are taken as exact unless device.toml states their
    uncertainty (``tare_inertia_std`` of every stage and ``torque_gain_std``, or for logs of
    the motor current ``torque_constant_std``: rsp_inertia.plant.config.Motor.torque_scale_std);
    the warning,
    naming the missing calibration ``calibration_source``, says when it does not. The
    encoder's stated error carries ``[encoder] error_std`` (exact without it, and a warning).
    """
    known = KnownTerms.from_tares([st.tare_inertia for st in device.stages])
    encoder = device.encoder.error
    size = theta_layout(len(device.stages), encoder.size // 2).size
    cov = np.zeros((size, size))
    known = KnownTerms(known.gains, known.inertia, known.gravity, cov, encoder=encoder)
    warnings = []
    stated = False
    if encoder.size:
        if device.encoder.error_std is None:
            warnings.append(
                f"{calibration_source}: not found, and device.toml states the encoder's error "
                "without error_std: it is taken as exact, and its error is not in the stds"
            )
        else:
            std = np.repeat(np.asarray(device.encoder.error_std, dtype=float), 2)
            cov[known.encoder_slice, known.encoder_slice] = np.diag(std**2)
            stated = bool(np.any(std > 0))
    tare_std = [st.tare_inertia_std for st in device.stages]
    gain_std = device.motor.torque_scale_std()
    if all(v is not None for v in tare_std) and gain_std is not None:
        # h_d = h_b = 1/gain ~ 1 - (gain - 1): the same std to first order, for both gains.
        gains = known.gains_slice
        cov[gains, gains] = gain_std**2
        for s, v in enumerate(tare_std, 1):
            i = known.harmonics_slice(s).start
            cov[i, i] = v**2
        stated = stated or any(v > 0 for v in tare_std) or gain_std > 0
    else:
        warnings.append(
            f"{calibration_source}: not found, and device.toml states no tare_inertia_std "
            "and torque_gain_std: the tares of device.toml, a torque gain of 1 and a lossless "
            "drive are taken as exact, and their errors are not in the stds (calibrate with "
            "rsp-inertia calibrate)"
        )
    return dataclasses.replace(known, cov=cov, calibrated=stated), warnings
