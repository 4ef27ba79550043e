"""Mountings: a body's own axes placed on the rig (docs/method.md §2 "Mountings").

rsp_inertia.plant.geometry.place_body carries a body's tensor and centre of mass from its
own axes to the rig's; device.toml's ``[mounting]`` states the rotation and the origin,
virtual.toml's ``[mounting]`` turns the real mounting by small angles from the stated one,
and rsp_inertia.virtual.device.placed_body is the virtual device's truth on the rig, which the
simulator runs and identify's result is compared with.
"""

import dataclasses

import numpy as np
import pytest

from rsp_inertia.identifying import identify
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Mounting, load_device, write_device
from rsp_inertia.plant.geometry import entries_from_tensor, place_body, small_rotation
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.config import VirtualMounting, load_virtual, placed_body, write_virtual
from tests.one_home import assert_calls_home, home_cases

QUARTER_TURN_X = ((1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0))
"""90 deg about x: body y -> rig z, body z -> rig -y (v_rig = R v_body)."""

HOMES = [
    ("a body carried to the rig's axes", "plant.geometry", "place_body", ["virtual.config"]),
    ("the virtual body on the rig", "virtual.config", "placed_body",
     ["virtual.integrate", "rig_demo"]),
]
"""(formula, home module, function, consumers): each consumer calls the home: a formula lives in one module."""

MOUNTING = f"""
[mounting]
rotation = {[list(row) for row in QUARTER_TURN_X]}
origin = [0.001, -0.0005, 0.02]
"""


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation drawn from the Haar measure (QR of a Gaussian matrix, signs fixed)."""
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def point_tensor(points: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """sum m (|r|^2 I - r r^T) of point masses about the origin of their coordinates."""
    square = np.einsum("n,ni,ni->", masses, points, points)
    return square * np.eye(3) - np.einsum("n,ni,nj->ij", masses, points, points)


# --- the formula ------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(5))
def test_place_body_is_the_sum_over_point_masses_in_rig_coordinates(seed):
    rng = np.random.default_rng(seed)
    points = rng.normal(0.05, 0.1, (40, 3))  # m, in body axes from the body's origin
    masses = rng.uniform(0.01, 0.2, 40)
    mass = masses.sum()
    inertia = entries_from_tensor(point_tensor(points, masses))
    com = masses @ points / mass
    rotation, origin = random_rotation(rng), rng.normal(0.0, 0.1, 3)

    placed, placed_com = place_body(inertia, com, mass, rotation, origin)

    rig = origin + points @ rotation.T  # every point in rig coordinates, from O
    direct = entries_from_tensor(point_tensor(rig, masses))
    # Sums of a few hundred products of order 1e-2: rounding far below 1e-12 of the largest.
    np.testing.assert_allclose(placed, direct, rtol=0, atol=1e-12 * np.abs(direct).max())
    np.testing.assert_allclose(placed_com, masses @ rig / mass, rtol=0, atol=1e-15)


def test_the_identity_mounting_returns_the_body_unchanged():
    inertia = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    com = np.array([0.003, -0.002, 0.0015])
    placed, placed_com = place_body(inertia, com, 2.0, np.eye(3), np.zeros(3))
    assert np.array_equal(placed, inertia) and np.array_equal(placed_com, com)


def test_place_body_is_affine_in_the_tensor_and_the_centre_of_mass():
    """A combination's linear model is place_body on basis vectors: exact to rounding."""
    rng = np.random.default_rng(7)
    rotation, origin, mass = random_rotation(rng), rng.normal(0.0, 0.05, 3), 2.5
    inertia, com = rng.normal(0.0, 0.03, 6), rng.normal(0.0, 0.01, 3)

    def f(x):
        return np.concatenate(place_body(x[:6], x[6:], mass, rotation, origin))

    offset = f(np.zeros(9))
    model = np.column_stack([f(e) - offset for e in np.eye(9)])
    x = np.concatenate([inertia, com])
    np.testing.assert_allclose(model @ x + offset, f(x), rtol=0, atol=1e-16)


