"""Calibration of the rig: the empty fixture (tare) and a reference body (torque gain).

Like every mass-properties instrument, the gimbal is calibrated with runs of its own:

- an **empty** experiment, the fixture without a body: its balances give, per stage, the
  empty system's reduced inertia M_empty(phi) in harmonic form (docs/method.md §2: the tare
  M_tare(lambda) and an unbalanced mounting plate's own harmonics, five coefficients), and
  the fixture's gravity terms Gs_f = m_f g x_f, Gc_f = m_f g y_f (docs/method.md §3);
- a **reference** experiment, the fixture with a body whose tensor, mass and centre of mass
  are known (``reference.toml``): the same balances with the known body's M_ref(phi) and
  gravity added fix the scale of the logged torque, h = 1 / torque gain (logged torque =
  gain x applied: every inertia and gravity term from the logged work scales with it).

One generalised least squares over every run of both experiments (rsp_inertia.estimation.gls), per
balance angle of a run of stage s:

    1/2 S M_s(phi) . [basis] + 2 Pi_f(phi) - h W(phi) - C_run - (slopes, asymmetry)
        = - 2 Pi_spring(phi) - [reference runs: 1/2 S M_ref(phi) + 2 Pi_ref(phi)]

with the harmonics of M_empty of stage s, the fixture's gravity and h as unknowns (h = 1,
exact, without a reference). The estimates and their covariance are the calibration
(:class:`KnownTerms`), written to ``EXP/calibration.toml`` and applied by identify: there
the loaded run's right-hand side is h W - 2 Pi_spring - 1/2 S M_empty - 2 Pi_f, and the
calibration's covariance reaches the tensor as its own budget line.

The reference body's data are taken as exact (a reference mass is certified far beyond the
method's noise); friction may differ between the calibration runs and the loaded ones (it
cancels within each run).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from rsp_inertia.estimation.gls import BalanceFit, Block, solve_blocks
from rsp_inertia.estimation.model_tests import ModelTest, model_warnings
from rsp_inertia.estimation.runs import ExperimentLogs, balance_runs
from rsp_inertia.estimation.stiffness import StiffnessCalibration, calibrate_stiffness
from rsp_inertia.estimation.tensor import (
    KnownTerms,
    both_directions,
    gravity_rows,
    run_columns,
    run_label,
)
from rsp_inertia.plant.config import Device, TrueBody
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.model import inertia_basis, inertia_harmonics

__all__ = [
    "Calibration",
    "calibrate_logs",
    "device_known_terms",
    "fit_calibration",
    "known_terms_from_toml",
    "stiffness_from_toml",
]

STIFFNESS_CHI2_WARN = 4.0
"""chi^2/dof of the nodes' pendulum stiffnesses above which calibrate warns."""

HARMONIC_NAMES = ("M0", "Mc2", "Ms2", "Ms1", "Mc1")


