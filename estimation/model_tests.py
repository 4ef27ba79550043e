"""Model tests of the balance equations: do the runs agree beyond their noise?

A run's own fit can absorb a systematic misfit into its speed-noise scale
(rsp_inertia.estimation.gls: its own M harmonics and constant take up much of it), so the scale
alone proves nothing: the runs are checked against each other. Unknowns declared per group
(the tensor, per run) are fitted once shared and once free per group (each run its own
tensor; each run's early and late turns their own; each turn its own), with the same
weights. The chi^2 drop is chi^2-distributed with as many degrees of freedom as the freed
unknowns add to the rank when the model is right; each drop is tested at a family-wise level
``TEST_ALPHA`` (Bonferroni over the tests). A systematic error rarely biases every run, and
fast and slow turns, alike: friction that differs between the directions of rotation (its
work grows with speed), a wrong spring or gear ratio, a torque gain that differs between
runs.

Probes. A suspected cause with a known signature (rsp_inertia.estimation.gls Block.probes)
is tested the same way: its columns added to the joint model, the chi^2 drop against its
rank. A drive that loses power by its direction of flow scales the driving and the
back-driven work differently, a signature no tensor and no gain can take up (the friction's
share of the work changes from turn to turn and between stages); a motor that warms between
the passes has a torque scale that falls with the heat its motor has dissipated so far, through
both passes and more in the reverse, which comes after the braking and works harder (its
column both passes' work weighted by that heat, rsp_inertia.estimation.balance.heat_work,
one coefficient for every run), where a drive's loss scales every run's driving work alike;
an encoder's reading error scales the kinetic energy by 1 + 2 e'(phi), at harmonics of the angle whose size grows with
the whole M, where the body's harmonics do not. Each probe test is one more test of the
family (Bonferroni), and its fitted terms (``estimate``) are what the warning reports. A
wrong model takes up any column it is offered, so the causes are found one at a time: the
probe most significant given those found before joins them while one is significant at the
family's level, and each probe's test is then made given the causes found (its columns added
to a model that has theirs): with an encoder's error alone, the drive's probe explains
nothing the encoder's does not, and the other way round. (Testing each given all the others
would cost a cause its power to a probe of many columns that merely overlaps it: the
encoder's six columns took the warming probe's p-value from 1e-11 to 0.01 on a motor that
drifted 2e-4 in one stage.) A drive's loss and a
warming motor both scale the work between the passes, and where the runs carry little on
how the scale grows through a run and from run to run (a drift of 2e-4 in one stage, the
other hardly warming), each explains what the other would: neither test given the other
finds it while the runs disagree. Their joint test (``SCALE_PROBES``, one more of the
family) then names both, each with its estimate fitted alone; it is not warned of when
either is named by its own test.

What a probe's fitted terms say, in words and numbers, is its warning's text
(:func:`probe_detail`, filled in by :func:`described` with the rig's known terms the fit
applied); the probes' columns are rsp_inertia.estimation.columns.cause_probes.

A smooth regressor per run (a drift in the angle, the shape of friction work) is no test
here: the kinetic energy along the braking is itself such a smooth function, so it would
stand in for the noisy measured speeds and reject every run. Nor is a per-node term (M let
off its harmonic form within 15 deg of each node): a closed-loop reverse leaves structure
locked to the angle there, so it would raise false alarms (benchmarks/results/design-notes.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import chi2

from rsp_inertia.estimation.whitening import Identity, lstsq_rows, weighted_chi2, whiten
from rsp_inertia.infra.frozen import freeze_arrays
from rsp_inertia.infra.progress import report

if TYPE_CHECKING:
    from rsp_inertia.estimation.gls import Block
    from rsp_inertia.estimation.known_terms import KnownTerms

__all__ = [
    "COARSE_COUNTS",
    "DRIVE_PROBE",
    "ENCODER_PROBE",
    "PROBE_ORDERS",
    "SCALE_CAP",
    "SCALE_PROBES",
    "TEST_ALPHA",
    "TURN_PARTS",
    "WARMING_PROBE",
    "ModelTest",
    "coarse_encoder_warnings",
    "described",
    "model_warnings",
    "probe_detail",
    "run_model_tests",
]

SCALE_CAP = 1e4
"""Largest speed-noise scale; a run that needs it has residuals no encoder explains."""

TEST_ALPHA = 0.01
"""Family-wise false-alarm probability of the model tests of one fit (Bonferroni over the
tests): a clean rig's identification warns in about 1 run in 100."""