def test_small_rotation_turns_about_the_rig_axes_in_order():
    a = np.radians(0.5)
    about_z = small_rotation([0.0, 0.0, 0.5])
    np.testing.assert_allclose(about_z @ [1.0, 0.0, 0.0], [np.cos(a), np.sin(a), 0.0], atol=1e-16)
    about_x = small_rotation([0.5, 0.0, 0.0])
    np.testing.assert_allclose(about_x @ [0.0, 1.0, 0.0], [0.0, np.cos(a), np.sin(a)], atol=1e-16)
    about_y = small_rotation([0.0, 0.5, 0.0])
    np.testing.assert_allclose(about_y @ [0.0, 0.0, 1.0], [np.sin(a), 0.0, np.cos(a)], atol=1e-16)
    angles = [0.3, -0.7, 1.1]
    turned = small_rotation(angles)
    composed = (
        small_rotation([angles[0], 0, 0])
        @ small_rotation([0, angles[1], 0])
        @ small_rotation([0, 0, angles[2]])
    )
    np.testing.assert_allclose(turned, composed, rtol=0, atol=1e-16)
    np.testing.assert_allclose(turned @ turned.T, np.eye(3), rtol=0, atol=1e-15)
    assert np.linalg.det(turned) == pytest.approx(1.0, abs=1e-15)
    assert np.array_equal(small_rotation([0.0, 0.0, 0.0]), np.eye(3))
    # Exact, not linearised: it departs from I + [angles]x at second order in the angles.
    skew = np.radians(angles)
    linear = np.eye(3) + np.array(
        [[0.0, -skew[2], skew[1]], [skew[2], 0.0, -skew[0]], [-skew[1], skew[0], 0.0]]
    )
    departure = np.abs(turned - linear).max()
    assert 1e-6 < departure < np.sum(skew**2)


# --- device.toml [mounting] -------------------------------------------------------------------


@pytest.fixture
def experiment(tmp_path):
    return create_default_experiment(tmp_path / "exp")


def with_table(root, table: str, name: str = "device.toml"):
    path = root / name
    path.write_text(path.read_text() + table)
    return path


def test_without_mounting_the_device_has_none(default_device):
    assert default_device.mounting is None


def test_a_mounting_loads_as_read_only_arrays(experiment):
    device = load_device(with_table(experiment, MOUNTING))
    mounting = device.mounting
    assert np.array_equal(mounting.rotation, np.array(QUARTER_TURN_X))
    assert np.array_equal(mounting.origin, [0.001, -0.0005, 0.02])
    assert mounting.rotation.shape == (3, 3) and mounting.origin.shape == (3,)
    with pytest.raises(ValueError):
        mounting.rotation[0, 0] = 2.0


def test_an_empty_mounting_table_is_the_identity(experiment):
    device = load_device(with_table(experiment, "\n[mounting]\n"))
    assert np.array_equal(device.mounting.rotation, np.eye(3))
    assert np.array_equal(device.mounting.origin, np.zeros(3))


def test_a_mounting_round_trips(experiment, tmp_path):
    device = load_device(with_table(experiment, MOUNTING))
    write_device(tmp_path / "device.toml", device)
    assert load_device(tmp_path / "device.toml") == device
    turned = Mounting(rotation=random_rotation(np.random.default_rng(3)), origin=(0.1, 0.2, 0.3))
    device = dataclasses.replace(device, mounting=turned)
    write_device(tmp_path / "device.toml", device)
    assert load_device(tmp_path / "device.toml") == device


@pytest.mark.parametrize(
    "rotation, key, fault",
    [
        ("[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]]", "mounting.rotation",
         "must have determinant +1"),
        ("[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.1, 1.0]]", "mounting.rotation",
         "must be orthonormal"),
        ("[[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]", "mounting.rotation",
         "must be orthonormal"),
        ("[[1.0, 0.0, 1e-8], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]", "mounting.rotation",
         "must be orthonormal"),
        ("[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]", "mounting.rotation", "must have 3 rows"),
        ("[[1.0, 0.0], [0.0, 1.0]]", "mounting.rotation[1]", "must have 3 entries"),
        ("[1.0, 0.0, 0.0]", "mounting.rotation[1]", "must be an array"),
        ("[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, true]]", "mounting.rotation[3][3]",
         "must be a number"),
    ],
)
def test_a_rotation_that_is_no_rotation_is_one_line_naming_file_and_key(
    experiment, rotation, key, fault
):
    path = with_table(experiment, f"\n[mounting]\nrotation = {rotation}\n")
    with pytest.raises(InputError) as error:
        load_device(path)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {key}: {fault}"), message


def test_a_rotation_within_the_tolerance_is_accepted(experiment):
    """Rounded to 1e-10, a rotation is still one (the tolerance is 1e-9)."""
    c, s = round(float(np.cos(0.3)), 10), round(float(np.sin(0.3)), 10)
    rows = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    device = load_device(with_table(experiment, f"\n[mounting]\nrotation = {rows}\n"))
    assert device.mounting.rotation[0, 0] == c


def test_a_bad_origin_is_one_line(experiment):
    path = with_table(experiment, "\n[mounting]\norigin = [0.0, 0.0]\n")
    with pytest.raises(InputError, match=r"mounting\.origin: must have 3 entries"):
        load_device(path)


# --- virtual.toml [mounting] and the placed body ----------------------------------------------


def test_a_misalignment_loads_and_round_trips(experiment, tmp_path):
    path = with_table(experiment, "\n[mounting]\nmisalignment_deg = [0.5, 0.0, -0.2]\n",
                      "virtual.toml")
    virtual = load_virtual(path)
    assert virtual.mounting == VirtualMounting(misalignment_deg=(0.5, 0.0, -0.2))
    write_virtual(tmp_path / "virtual.toml", virtual)
    assert load_virtual(tmp_path / "virtual.toml") == virtual