def _param_names(n_stages: int) -> list[str]:
    """Names of theta = [h, harmonics of stage 1..n, Gs_f, Gc_f] (KnownTerms)."""
    names = ["h"]
    for s in range(1, n_stages + 1):
        names += [f"{h}[{s}]" for h in HARMONIC_NAMES]
    return names + ["Gs", "Gc"]


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

    def to_toml(self) -> str:
        """The calibration.toml text (deterministic: the same inputs give the same bytes)."""
        k = self.known
        std = np.sqrt(np.diag(k.cov))
        gain = 1.0 / k.work_scale
        lines = [
            "# Rig calibration written by rsp-inertia calibrate; identify applies it.",
            "# theta = [h = 1/torque_gain, empty-system harmonics per stage, fixture gravity].",
            "",
            "[calibration]",
            f"device = {_toml_str(self.device_name)}",
            f"counts_per_rev = {self.counts_per_rev}",
            f"reference = {'true' if self.reference else 'false'}",
            f"torque_gain = {gain!r}                # logged torque / applied torque",
            f"torque_gain_std = {float(std[0] * gain * gain)!r}",
            f"chi2_dof = {self.chi2_dof!r}",
            "",
            "[fixture]",
            f"gravity = {_toml_list(k.gravity)}     # [m g x_c, m g y_c] of the fixture, N m",
            f"gravity_std = {_toml_list(std[-2:])}",
        ]
        for s, (lam, nodes) in enumerate(zip(self.gear_ratios, self.nodes_deg)):
            lines += [
                "",
                "[[stage]]",
                f"gear_ratio = {lam!r}",
                f"nodes_deg = {_toml_list(nodes)}",
                f"empty_inertia = {_toml_list(k.inertia[s])}   # [M0, Mc2, Ms2, Ms1, Mc1], kg m^2",
                f"empty_inertia_std = {_toml_list(std[1 + 5 * s : 6 + 5 * s])}",
            ]
        names = _param_names(len(self.gear_ratios))
        if self.stiffness is not None:
            c = self.stiffness
            lines += [
                "",
                "[pendulum]                   # the torsion element, from the pendulum runs",
                f"stiffness = {c.stiffness!r}      # N m/rad",
                f"stiffness_std = {c.stiffness_std!r}",
                f"nodes = {len(c.per_node)}",
            ]
        lines += ["", "[covariance]", f"parameters = [{', '.join(map(_toml_str, names))}]"]
        lines.append("matrix = [")
        lines += [f"  {_toml_list(row)}," for row in k.cov]
        lines += ["]", "", "[inputs]                     # sha256 of every file used"]
        lines += [f"{_toml_str(path)} = {_toml_str(digest)}" for path, digest in self.inputs.items()]
        return "\n".join(lines) + "\n"

    def __str__(self) -> str:
        k = self.known
        std = np.sqrt(np.diag(k.cov))
        gain = 1.0 / k.work_scale
        out = []
        if self.reference:
            out.append(f"torque gain {gain:.6f} +- {std[0] * gain * gain:.1e} (logged / applied)")
        else:
            out.append("torque gain 1 (no reference experiment: taken as exact)")
        for s in range(len(self.gear_ratios)):
            M = k.inertia[s]
            Ms = std[1 + 5 * s : 6 + 5 * s]
            out.append(
                f"stage {s + 1}: empty M0 = {M[0]:.8f} +- {Ms[0]:.1e} kg m^2, harmonics "
                + ", ".join(
                    f"{name} {v:+.2e} +- {e:.0e}"
                    for name, v, e in zip(HARMONIC_NAMES[1:], M[1:], Ms[1:])
                )
            )
        out.append(
            f"fixture gravity: m g x_c = {k.gravity[0]:+.3e} +- {std[-2]:.0e} N m, "
            f"m g y_c = {k.gravity[1]:+.3e} +- {std[-1]:.0e} N m"
        )
        if self.stiffness is not None:
            c = self.stiffness
            out.append(
                f"pendulum stiffness: {c.stiffness:.6f} +- {c.stiffness_std:.1e} N m/rad from "
                f"{len(c.per_node)} node(s) with an empty and a reference run"
                + ("" if math.isnan(c.chi2_dof) else f" (chi2/dof {c.chi2_dof:.2f})")
            )
        out += [f"warning: {w}" for w in self.warnings]
        return "\n".join(out)