DRIVE_PROBE = "drive loss"
"""The model test of a drive that loses power by its direction of flow (probe kind)."""
WARMING_PROBE = "warming motor"
"""The model test of a torque scale that differs between a run's braking and reverse pass by
a drift that grows with the heat its motor dissipated (probe kind)."""
SCALE_PROBES = "drive loss or warming motor"
"""The joint test of the drive-loss and warming probes (both scale the work between the
passes), warned of only when neither is named by its own test; its ``estimate`` is each
probe's fitted alone."""
ENCODER_PROBE = "encoder error"
"""The model test of a periodic error of the encoder's reading (probe kind)."""
PROBE_ORDERS = 3
"""Orders of the encoder's error the probe looks for (rsp_inertia.estimation.calibration
ENCODER_ORDERS: orders 1 and 2 bias the tensor, order 3 is still measurable)."""


@dataclass(frozen=True)
class ModelTest:
    """A chi^2 test of the balance model (module docstring)."""

    kind: str
    """"consistency" (between runs), "early/late" (between each run's halves) or "per turn"."""
    label: str
    """What was tested, e.g. "stage 1 forward"."""
    statistic: float
    """The chi^2 drop."""
    dof: int
    """Degrees of freedom added."""
    p_value: float
    """P(chi^2_dof >= statistic) under the model."""
    significant: bool
    """p_value below the family-wise level (Bonferroni over the fit's tests)."""
    estimate: np.ndarray | None = None
    """A probe test's fitted terms (the probe's columns' coefficients), else None."""
    estimate_cov: np.ndarray | None = None
    """Their covariance."""
    detail: str = ""
    """What the fitted terms mean, in words and numbers, for the warning (a probe's:
    :func:`probe_detail`)."""

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen

    def to_dict(self) -> dict:
        """The result.json entry."""
        return {
            "kind": self.kind,
            "label": self.label,
            "chi2": self.statistic,
            "dof": self.dof,
            "p_value": self.p_value,
            "significant": self.significant,
        }


def run_model_tests(
    blocks, names, A, y, x, factors, nuisance=None, probes=None, probe_factors=None,
    probe_bounds=None,
) -> list[ModelTest]:
    """The three tests (between runs, early against late turns, per turn) of a joint fit, and
    one per probe.

    The unknowns of the blocks' ``fixed_in_tests`` are held at ``x``.

    Parameters
    ----------
    blocks : list of Block
        The runs' blocks of equations (rsp_inertia.estimation.gls.Block).
    names : list of str
        The unknowns, in the order of ``A``'s columns.
    A : numpy.ndarray
        The stacked equations' design matrix.
    y : numpy.ndarray
        Their right-hand side.
    x : numpy.ndarray
        The joint estimate of the unknowns.
    factors : list
        The Cholesky factors of the equations' covariance (rsp_inertia.estimation.whitening).
    nuisance : tuple, optional
        (B, p): columns of p standardised calibration errors (prior N(0, 1) each) that both
        fits of a test take as unknowns.
    probes : dict of str to numpy.ndarray, optional
        Cause -> the columns it would add (module docstring).
    probe_factors : list, optional
        The covariance's factors for the probe tests when they differ (speed-noise scales
        taken with the probes in each run's own fit, rsp_inertia.estimation.gls).
    probe_bounds : dict of str to float, optional
        Cause -> the largest value the physics allows its probe's one coefficient
        (:func:`_probe_tests`).

    Returns
    -------
    list of ModelTest
        One per test made, each marked significant at the family-wise level.
    """
    found_tests = []
    fixed = [j for j, n in enumerate(names) if any(n in b.fixed_in_tests for b in blocks)]
    kept = [j for j in range(len(names)) if j not in fixed]
    y_kept = y - A[:, fixed] @ x[fixed]
    splits = ((None, "consistency"), ("halves", "early/late"), ("turns", "per turn"))
    for step, (split, kind) in enumerate(splits):
        report("least squares: model tests", step, len(splits) + len(probes or {}))
        found = _consistency(
            blocks, [names[j] for j in kept], A[:, kept], y_kept, factors, split, nuisance
        )
        if found is not None:
            found_tests.append(((kind, found[0]), found[1], found[2], None))
    probes = probes or {}
    found_tests += _probe_tests(
        A[:, kept], y_kept, probes, probe_factors or factors, nuisance, len(found_tests),
        probe_bounds or {},
    )
    level = TEST_ALPHA / max(len(found_tests), 1)
    model_tests = []
    for (kind, label), stat, dof_, fitted in found_tests:
        p_value = float(chi2.sf(max(stat, 0.0), dof_))
        estimate, estimate_cov = (None, None) if fitted is None else fitted
        model_tests.append(
            ModelTest(
                kind, label, float(stat), int(dof_), p_value, p_value < level,
                estimate, estimate_cov,
            )
        )
    return model_tests


