"""The rig's conventions verified from the calibration runs, and the encoder's zero offset
(docs/method.md §1, §3 "Encoder and drive", §5 "Calibration").

Physics first: a zero offset left in the readings turns the measured body about z, so the
zero's share of identify's uncertainty must be that turn's; a convention flipped must come
out as the reference's terms flipped. The calibrated route runs on the virtual device's
default experiment (forward runs, ideal reverse: about 10 s per folder) with a rig built
against the conventions (virtual.toml [rig]).
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from rsp_inertia import calibrate, identify, simulate, write_report
from rsp_inertia.cli import main
from rsp_inertia.estimation.conventions import (
    CONVENTIONS,
    ConventionCheck,
    check_conventions,
    shows_orientation,
    unverified_conventions,
)
from rsp_inertia.estimation.known_terms import ZERO_SOURCE, KnownTerms
from rsp_inertia.estimation.tensor_fit import fit_tensor
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import TrueBody, placed_reference
from rsp_inertia.plant.device_config import Mounting
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.geometry import entries_from_tensor, tensor_from_entries
from rsp_inertia.plant.transducers import encoder_reading, error_coefficients, true_angle
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.virtual.config import experiment_virtual, placed_body

# --- the encoder's zero -----------------------------------------------------------------------


def test_a_reading_with_a_zero_offset_goes_back_to_the_true_angle():
    """The reading floor((phi + z + e(phi)) / q) q taken back: within one count below phi."""
    q = 2 * math.pi / 65536
    phi = np.linspace(-7.0, 7.0, 1001)
    coefficients = error_coefficients([2e-4, 5e-5], [30.0, 100.0])
    zero = math.radians(3.0)
    back = true_angle(encoder_reading(phi, q, coefficients, zero), coefficients, zero)
    assert np.all(phi - back >= -1e-12) and np.all(phi - back < 1.001 * q)
    # Without the zero taken off, the readings are 3 deg off.
    assert np.allclose(true_angle(encoder_reading(phi, q, coefficients, zero), coefficients)
                       - phi, zero, atol=2 * q)


def _turn_generator(entries: np.ndarray) -> np.ndarray:
    """d/dz of the entries of Rz(z) J Rz(z)^T at z = 0 (the body turned about z)."""
    K = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    J = tensor_from_entries(entries)
    return entries_from_tensor(K @ J - J @ K)


def test_the_zeros_share_of_the_stds_is_the_bodys_turn_about_z(default_balances):
    """With only the zero uncertain (std s), identify's budget line for it is the tensor
    turned about z by s: |d entries / dz| s, computed here from the rotation itself."""
    known = KnownTerms.from_tares([bal.tare_inertia for bal in default_balances])
    s = math.radians(0.05)
    cov = np.zeros_like(known.cov)
    cov[known.zero_slice, known.zero_slice] = s**2
    known = dataclasses.replace(known, cov=cov, calibrated=True)
    fit = fit_tensor(default_balances, known, tests=False)
    part = fit.cov_parts[ZERO_SOURCE][:6, :6]
    expected = np.abs(_turn_generator(fit.entries)) * s
    np.testing.assert_allclose(np.sqrt(np.diag(part)), expected, rtol=2e-3, atol=1e-12)
    # The turn is one direction in the six entries: the share has rank one.
    assert np.linalg.matrix_rank(part, tol=1e-6 * np.abs(part).max()) == 1


# --- the check, by itself ---------------------------------------------------------------------


class _Fit:
    """A fit's names, estimates and covariance, as check_conventions reads them."""

    def __init__(self, k: float, std: float) -> None:
        self.names = ["convention"]
        self.x = np.array([k])
        self.cov = np.array([[std**2]])

    def index(self, name: str) -> int:
        return self.names.index(name)


def _known(zero: float = 0.0, zero_std: float = 0.0) -> KnownTerms:
    known = KnownTerms.exact(2, np.zeros(6))
    cov = known.cov.copy()
    cov[known.zero_slice, known.zero_slice] = zero_std**2
    return dataclasses.replace(known, zero=zero, cov=cov)


def _fitter(factors: dict[str, tuple[float, float]]):
    masks = {c.name: c.mask.tobytes() for c in CONVENTIONS}

    def fitter(flip):
        name = next(n for n, m in masks.items() if m == flip.tobytes())
        return None, _Fit(*factors[name])

    return fitter