def _toml_str(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _toml_list(values) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def _blocks(device: Device, balances, role: str, reference: TrueBody | None, has_gain: bool):
    """The calibration equations of one experiment's runs (module docstring)."""
    both = both_directions(balances)
    blocks = []
    for k, bal in enumerate(balances):
        s = bal.stage
        basis = inertia_basis(bal.phi)
        half_s = 0.5 * bal.speed_sq
        cols = {f"{h}[{s}]": half_s * basis[:, j] for j, h in enumerate(HARMONIC_NAMES)}
        cols["Gs"], cols["Gc"] = gravity_rows(bal.phi).T
        cols.update(run_columns(bal, f"{role}{k}", s in both, group=f"{role} {s}"))
        if has_gain:
            cols["h"] = -bal.motor_work
            rhs = -bal.spring
        else:
            rhs = bal.work.copy()
        known_M = np.zeros(len(bal.phi))
        if reference is not None:
            st = device.stages[s - 1]
            known_M = basis @ inertia_harmonics(reference.inertia, st.gear_ratio, 0.0)
            weight = reference.mass * device.gravity
            rhs = rhs - half_s * known_M - gravity_rows(bal.phi) @ (weight * reference.com[:2])
        blocks.append(
            Block(
                balance=bal,
                label=f"{role} {run_label(bal)}",
                columns=cols,
                rhs=rhs,
                inertia_columns={f"{h}[{s}]": basis[:, j] for j, h in enumerate(HARMONIC_NAMES)},
                inertia_known=known_M,
                # h scales the logged work, a smooth function as the kinetic energy is: alone
                # in one run it would stand in for the noisy speeds (rsp_inertia.estimation.gls).
                joint_only=frozenset(name for name in cols if name.startswith("e") or name == "h"),
                groups={f"{h}[{s}]": f"{role} {run_label(bal)}" for h in HARMONIC_NAMES},
                fixed_in_tests=frozenset({"h"}),
            )
        )
    return blocks


def fit_calibration(
    device: Device,
    empty: list,
    reference: list | None = None,
    reference_body: TrueBody | None = None,
) -> tuple[KnownTerms, BalanceFit]:
    """The calibrated terms from the empty runs' and the reference runs' balances.

    Parameters
    ----------
    device : Device
        The loaded experiment's device (its stages and gravity).
    empty, reference : list of StageBalance
        The runs of the empty experiment and of the reference experiment (optional).
    reference_body : TrueBody
        The reference body (with ``reference``).
    """
    has_gain = reference is not None
    blocks = _blocks(device, empty, "empty", None, has_gain)
    if has_gain:
        blocks += _blocks(device, reference, "reference", reference_body, has_gain)
    fit = solve_blocks(blocks)
    n_stages = len(device.stages)
    names = _param_names(n_stages)
    missing = [n for n in names[1:] if n not in fit.names]
    if missing:
        raise InputError(f"the calibration runs leave {', '.join(missing)} undetermined")
    index = [fit.index(n) if n in fit.names else None for n in names]
    theta = np.array([1.0 if i is None else fit.x[i] for i in index])
    cov = np.zeros((len(names), len(names)))
    live = [j for j, i in enumerate(index) if i is not None]
    cov[np.ix_(live, live)] = fit.cov[np.ix_([index[j] for j in live], [index[j] for j in live])]
    known = KnownTerms(
        work_scale=float(theta[0]),
        inertia=theta[1:-2].reshape(n_stages, 5),
        gravity=theta[-2:],
        cov=cov,
        calibrated=True,
    )
    return known, fit


def calibrate_logs(
    device: Device,
    empty: ExperimentLogs,
    reference: ExperimentLogs | None = None,
    reference_body: TrueBody | None = None,
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """Calibrate the rig of ``device`` from the empty-fixture and reference experiments' logs.

    ``reference_body``: the reference experiment's known body (reference.toml), with
    ``reference``. The torsion stiffness comes from the nodes with a pendulum log in both.
    ``inputs`` is left empty: the reader of the files records them.

    Raises
    ------
    InputError
        Bad logs; a pendulum run the best-practice fit cannot take.
    """
    warnings: list[str] = []
    empty_bal, _ = balance_runs(empty, warnings, progress)
    ref_bal = None
    if reference is not None:
        ref_bal, _ = balance_runs(reference, warnings, progress)
    known, fit = fit_calibration(device, empty_bal, ref_bal, reference_body)
    warnings += model_warnings(fit.tests, fit.scales, fit.labels)
    stiffness = None
    if reference is not None:
        stiffness = calibrate_stiffness(
            empty, reference, reference_body, known.gravity, known.cov[-2:, -2:], known.inertia
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
        tests=fit.tests,
        warnings=warnings,
        stiffness=stiffness,
    )


def known_terms_from_toml(doc: dict, device: Device, source: str) -> KnownTerms:
    """A calibration.toml document (parsed TOML) as KnownTerms, checked to be made for
    ``device``; ``source`` names the file in messages.

    Raises
    ------
    InputError
        A malformed document, or one made for another device (name, encoder or stages differ).
    """
    path = source
    try:
        head = doc["calibration"]
        stages = doc["stage"]
        gain = float(head["torque_gain"])
        if head["device"] != device.name:
            raise InputError(
                f"{path}: made for device {head['device']!r}, not {device.name!r} "
                "(run rsp-inertia calibrate for this device)"
            )
        if int(head["counts_per_rev"]) != device.encoder.counts_per_rev:
            raise InputError(f"{path}: made for another device (encoder counts_per_rev differ)")
        if len(stages) != len(device.stages):
            raise InputError(
                f"{path}: made for another device: {len(stages)} stage(s), device.toml has "
                f"{len(device.stages)}"
            )
        for k, (entry, st) in enumerate(zip(stages, device.stages), 1):
            if not math.isclose(float(entry["gear_ratio"]), st.gear_ratio, rel_tol=1e-9) or (
                tuple(float(v) for v in entry["nodes_deg"]) != tuple(st.nodes_deg)
            ):
                raise InputError(
                    f"{path}: stage[{k}]: made for another device (gear ratio or nodes differ "
                    "from device.toml's)"
                )
        inertia = np.array([[float(v) for v in entry["empty_inertia"]] for entry in stages])
        gravity = np.array([float(v) for v in doc["fixture"]["gravity"]])
        cov = np.array(doc["covariance"]["matrix"], dtype=float)
    except InputError:
        raise
    except (KeyError, TypeError, ValueError) as error:
        raise InputError(f"{path}: malformed calibration file ({error!r})") from None
    size = 1 + inertia.size + 2
    if inertia.shape != (len(device.stages), 5) or gravity.shape != (2,) or cov.shape != (
        size,
        size,
    ):
        raise InputError(f"{path}: malformed calibration file (array sizes)")
    if not gain > 0 or not np.all(np.isfinite(cov)):
        raise InputError(f"{path}: malformed calibration file (torque_gain or covariance)")
    return KnownTerms(1.0 / gain, inertia, gravity, cov, calibrated=True)


def stiffness_from_toml(doc: dict, source: str) -> tuple[float, float] | None:
    """(c, std), N m/rad, of a calibration.toml document's ``[pendulum]``; None without one.

    Raises
    ------
    InputError
        A malformed ``[pendulum]`` table (``source`` names the file).
    """
    table = doc.get("pendulum")
    if table is None:
        return None
    try:
        c, std = float(table["stiffness"]), float(table["stiffness_std"])
    except (KeyError, TypeError, ValueError) as error:
        raise InputError(f"{source}: pendulum: malformed ({error!r})") from None
    if not (c > 0 and std >= 0):
        raise InputError(f"{source}: pendulum: stiffness must be > 0 and its std >= 0")
    return c, std


def device_known_terms(
    device: Device, calibration_source: str = "calibration.toml"
) -> tuple[KnownTerms, list[str]]:
    """The rig's known terms without a calibration: device.toml's tares and a torque gain of 1.

    They are taken as exact unless device.toml states their uncertainty
    (``tare_inertia_std`` of every stage and ``torque_gain_std``); the warning, naming the
    missing calibration ``calibration_source``, says when it does not.
    """
    known = KnownTerms.from_tares([st.tare_inertia for st in device.stages])
    tare_std = [st.tare_inertia_std for st in device.stages]
    gain_std = device.motor.torque_gain_std
    if all(v is not None for v in tare_std) and gain_std is not None:
        cov = np.zeros_like(known.cov)
        cov[0, 0] = gain_std**2  # h = 1/gain ~ 1 - (gain - 1): the same std to first order
        for s, v in enumerate(tare_std):
            cov[1 + 5 * s, 1 + 5 * s] = v**2
        stated = any(v > 0 for v in tare_std) or gain_std > 0
        return KnownTerms(1.0, known.inertia, known.gravity, cov, calibrated=stated), []
    warning = (
        f"{calibration_source}: not found, and device.toml states no tare_inertia_std "
        "and torque_gain_std: the tares of device.toml and a torque gain of 1 are taken as "
        "exact, and their errors are not in the stds (calibrate with rsp-inertia calibrate)"
    )
    return known, [warning]