def test_without_mountings_the_placed_body_is_the_virtual_body(default_device, default_virtual):
    assert placed_body(default_device, default_virtual) is default_virtual.body
    empty = dataclasses.replace(default_virtual, body=None)
    assert placed_body(default_device, empty) is None


def test_the_placed_body_is_the_stated_mounting_of_the_body(experiment):
    device = load_device(with_table(experiment, MOUNTING))
    virtual = load_virtual(experiment / "virtual.toml")
    body = placed_body(device, virtual)
    inertia, com = place_body(
        virtual.body.inertia, virtual.body.com, virtual.body.mass, QUARTER_TURN_X,
        device.mounting.origin,
    )
    assert body.mass == virtual.body.mass
    assert np.array_equal(body.inertia, inertia) and np.array_equal(body.com, com)
    # A quarter turn about x: the body's z is the rig's -y, its y the rig's z.
    b = virtual.body.com
    np.testing.assert_allclose(com, [b[0], -b[2], b[1]] + device.mounting.origin, atol=1e-18)


def test_a_misalignment_turns_the_placed_body_as_small_rotation_says(experiment):
    device = load_device(with_table(experiment, MOUNTING))
    virtual = load_virtual(experiment / "virtual.toml")
    angles = (0.5, -0.3, 0.2)
    misaligned = dataclasses.replace(virtual, mounting=VirtualMounting(misalignment_deg=angles))
    body = placed_body(device, misaligned)
    inertia, com = place_body(
        virtual.body.inertia, virtual.body.com, virtual.body.mass,
        small_rotation(angles) @ np.array(QUARTER_TURN_X), device.mounting.origin,
    )
    assert np.array_equal(body.inertia, inertia) and np.array_equal(body.com, com)
    stated = placed_body(device, virtual)
    # Half a degree moves a product of inertia by about (0.028 - 0.022) x 0.009 rad.
    assert np.abs(body.inertia - stated.inertia).max() > 1e-5
    # Without device.toml's table the misalignment turns the body's own axes.
    alone = placed_body(dataclasses.replace(device, mounting=None), misaligned)
    inertia, com = place_body(
        virtual.body.inertia, virtual.body.com, virtual.body.mass, small_rotation(angles),
        np.zeros(3),
    )
    assert np.array_equal(alone.inertia, inertia) and np.array_equal(alone.com, com)


# --- the virtual device runs the placed body ---------------------------------------------------


@pytest.mark.parametrize("stage", [1, 2])
def test_the_simulator_runs_the_placed_body(experiment, stage):
    """A mounted body brakes exactly as the same body given in rig axes without a mounting,
    and differently from the body unmounted: the free motion follows the placed inertia."""
    mounted = load_device(with_table(experiment, MOUNTING))
    virtual = load_virtual(experiment / "virtual.toml")
    on_rig = dataclasses.replace(virtual, body=placed_body(mounted, virtual))
    plain = dataclasses.replace(mounted, mounting=None)

    assert np.array_equal(
        vd.true_parameters(mounted, stage, virtual).vector,
        vd.true_parameters(plain, stage, on_rig).vector,
    )
    braking = vd.simulate_braking(mounted, stage, virtual)
    same = vd.simulate_braking(plain, stage, on_rig)
    assert np.array_equal(braking.log.phi, same.log.phi)
    assert np.array_equal(braking.truth.omega, same.truth.omega)
    unmounted = vd.simulate_braking(plain, stage, virtual)
    assert braking.truth.end_phi != unmounted.truth.end_phi


@pytest.fixture(scope="module")
def mounted_identification(tmp_path_factory):
    """(device, virtual, result): the default experiment with the body mounted a quarter
    turn about x, off the centre, identified from its ideal reverse (~10 s)."""
    root = create_default_experiment(tmp_path_factory.mktemp("mounted") / "exp")
    with_table(root, MOUNTING)
    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    result = identify(root)
    return load_device(root / "device.toml"), load_virtual(root / "virtual.toml"), result


def test_identify_measures_the_placed_body_in_rig_axes(mounted_identification):
    """Within 4 of identify's stds (tests/estimation/test_identify.py's bound), and not the
    body's own-axes entries."""
    device, virtual, result = mounted_identification
    truth = placed_body(device, virtual)
    err = result.entries - truth.inertia
    assert np.all(np.abs(err) <= 4.0 * result.entries_std), err / result.entries_std
    com_err = result.com - truth.com[:2]
    assert np.all(np.abs(com_err) <= 4.0 * result.com_std), com_err / result.com_std
    own = np.abs(result.entries - virtual.body.inertia) / result.entries_std
    assert own.max() > 100.0


@pytest.mark.parametrize("home, name, consumer", home_cases(HOMES), ids=str)
def test_every_truth_on_the_rig_comes_from_one_home(home, name, consumer):
    assert_calls_home(home, name, consumer)