def test_a_flipped_convention_is_refused_naming_it():
    factors = {c.name: (1.0, 0.002) for c in CONVENTIONS}
    factors["the gear's sense"] = (-0.998, 0.004)
    factors["the encoder's zero to the half turn"] = (-0.4, 0.01)  # a compromise: not chosen
    with pytest.raises(InputError) as error:
        check_conventions(_fitter(factors), _known(), "REF")
    message = str(error.value)
    assert message.startswith("REF: the rig's conventions: the gear turns the outer frame")
    assert "Jxz and Jyz come out at -0.998 +- 0.004" in message
    assert "(500 stds away)" in message and "reverse the gear's sense" in message
    assert "\n" not in message


def test_kept_conventions_are_verified_and_a_zero_beyond_the_bound_refused():
    factors = {c.name: (1.0 + 0.001, 0.003) for c in CONVENTIONS}
    check = check_conventions(_fitter(factors), _known(1e-3, 1e-5), None)
    assert check.zero_measured and check.zero == 1e-3
    assert check.statement.startswith(
        "conventions verified by the reference: the gear's sense, phi's handedness and the "
        "encoder's zero (each alternative at least 667 stds away; the encoder's zero offset "
        "+0.0573 +- 0.0006 deg, measured and applied)"
    )
    with pytest.raises(InputError, match=r"the encoder's zero is off by about \+12\.0 deg"):
        check_conventions(_fitter(factors), _known(math.radians(12.0), 1e-4), None)
    # A zero the reference shows too weakly is not measured, and the line says so.
    weak = check_conventions(_fitter(factors), _known(0.01, math.radians(2)), None)
    assert not weak.zero_measured
    assert weak.statement.startswith("conventions verified by the reference")
    assert weak.statement.endswith("the encoder's zero offset not measured)")


def test_a_reference_that_cannot_show_a_convention_leaves_it_unverified():
    factors = {c.name: (math.nan, math.inf) for c in CONVENTIONS}
    factors["the gear's sense"] = (1.0, 0.01)
    factors["the encoder's zero to the half turn"] = (1.0, 0.01)
    statement = ConventionCheck(factors=factors, zero_measured=True).statement
    assert statement.startswith(
        "conventions not verified: phi's handedness (the reference has too little Jxy, Jxz, "
        "x_c or Jyz in rig axes to show it); verified: the gear's sense and the encoder's zero "
        "to the half turn;"
    )
    assert "mount the reference turned" in statement
    assert unverified_conventions().statement.startswith("conventions not verified: no reference")


def test_only_a_reference_off_the_axis_or_with_harmonics_shows_the_orientation(default_device):
    straight = TrueBody(mass=3.0, inertia=[0.03, 0.03, 0.02, 0.0, 0.0, 0.0], com=[0, 0, 0])
    assert not shows_orientation(straight, default_device)
    turned = placed_reference(straight, Mounting(rotation=_turned(), origin=[0.0, 0.0, 0.0]))
    assert turned.inertia[3:].any() and shows_orientation(turned, default_device)
    off = dataclasses.replace(straight, com=np.array([0.0, 1e-3, 0.0]))
    assert shows_orientation(off, default_device)


def _turned() -> np.ndarray:
    """Rz(20 deg) Rx(30 deg): the commissioning mounting of docs/files.md."""
    a, b = math.radians(30.0), math.radians(20.0)
    Rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    Rz = np.array([[math.cos(b), -math.sin(b), 0], [math.sin(b), math.cos(b), 0], [0, 0, 1]])
    return Rz @ Rx


# --- the calibrated route on the virtual device -----------------------------------------------

REFERENCE = """[body]
mass = 3.0
inertia = [0.03, 0.032, 0.02, 0.0, 0.0, 0.0]
com = [0.0, 0.0, 0.0]
"""

FIXTURE = """
[fixture]
mass = 0.8
inertia = [0.004, 0.0045, 0.006, 0.0002, -0.0001, 0.00015]
com = [0.001, 0.0005, 0.0]
"""


def _mounting_table(origin_y: float) -> str:
    rows = ", ".join("[" + ", ".join(f"{v:.15f}" for v in row) + "]" for row in _turned())
    return f"\n[mounting]\nrotation = [{rows}]\norigin = [0.0, {origin_y}, 0.0]\n"


