"""Axis geometry and the design matrix (docs/method.md §1, §2, §5 "Axis designs")."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rsp_inertia.design.mountings import best_cone_opening
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.geometry import (
    axis_angles_deg,
    axis_direction,
    axis_nodes_deg,
    condition_number,
    cone_plus_z_design,
    design_matrix,
    device_design,
    entries_from_tensor,
    icosahedron_design,
    physical_margins,
    rcond_curve,
    relative_errors,
    tensor_from_entries,
)

# Closed forms of the regular icosahedron (docs/method.md §5): its six vertex axes meet pairwise
# at arccos(1/sqrt 5), and its design matrix has cond(V) = sqrt(5/2).
ICOSAHEDRON_ANGLE_DEG = np.degrees(np.arccos(1.0 / np.sqrt(5.0)))
ICOSAHEDRON_COND = np.sqrt(5.0 / 2.0)

angles = st.floats(-4 * np.pi, 4 * np.pi, allow_nan=False)
gear_ratios = st.floats(-20.0, 20.0, allow_nan=False)
entries = st.lists(st.floats(-10.0, 10.0, allow_nan=False), min_size=6, max_size=6)


def random_tensor(rng: np.random.Generator) -> np.ndarray:
    """A physical inertia tensor: R diag(principal moments) R^T, triangle inequality kept."""
    a, b = rng.uniform(0.5, 2.0, size=2)
    moments = np.array([a, b, rng.uniform(abs(a - b), a + b)])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q @ np.diag(moments) @ q.T


@given(phi=angles, lam=gear_ratios)
def test_directions_are_unit_vectors(phi: float, lam: float) -> None:
    assert np.linalg.norm(axis_direction(phi, lam)) == pytest.approx(1.0, abs=1e-12)


def test_directions_broadcast_over_arrays() -> None:
    phi = np.linspace(0.0, 2 * np.pi, 7)
    e = axis_direction(phi[:, None], np.array([0.5, 2.0, 5.0]))
    assert e.shape == (7, 3, 3)
    np.testing.assert_allclose(np.linalg.norm(e, axis=-1), 1.0, atol=1e-12)


@given(phi=angles)
def test_locked_outer_frame_spins_about_z(phi: float) -> None:
    # lambda = 0: the outer frame does not turn, the body spins about the shaft z.
    np.testing.assert_array_equal(axis_direction(phi, 0.0), [0.0, 0.0, 1.0])


@given(phi=angles, lam=gear_ratios)
def test_axis_lies_on_its_cone(phi: float, lam: float) -> None:
    # The instantaneous axis sweeps the cone of half-opening beta = arctan(lambda) (§1).
    ez = axis_direction(phi, lam)[2]
    assert np.degrees(np.arccos(ez)) == pytest.approx(np.degrees(np.arctan(abs(lam))), abs=1e-6)


@given(j6=entries, phi=angles, lam=gear_ratios)
def test_design_row_gives_the_moment_about_the_axis(
    j6: list[float], phi: float, lam: float
) -> None:
    # V_k . [Jx, Jy, Jz, Jxy, Jyz, Jxz] = e^T J e for any symmetric J (§5, paper (8)).
    J = tensor_from_entries(j6)
    e = axis_direction(phi, lam)
    lhs = design_matrix(e[None, :])[0] @ np.asarray(j6)
    assert lhs == pytest.approx(e @ J @ e, abs=1e-10 * (1 + np.abs(j6).max()))


@given(j6=entries, phi=angles, lam=st.floats(-8.0, 8.0, allow_nan=False))
def test_harmonic_form_equals_the_quadratic_form(j6: list[float], phi: float, lam: float) -> None:
    # Two independent computations of (1 + lambda^2) J_e(phi): docs/method.md §2's harmonic form
    # and the 3-D quadratic form about the axis of §1.
    jx, jy, jz, jxy, jyz, jxz = j6
    harmonic = (
        jz
        + lam**2 * (jx + jy) / 2
        + lam**2 * (jy - jx) / 2 * np.cos(2 * phi)
        + lam**2 * jxy * np.sin(2 * phi)
        + 2 * lam * jxz * np.sin(phi)
        + 2 * lam * jyz * np.cos(phi)
    )
    e = axis_direction(phi, lam)
    quadratic = (1 + lam**2) * (e @ tensor_from_entries(j6) @ e)
    assert quadratic == pytest.approx(harmonic, abs=1e-9 * (1 + lam**2) * (1 + np.abs(j6).max()))


@given(j6=entries)
def test_entries_tensor_round_trip(j6: list[float]) -> None:
    J = tensor_from_entries(j6)
    np.testing.assert_array_equal(J, J.T)
    np.testing.assert_array_equal(entries_from_tensor(J), j6)
    np.testing.assert_array_equal(tensor_from_entries(entries_from_tensor(J)), J)


def test_products_are_tensor_entries() -> None:
    J = tensor_from_entries([1.0, 2.0, 3.0, 0.1, 0.2, 0.3])
    assert (J[0, 1], J[1, 2], J[0, 2]) == (0.1, 0.2, 0.3)


def test_angles_are_between_lines_not_vectors() -> None:
    # An axis and its opposite are the same line: angle 0, and nothing exceeds 90 deg.
    e = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, -1.0]])
    a = axis_angles_deg(e)
    assert a[0, 1] == 0.0
    assert a[0, 2] == pytest.approx(45.0)
    assert np.all((a >= 0.0) & (a <= 90.0))
    np.testing.assert_array_equal(np.diag(a), 0.0)


def test_icosahedron_axes_are_equiangular() -> None:
    d = icosahedron_design()
    off = d.angles_deg[np.triu_indices(6, k=1)]
    assert off.size == 15
    np.testing.assert_allclose(off, ICOSAHEDRON_ANGLE_DEG, atol=1e-9)
    np.testing.assert_array_equal(d.stages, [1, 1, 1, 2, 2, 2])


def test_icosahedron_condition_is_sqrt_five_halves() -> None:
    assert icosahedron_design().condition == pytest.approx(ICOSAHEDRON_COND, abs=1e-12)


def test_six_independent_axes_recover_the_tensor() -> None:
    # Moments about six well-spread axes (computed directly as e^T J e) determine J (§5).
    rng = np.random.default_rng(7)
    J = random_tensor(rng)
    d = icosahedron_design()
    V = d.matrix
    assert np.linalg.matrix_rank(V) == 6
    moments = np.einsum("ki,ij,kj->k", d.directions, J, d.directions)
    j6 = np.linalg.solve(V, moments)
    # cond(V) = 1.58 amplifies rounding only a little.
    np.testing.assert_allclose(tensor_from_entries(j6), J, atol=1e-13)


def test_rank_deficient_design_has_infinite_condition() -> None:
    # All five cone axes collapse onto z at zero opening: V has rank 1.
    assert condition_number(cone_plus_z_design(0.0).matrix) == np.inf
    assert rcond_curve([0.0])[0] == 0.0


def test_cone_opening_out_of_range_is_an_input_error() -> None:
    with pytest.raises(InputError, match="180"):
        cone_plus_z_design(180.0)


def test_best_cone_opening_matches_the_paper() -> None:
    opening, cond = best_cone_opening()
    # The paper reads its Fig. 1 to the nearest 10 deg-ish (140 deg); the minimum is at 142.
    assert opening == pytest.approx(142.0, abs=1.0)
    # Paper: cond 1.4899 at the optimum it read off the curve.
    assert cond == pytest.approx(1.4899, abs=0.005)
    assert cone_plus_z_design(opening).condition == pytest.approx(cond, abs=1e-12)


def test_best_cone_opening_beats_every_other_opening() -> None:
    opening, cond = best_cone_opening()
    grid = np.arange(1.0, 179.0, 0.05)
    # Slack: rounding of the SVD only.
    assert np.all(cond <= 1.0 / rcond_curve(grid) + 1e-12)
    for other in (130.0, 140.0, opening - 0.5, opening + 0.5):
        assert cond <= cone_plus_z_design(other).condition


def test_one_cone_plus_z_needs_no_gear_switch_but_beats_the_icosahedron() -> None:
    # Fig. 1's optimum (1.489) conditions V slightly better than the icosahedron (1.581).
    assert best_cone_opening()[1] < icosahedron_design().condition


def test_device_with_a_locked_stage_gives_one_z_axis() -> None:
    lam = np.tan(np.radians(142.0) / 2)
    device = SimpleNamespace(
        stages=(
            SimpleNamespace(gear_ratio=0.0, nodes_deg=(0.0, 90.0, 180.0)),
            SimpleNamespace(gear_ratio=lam, nodes_deg=(0.0, 72.0, 144.0, 216.0, 288.0)),
        )
    )
    assert axis_nodes_deg(device.stages[0]) == [0.0]
    assert axis_nodes_deg(device.stages[1]) == [0.0, 72.0, 144.0, 216.0, 288.0]
    d = device_design(device)
    assert d.name == "device"
    np.testing.assert_array_equal(d.stages, [1, 2, 2, 2, 2, 2])
    np.testing.assert_array_equal(d.directions[0], [0.0, 0.0, 1.0])
    # Same axes as the cone-plus-z design, listed in the other stage order.
    cone = cone_plus_z_design(142.0)
    np.testing.assert_allclose(d.directions[1:], cone.directions[:5], atol=1e-15)
    assert d.condition == pytest.approx(cone.condition, rel=1e-12)


def test_device_of_the_paper_is_the_icosahedron() -> None:
    s5 = np.sqrt(5.0)
    device = SimpleNamespace(
        stages=(
            SimpleNamespace(gear_ratio=3 - s5, nodes_deg=(0.0, 120.0, 240.0)),
            SimpleNamespace(gear_ratio=3 + s5, nodes_deg=(60.0, 180.0, 300.0)),
        )
    )
    np.testing.assert_array_equal(device_design(device).matrix, icosahedron_design().matrix)


def test_designs_are_frozen() -> None:
    d = icosahedron_design()
    with pytest.raises(AttributeError):
        d.name = "other"  # type: ignore[misc]
    with pytest.raises(ValueError):
        d.phis[0] = 1.0


def test_physical_margins_are_the_smallest_moment_and_the_triangle() -> None:
    rng = np.random.default_rng(3)
    J = random_tensor(rng)
    moments = np.linalg.eigvalsh(J)
    smallest, triangle = physical_margins(entries_from_tensor(J))
    assert smallest == pytest.approx(moments[0], rel=1e-12)
    assert triangle == pytest.approx(moments[0] + moments[1] - moments[2], rel=1e-9)
    # A flat plate is on the triangle's limit, a rod with a negative moment off both.
    assert physical_margins([1.0, 2.0, 3.0, 0.0, 0.0, 0.0])[1] == 0.0
    smallest, triangle = physical_margins([-0.1, 1.0, 1.0, 0.0, 0.0, 0.0])
    assert smallest == -0.1 and triangle < 0
    # Several tensors at once, as physical_warnings samples them.
    many = np.array([entries_from_tensor(random_tensor(rng)) for _ in range(4)])
    batch = np.column_stack(physical_margins(many))
    np.testing.assert_array_equal(batch, [physical_margins(e) for e in many])


def test_physical_warnings_take_the_margins_from_physical_margins(monkeypatch) -> None:
    """plant.geometry.physical_warnings judges the margins plant.geometry gives it."""
    from rsp_inertia.plant import geometry

    body = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    cov = np.diag(np.full(6, 1e-14))
    assert geometry.physical_warnings(body, cov) == []

    def broken(j6):
        smallest, triangle = physical_margins(j6)
        return smallest - 1.0, triangle - 1.0

    monkeypatch.setattr(geometry, "physical_margins", broken)
    found = geometry.physical_warnings(body, cov)
    assert len(found) == 2 and "not positive definite" in found[0] and "triangle" in found[1]


def test_relative_errors_are_over_the_largest_principal_moment() -> None:
    truth = np.array([1.0, 2.0, 3.0, 0.0, 0.0, 0.5])
    scale = np.linalg.eigvalsh(tensor_from_entries(truth)).max()
    estimate = truth + np.array([0.0, 1e-3, 0.0, 0.0, -2e-3, 0.0])
    np.testing.assert_allclose(
        relative_errors(estimate, truth), (estimate - truth) / scale, rtol=1e-15
    )


def test_the_demo_prints_the_errors_relative_errors_gives(monkeypatch) -> None:
    """rsp_inertia.results.format_identification's error columns are relative_errors'."""
    from rsp_inertia.results import format_identification

    truth = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    result = SimpleNamespace(
        entries=truth + 1e-6, entries_std=np.full(6, 1e-7), node_entries=truth - 1e-6,
        node_entries_cov=np.eye(6) * 1e-12, condition_number=1.58, axes=[], std_budget={},
        friction_asymmetry=None, warming=None, calibration=None, pendulum=None, com=None, decision=None,
        warnings=[], expanded_uncertainty=SimpleNamespace(lines=list),
    )
    monkeypatch.setattr(
        "rsp_inertia.results.identify.relative_errors", lambda j6, true_j6: np.full(6, 0.125)
    )
    rows = format_identification(result, truth).splitlines()[1:7]
    assert all(row.split()[-2:] == ["+1.2e-01", "+1.2e-01"] for row in rows)