def _probe_tests(A, y, probes, factors, nuisance, n_tests: int, bounds: dict) -> list:
    """The probes' tests (module docstring): the causes the runs call for, found one at a time
    (the most significant given those found before, at the family's level), then each probe
    tested given the causes found (the drive's loss and the warming motor given each other
    too, each only while its own estimate is physical), and the pair's joint test.
    ``n_tests``: the family's other tests. ``bounds``: cause -> the largest value the physics
    allows its one coefficient; beyond it the test's chi^2 drop is the one at the bound,
    (x^2 - (x - c)^2) / var for an estimate x of variance var and bound c (a likelihood
    ratio test under the constraint; zero for c = 0), so that a drive "gaining" power is
    never named a loss."""
    pair = (DRIVE_PROBE, WARMING_PROBE)
    both = all(cause in probes for cause in pair)
    level = TEST_ALPHA / max(n_tests + len(probes) + both, 1)

    def given(columns, causes, cause=None):
        base = np.hstack([A, *(probes[c] for c in causes)])
        found = _probe(base, columns, y, factors, nuisance)
        if found is None or cause not in bounds or found[1] != 1:
            return found
        (x,), var = found[2][0], found[2][1][0, 0]
        c = bounds[cause]
        if x <= c or var <= 0.0:
            return found
        return (max((x * x - (x - c) ** 2) / var, 0.0), *found[1:])

    def physical(cause, causes):
        found = given(probes[cause], causes)
        return cause not in bounds or found is None or found[2][0][0] <= bounds[cause]

    def p_value(found):
        return float(chi2.sf(max(found[0], 0.0), found[1]))

    named: list[str] = []
    while True:
        trial = {c: given(probes[c], named, c) for c in probes if c not in named}
        trial = {c: found for c, found in trial.items() if found is not None}
        if not trial:
            break
        best = min(trial, key=lambda c: p_value(trial[c]))
        if p_value(trial[best]) >= level:
            break
        named.append(best)
    tests = []
    for cause, columns in probes.items():
        # Given the causes found (a wrong model takes up any column it is offered), and the
        # pair's other member: each names only what the other cannot explain.
        others = [c for c in named if c != cause]
        if both and cause in pair:
            partner = next(c for c in pair if c != cause)
            if partner not in others and physical(partner, others):
                others.append(partner)
        found = given(columns, others, cause)
        if found is not None:
            tests.append(((cause, cause), *found))
    if both:
        others = [c for c in named if c not in pair]
        found = given(np.hstack([probes[c] for c in pair]), others)
        if found is not None and not all(physical(c, others) for c in pair):
            found = (0.0, *found[1:])  # one of the two cannot be: no "either"
        if found is not None:
            alone = [given(probes[c], others) for c in pair]
            if all(a is not None for a in alone):  # each fitted alone, for the warning
                estimate = np.array([a[2][0][0] for a in alone])
                cov = np.diag([a[2][1][0, 0] for a in alone])
                found = (found[0], found[1], (estimate, cov))
            tests.append(((SCALE_PROBES, SCALE_PROBES), *found))
    return tests


def _with_nuisance(A, y, factors, nuisance):
    """Equations with the calibrated terms' standardised errors as unknowns with the prior
    N(0, 1) (:func:`_consistency`)."""
    if nuisance is None:
        return A, y, list(factors), 0
    B, p = nuisance
    A = np.vstack([np.hstack([A, B]), np.hstack([np.zeros((p, A.shape[1])), np.eye(p)])])
    return A, np.concatenate([y, np.zeros(p)]), list(factors) + [Identity(p)], p