def _folder(root, role: str, rig: str, seed: int, turned: bool = True, device_edit=None):
    """The default experiment as the body's folder, the empty fixture's or the reference's,
    on a rig with an unbalanced fixture and the faults ``rig`` ([rig] lines); ``device_edit``
    (text -> text), if given, changes device.toml's text last."""
    create_default_experiment(root)
    device = (root / "device.toml").read_text()
    device = re.sub(r"\[pendulum\].*", "", device, flags=re.DOTALL)
    if role != "body":
        device = device.replace("[body]\nmass = 2.0", "")
        device = re.sub(r"\nmass = 2.0 .*\n", "\n", device)
    if role == "empty":
        device = device.replace("braking_torque = 0.12 ", "braking_torque = 0.03 ")
    if role == "reference" and turned:
        device += _mounting_table(0.002)
    if device_edit is not None:
        device = device_edit(device)
    (root / "device.toml").write_text(device)
    virtual = (root / "virtual.toml").read_text()
    if role != "body":
        virtual = re.sub(r"\[body\].*?\n\n", REFERENCE + "\n" if role == "reference" else "",
                         virtual, flags=re.DOTALL)
    virtual = virtual.replace("seed = 0", f"seed = {seed}") + FIXTURE + f"\n[rig]\n{rig}\n"
    (root / "virtual.toml").write_text(virtual)
    if role == "reference":
        (root / "reference.toml").write_text(REFERENCE)
    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    return root


def _rig(base, rig: str, body: bool = True, turned: bool = True):
    """(body, empty, reference) folders of one rig."""
    empty = _folder(base / "empty", "empty", rig, 2)
    reference = _folder(base / "reference", "reference", rig, 3, turned)
    exp = _folder(base / "exp", "body", rig, 1) if body else None
    if exp is None:
        exp = base / "exp"
        create_default_experiment(exp)
    return exp, empty, reference


@pytest.fixture(scope="module")
def zeroed(tmp_path_factory):
    """A rig whose encoder is zeroed 3 deg off phi = 0 (about 30 s)."""
    return _rig(tmp_path_factory.mktemp("zeroed"), "encoder_zero_deg = 3.0")


def test_a_zero_offset_is_measured_applied_and_the_tensor_is_true(zeroed):
    exp, empty, reference = zeroed
    calibration = calibrate(exp, empty, reference)
    zero, zero_std = math.degrees(calibration.encoder_zero), math.degrees(
        calibration.encoder_zero_std)
    assert abs(zero - 3.0) < 3 * zero_std and zero_std < 0.01
    assert calibration.conventions.startswith("conventions verified by the reference")
    result = identify(exp)
    truth = placed_body(open_experiment(exp).device, experiment_virtual(open_experiment(exp)))
    err = np.asarray(result.entries) - truth.inertia
    assert np.all(np.abs(err) < 3 * np.asarray(result.entries_std))
    assert np.abs(err).max() < 1e-4 * truth.inertia[:3].max()
    record = result.identification
    assert record.std_budget[ZERO_SOURCE]["tensor"].max() > 0
    assert record.calibration.conventions == calibration.conventions
    assert not result.warnings
    # The report says it, in its calibration section.
    page = Path(write_report(exp)).read_text()
    assert "Conventions verified by the reference: the gear&#x27;s sense" in page


@pytest.mark.parametrize(
    "fault, named",
    [
        ("gear_reversed = true", "the gear turns the outer frame the other way"),
        pytest.param("phi_left_handed = true", "phi is read left-handed",
                     marks=pytest.mark.slow),
    ],
)
def test_a_flipped_convention_is_refused_and_nothing_is_written(
    tmp_path, capsys, fault, named
):
    exp, empty, reference = _rig(tmp_path, fault, body=False)
    before = sorted(p.name for p in exp.iterdir())
    code = main(["calibrate", str(exp), "--empty", str(empty), "--reference", str(reference)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert named in err and "times their certified values" in err
    # Named for what it is, never taken for a drive loss or an encoder eccentricity.
    assert "drive loss" not in err and "gain" not in err and "eccentric" not in err
    assert sorted(p.name for p in exp.iterdir()) == before


@pytest.mark.slow
def test_a_straight_reference_says_the_conventions_are_not_verified(tmp_path):
    exp, empty, reference = _rig(tmp_path, "", body=False, turned=False)
    calibration = calibrate(exp, empty, reference)
    assert calibration.conventions.startswith("conventions not verified: the gear's sense")
    assert "conventions not verified" in (exp / "calibration.toml").read_text()
