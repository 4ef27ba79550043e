"""reference.toml's certificate: its stds read into a covariance, its faults refused, and the
reference terms' derivatives against the physics they come from."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rsp_inertia.estimation.conventions import certificate_jacobian, reference_terms
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import (
    Certificate,
    Mounting,
    Reference,
    TrueBody,
    load_reference,
    write_reference,
)
from rsp_inertia.plant.model import inertia_harmonics

BODY = """[body]
mass = 3.0
inertia = [0.03, 0.032, 0.02, 0.001, -0.0005, 0.0002]
com = [0.001, -0.002, 0.003]
"""


def _write(tmp_path, text: str):
    path = tmp_path / "reference.toml"
    path.write_text(text)
    return path


def test_stated_stds_become_the_certificates_covariance(tmp_path):
    path = _write(
        tmp_path,
        BODY
        + "mass_std = 1e-4\ninertia_std = [1e-6, 2e-6, 3e-6, 4e-6, 5e-6, 6e-6]\n"
        + "com_std = [1e-5, 2e-5, 3e-5]\n\n[certificate]\nid = 'RB-1'\nissuer = 'Lab'\n"
        + "date = '2026-03-02'\n",
    )
    reference = load_reference(path)
    stds = [1e-4, 1e-6, 2e-6, 3e-6, 4e-6, 5e-6, 6e-6, 1e-5, 2e-5, 3e-5]
    np.testing.assert_array_equal(reference.cov, np.diag(np.square(stds)))
    assert reference.stated
    assert reference.certificate == Certificate(id="RB-1", issuer="Lab", date="2026-03-02")
    with pytest.raises(ValueError):
        reference.cov[0, 0] = 1.0  # read-only, as documented


def test_a_stated_covariance_is_read_whole(tmp_path):
    cov = np.diag([4.0, 4.0, 1.0, 1.0, 1.0, 1.0]) * 1e-12
    cov[0, 1] = cov[1, 0] = 3e-12  # Jx and Jy correlated (0.75)
    rows = ",\n".join("[" + ", ".join(repr(float(v)) for v in row) + "]" for row in cov)
    reference = load_reference(_write(tmp_path, BODY + f"inertia_cov = [\n{rows}\n]\n"))
    np.testing.assert_array_equal(reference.cov[1:7, 1:7], cov)
    assert reference.cov[0, 0] == 0.0 and reference.certificate is None
    write_reference(tmp_path / "again.toml", reference)
    assert load_reference(tmp_path / "again.toml") == reference


def test_a_certificate_without_stds_is_exact(tmp_path):
    reference = load_reference(_write(tmp_path, BODY))
    assert not reference.stated and not reference.cov.any()


def test_a_certificate_round_trips(tmp_path):
    body = TrueBody(3.0, [0.03, 0.032, 0.02, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    cov = np.diag(np.square([1e-4, 1e-6, 1e-6, 1e-6, 2e-7, 2e-7, 2e-7, 1e-6, 1e-6, 1e-6]))
    reference = Reference(body, cov, Certificate(id="X", issuer="", date="2026-01-31"))
    write_reference(tmp_path / "reference.toml", reference)
    assert load_reference(tmp_path / "reference.toml") == reference


@pytest.mark.parametrize(
    "extra, fault",
    [
        ("inertia_std = [1e-6, 1e-6, 1e-6, 1e-6, 1e-6]\n", "body.inertia_std"),
        ("inertia_std = [1e-6, 1e-6, 1e-6, 1e-6, 1e-6, -1e-6]\n", "body.inertia_std"),
        ("mass_std = -1.0\n", "body.mass_std"),
        ("com_std = [1e-6, 1e-6]\n", "body.com_std"),
        (
            "inertia_std = [1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6]\ninertia_cov = ["
            + ", ".join(["[" + ", ".join(["0.0"] * 6) + "]"] * 6)
            + "]\n",
            "give either body.inertia_std or body.inertia_cov",
        ),
        (
            "inertia_cov = ["
            + ", ".join(
                "[" + ", ".join("1e-12" if i == j else ("1e-13" if (i, j) == (0, 1) else "0.0")
                                for j in range(6)) + "]"
                for i in range(6)
            )
            + "]\n",
            "must be symmetric",
        ),
        (
            "inertia_cov = ["
            + ", ".join(
                "[" + ", ".join(("1e-12" if i == j else "2e-12") if {i, j} <= {0, 1} else
                                ("1e-12" if i == j else "0.0") for j in range(6)) + "]"
                for i in range(6)
            )
            + "]\n",
            "not positive semi-definite",
        ),
        ("\n[certificate]\nid = 'A'\ndate = '2 March 2026'\n", "certificate.date"),
        ("\n[certificate]\nissuer = 'Lab'\n", "certificate.id"),
    ],
)
def test_a_bad_certificate_is_refused_in_one_line(tmp_path, extra, fault):
    path = _write(tmp_path, BODY + extra)
    with pytest.raises(InputError) as caught:
        load_reference(path)
    message = str(caught.value)
    assert message.startswith(str(path)) and fault in message and "\n" not in message


# --- the reference terms' derivatives -----------------------------------------------------

GRAVITY = 9.81
RTOL = 1e-9
"""The central differences' rounding: terms of order 1 over steps of 1e-3 of the values
leave about 1e-13 relative."""


def _reference(mounting=None) -> Reference:
    body = TrueBody(2.5, [0.03, 0.032, 0.02, 0.001, -0.0005, 0.0002], [0.004, -0.002, 0.003])
    return Reference(body, mounting=mounting)


def test_the_terms_derivatives_unmounted_are_the_harmonics_and_the_weight():
    """Without a mounting the harmonics are linear in the tensor (inertia_harmonics of each
    unit entry) and the gravity terms are m g x_c, m g y_c."""
    reference = _reference()
    for gear_ratio in (0.7639320225, 5.2360679775):
        D = certificate_jacobian(reference, gear_ratio, GRAVITY)
        for i in range(6):
            unit = np.zeros(6)
            unit[i] = 1.0
            np.testing.assert_allclose(
                D[:5, 1 + i], inertia_harmonics(unit, gear_ratio, 0.0), rtol=RTOL, atol=1e-12
            )
        com, mass = reference.body.com, reference.body.mass
        np.testing.assert_allclose(D[5:, 0], GRAVITY * com[:2], rtol=RTOL)
        np.testing.assert_allclose(D[5:, 7:9], mass * GRAVITY * np.eye(2), rtol=RTOL, atol=1e-12)
        # The harmonics depend on neither the mass nor the centre of mass about O unmounted.
        np.testing.assert_allclose(D[:5, [0, 7, 8, 9]], 0.0, atol=1e-12)


def test_the_terms_are_homogeneous_in_mass_and_tensor_mounted():
    """Placed by a turn and a shift, the terms are homogeneous of degree one in the mass and
    the tensor (the centre of mass fixed): D (m, J, 0) = terms (Euler's theorem), the
    identity the certificate's common scale rests on (estimation.calibration)."""
    angle = math.radians(30.0)
    turn = np.array([[1, 0, 0], [0, math.cos(angle), -math.sin(angle)],
                     [0, math.sin(angle), math.cos(angle)]])
    reference = _reference(Mounting(rotation=turn, origin=[0.002, -0.001, 0.004]))
    values = reference.values
    scale = np.concatenate([values[:7], np.zeros(3)])
    for gear_ratio in (0.7639320225, 5.2360679775):
        D = certificate_jacobian(reference, gear_ratio, GRAVITY)
        terms = reference_terms(reference.placed, gear_ratio, GRAVITY)
        np.testing.assert_allclose(D @ scale, terms, rtol=RTOL, atol=1e-15)
        # The tensor's columns: the harmonics of each unit entry turned into rig axes.
        for i in range(6):
            unit = np.zeros(6)
            unit[i] = 1.0
            E = np.array([[unit[0], unit[3], unit[5]], [unit[3], unit[1], unit[4]],
                          [unit[5], unit[4], unit[2]]])
            turned = turn @ E @ turn.T
            entries = [turned[0, 0], turned[1, 1], turned[2, 2], turned[0, 1], turned[1, 2],
                       turned[0, 2]]
            np.testing.assert_allclose(
                D[:5, 1 + i], inertia_harmonics(np.array(entries), gear_ratio, 0.0),
                rtol=RTOL, atol=1e-12,
            )


def test_the_placed_reference_is_the_certificates_body_turned():
    turn = Mounting(rotation=np.eye(3), origin=[0.0, 0.0, 0.002])
    reference = dataclasses.replace(_reference(), mounting=turn)
    values = reference.values.copy()
    assert reference.placed_at(values) == reference.placed