def _probe(A, columns, y, factors, nuisance):
    """(chi^2 drop, dof, (estimate, covariance)) when the probe's ``columns`` join the joint
    model's unknowns; None if they add nothing to its rank."""
    base, y_aug, factors_aug, p = _with_nuisance(A, y, factors, nuisance)
    extra = np.vstack([columns, np.zeros((p, columns.shape[1]))])
    joint, rank_joint, _ = weighted_chi2(base, y_aug, factors_aug)
    freed = np.hstack([base, extra])
    free, rank_free, _ = weighted_chi2(freed, y_aug, factors_aug)
    dof = rank_free - rank_joint
    if dof <= 0:
        return None
    Aw = whiten(freed, factors_aug)
    cov = np.linalg.pinv(Aw.T @ Aw)
    estimate = np.linalg.lstsq(Aw, whiten(y_aug, factors_aug), rcond=None)[0]
    k = columns.shape[1]
    return joint - free, dof, (estimate[-k:], cov[-k:, -k:])


TURN_PARTS = 16
"""Most parts of a run in the per-turn test: a longer run's turns are grouped into this many
runs of consecutive turns (:func:`_parts`), so that the test's unknowns, and its cost, stay
bounded however long the braking (a test of thousands of degrees of freedom would also
drown a misfit of a few turns' pattern)."""


def _consistency(
    blocks, names, A, y, factors, split, nuisance=None
) -> tuple[str, float, int] | None:
    """The chi^2 drop when the grouped unknowns are freed per group, or None if no groups.

    ``split``: None, or each block's balance angles are also cut into parts, each a group of
    its own: "halves" (early turns, late turns) or "turns" (every whole turn travelled, at
    most TURN_PARTS parts; a last part shorter than a turn joins the one before).
    ``nuisance``: (B, p), columns of p standardised calibration errors (prior N(0, 1) each)
    that both fits take as unknowns. Both fits fold the whitened rows block by block
    (rsp_inertia.estimation.whitening.lstsq_rows): the freed design is never held whole.
    """
    grouped = {name for block in blocks for name in block.groups}
    labels = list(dict.fromkeys(g for block in blocks for g in block.groups.values()))
    if not grouped or (len(labels) < 2 and split is None):
        return None
    free_names = [n for n in names if n not in grouped]
    block_parts = []
    for block in blocks:
        parts = []
        for rows, half in _parts(block, split):
            keys = {}
            for name in sorted(grouped & block.columns.keys()):
                key = f"{name}@{block.groups[name]}{half}"
                keys[key] = name
                if key not in free_names:
                    free_names.append(key)
            parts.append((rows, keys))
        block_parts.append(parts)
    index = {name: j for j, name in enumerate(free_names)}
    q = 0 if nuisance is None else nuisance[1]
    starts = np.cumsum([0] + [len(block.rhs) for block in blocks])

    def pieces(free: bool):
        width = len(free_names) if free else A.shape[1]
        for k, (block, factor) in enumerate(zip(blocks, factors)):
            mine = slice(starts[k], starts[k + 1])
            if free:
                shared = [n for n in block.columns if n in index and n not in grouped]
                cols = [index[n] for n in shared] + [
                    index[key] for _, keys in block_parts[k] for key in keys
                ]
                M = np.zeros((len(block.rhs), len(cols)))
                for j, name in enumerate(shared):
                    M[:, j] = block.columns[name]
                j = len(shared)
                for rows, keys in block_parts[k]:
                    for name in keys.values():
                        M[rows, j] = block.columns[name][rows]
                        j += 1
            else:
                cols = list(range(width))
                M = A[mine]
            if q:
                cols = cols + list(range(width, width + q))
                M = np.hstack([M, nuisance[0][mine]])
            yield np.array(cols, dtype=int), factor.whiten(M), factor.whiten(y[mine])
        if q:  # the calibration's prior, z = 0 +- 1
            yield np.arange(width, width + q), np.eye(q), np.zeros(q)

    joint, rank_joint, _ = lstsq_rows(pieces(False), A.shape[1] + q)
    free, rank_free, _ = lstsq_rows(pieces(True), len(free_names) + q)
    dof = rank_free - rank_joint
    if dof <= 0:
        return None
    what = {
        None: "the runs " + ", ".join(labels),
        "halves": "the early and late turns of each run",
        "turns": "the turns of each run",
    }[split]
    return what, joint - free, dof


def _parts(block: Block, split: str | None) -> list[tuple[slice, str]]:
    """Row ranges of a block for :func:`_consistency`, with their group suffixes."""
    n = len(block.rhs)
    if split is None:
        return [(slice(0, n), "")]
    if split == "halves":
        return [(slice(0, n // 2), " early"), (slice(n // 2, n), " late")]
    turn = np.floor(block.balance.friction_shape[:, 0] / (2 * math.pi)).astype(int)
    turns = max(int(turn[-1]), 1)  # a last partial turn joins the one before
    turn = np.minimum(turn, turns - 1)
    if turns <= TURN_PARTS:
        starts = np.searchsorted(turn, np.arange(turns))
        ends = np.append(starts[1:], n)
        return [(slice(a, b), f" turn {k + 1}") for k, (a, b) in enumerate(zip(starts, ends))]
    first = np.floor(np.arange(TURN_PARTS + 1) * turns / TURN_PARTS).astype(int)
    starts = np.searchsorted(turn, first[:-1])
    ends = np.append(starts[1:], n)
    return [
        (slice(a, b), f" turns {first[k] + 1}-{first[k + 1]}")
        for k, (a, b) in enumerate(zip(starts, ends))
    ]


COARSE_COUNTS = 1.0
"""Counts per sample (median over a run's balance angles, at the braking's speed) below which
identify warns that the encoder is coarse for the run (:func:`coarse_encoder_warnings`)."""


def coarse_encoder_warnings(balances, quantum: float, dt: float, labels: list[str]) -> list[str]:
    """One warning per run whose braking moves fewer than COARSE_COUNTS encoder counts per
    sample over its balances (median; Omega^2 ~ S / 2 at each balance angle).

    There the reading error is a few aliased lines of the quantization's sawtooth, not white
    noise (rsp_inertia.estimation.smoothing: quantization lines): the speed error's level moves
    10x along the run about what the white model and the run's one speed-noise scale say. The
    stds keep their calibration on the residuals (measured on the virtual device at 10 bits:
    mean (err/std)^2 0.81 over 30 closed-loop experiments), but the closure tests lose their
    footing: on an ideal reverse of a lossless drive with an exact 10-bit encoder they named a
    drive loss in 17 of 30 experiments and an unclosed balance in nearly all.

    Parameters
    ----------
    balances : list of StageBalance
        The runs' balances (rsp_inertia.estimation.balance), their ``speed_sq`` S, rad^2/s^2.
    quantum : float
        rad, the encoder's count.
    dt : float
        s, the sampling period.
    labels : list of str
        The runs' names, one per balance.

    Returns
    -------
    list of str
        The warnings, one per coarse run.
    """
    warnings = []
    for bal, label in zip(balances, labels):
        speed = np.sqrt(np.asarray(bal.speed_sq, dtype=float) / 2)
        counts = float(np.median(speed)) * dt / quantum
        if counts < COARSE_COUNTS:
            warnings.append(
                f"{label}: the encoder reads {counts:.2g} counts per sample over the balances "
                "(median): its quantization error there is a few aliased lines, not the white "
                "noise the balances' noise model assumes, so the closure tests above may name a "
                "cause (drive loss, encoder error, unclosed turns) that is only the "
                "quantization, and the stds hold on average (scaled on the residuals) rather "
                "than balance by balance; a finer encoder or a faster launch lifts it"
            )
    return warnings


def model_warnings(tests: list[ModelTest], scales: list[float], labels: list[str]) -> list[str]:
    """Warnings from the balance model's tests and the runs' speed-noise scales.

    Parameters
    ----------
    tests : list of ModelTest
        The fit's model tests (:func:`run_model_tests`).
    scales : list of float
        The runs' speed-noise scales: one at SCALE_CAP means the balances do not close.
    labels : list of str
        The runs' names, one per scale.

    Returns
    -------
    list of str
        One warning per significant test and per run at the scale's cap.
    """
    warnings = []
    for label, scale in zip(labels, scales):
        if scale >= SCALE_CAP:
            warnings.append(
                f"{label}: the balance residuals exceed the encoder's speed-noise model even "
                f"{scale:.0f}-fold: the balances do not close; the stds are not reliable"
            )
    named = [test.kind for test in tests if test.significant and test.detail]
    either = (DRIVE_PROBE in named or WARMING_PROBE in named) and SCALE_PROBES in named
    if either:
        named.remove(SCALE_PROBES)
    for test in tests:
        if not test.significant or (either and test.kind == SCALE_PROBES):
            continue
        if test.detail:  # a probe: the cause is named, with what the runs say of it
            warnings.append(
                f"{test.kind}: {test.detail}; chi2 = {test.statistic:.3g} for {test.dof} "
                f"term(s), p = {test.p_value:.2g}: the result may be off by more than its std"
            )
            continue
        warnings.append(
            f"the balances do not close: {test.label} disagree beyond their noise (chi2 = "
            f"{test.statistic:.3g} for {test.dof} terms, p = {test.p_value:.2g}); likely "
            "causes: "
            + "".join(f"the {kind} named below, " for kind in named)
            + "friction that differs between the directions of rotation (run the "
            'stages both ways: directions = ["forward", "backward"]), a reverse that does not '
            "track the mirror, a wrong spring stiffness or gear ratio in device.toml, a torque "
            "gain that differs between the passes (a warming motor) or runs; the result may be off by more "
            "than its std"
        )
    return warnings


def described(
    tests: list[ModelTest],
    known: KnownTerms,
    one_direction: bool = False,
    compensated: bool = False,
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
    compensated : bool, optional
        The logs' torque was compensated for the motor's temperature.

    Returns
    -------
    list of ModelTest
        The tests, the probes' with their ``detail``.
    """
    return [
        replace(test, detail=probe_detail(test, known, one_direction, compensated))
        if test.kind in (DRIVE_PROBE, WARMING_PROBE, SCALE_PROBES, ENCODER_PROBE)
        else test
        for test in tests
    ]


def probe_detail(
    test: ModelTest, known: KnownTerms, one_direction: bool = False, compensated: bool = False
) -> str:
    """What a probe test's fitted terms say, in words and numbers (its warning's text).

    drive loss: the driving work's gain came out h_d + dh_d against h_b's, so the runs call
    for the round-trip efficiency (h_d + dh_d) / h_b (the common scale of both gains the
    tensor takes up). warming motor: the reverse pass's torque scale over the braking's,
    1 + d, in the run whose motor dissipated the most heat (the others' d in proportion to
    their heat). encoder error: each order's amplitude sqrt(c_n^2 + s_n^2), first-order
    std, in arcseconds. What to do depends on what is known: a calibration of the drive or of
    the encoder that the runs contradict (the rig changed since), or none (calibrate); a
    temperature compensation that the runs contradict (its tempco or lag), or none (log the
    temperature). In a stage run one way only, friction that differs between the directions
    of rotation leaves the same shape as a drive's loss (the braking turns one way, the
    reverse the other), so the drive's warning names it too.

    Parameters
    ----------
    test : ModelTest
        A model test, its ``estimate`` and ``estimate_cov`` the probe's fitted terms.
    known : KnownTerms
        The rig's known terms the fit applied (a calibration or none).
    one_direction : bool, optional
        Some stage was run in one direction only.
    compensated : bool, optional
        The logs' torque was compensated for the motor's temperature (device.toml
        ``[motor] torque_constant_tempco``).

    Returns
    -------
    str
        The warning's text; empty for a test that is no probe.
    """
    x, cov = test.estimate, test.estimate_cov
    gains = known.gains
    std = known.std if known.calibrated else np.zeros(known.cov.shape[0])
    if test.kind == SCALE_PROBES:
        drive = replace(test, kind=DRIVE_PROBE, estimate=x[:1], estimate_cov=cov[:1, :1])
        warming = replace(test, kind=WARMING_PROBE, estimate=x[1:], estimate_cov=cov[1:, 1:])
        return (
            "the work's scale differs between the passes, and the runs cannot tell a drive's "
            "loss from a warming motor; either "
            + probe_detail(drive, known, one_direction, compensated)
            + "; or "
            + probe_detail(warming, known, one_direction, compensated)
        )
    if test.kind == WARMING_PROBE:
        d, d_std = float(x[0]), math.sqrt(max(cov[0, 0], 0.0))
        if compensated:
            cause = (
                "the temperature compensation does not fit these runs: check device.toml "
                "[motor] torque_constant_tempco and temperature_lag, and that [log] "
                "temperature_column is the motor's winding or housing"
            )
        else:
            cause = (
                "a warming motor, whose torque constant falls as its magnets warm; log its "
                "temperature and state its tempco (device.toml [log] temperature_column, "
                "[motor] torque_constant_tempco)"
            )
        return (
            "the torque's scale differs between the braking and the reverse pass by "
            f"{d:+.2g} +- {d_std:.1g} in the run whose motor dissipated the most heat (in "
            f"the others in proportion to their heat): {cause}; see docs/method.md §3, "
            '"Temperature"'
        )
    if test.kind == DRIVE_PROBE:
        ratio = (gains[0] + x[0]) / gains[1]
        ratio_std = math.sqrt(max(cov[0, 0], 0.0)) / gains[1]
        if np.any(std[known.gains_slice] > 0):
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
