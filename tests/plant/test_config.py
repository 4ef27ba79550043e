"""device.toml, virtual.toml and reference.toml: the documented examples load, bad input is
one line, and whatever the writers write reads back equal."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import rsp_inertia.plant
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import (
    Body,
    Device,
    Encoder,
    Motor,
    Mounting,
    Pendulum,
    PlanGuess,
    Spring,
    Stage,
    TrueBody,
    load_device,
    load_reference,
    require_protocol,
    write_device,
    write_reference,
)
from rsp_inertia.plant.direction import Direction
from rsp_inertia.virtual.config import (
    ControllerSettings,
    Friction,
    LoggerSettings,
    Rig,
    RunSettings,
    Virtual,
    VirtualMounting,
    load_virtual,
    write_virtual,
)

# The example of docs/files.md: the paper's icosahedron design, two stages of three nodes.
DEVICE_TABLE = """\
[device]
name = "bench-A"
gravity = 9.80665            # m/s^2
"""

SPRING = """
[spring]                     # torsion element, reduced to phi
stiffness = 0.0              # N m/rad (0 = none)
zero_angle = 0.0             # rad
"""

MOTOR = """
[motor]                      # reduced to phi
torque_limit = 0.5           # N m, |u| <= this
torque_rate_limit = 20.0     # N m/s, |du/dt| <= this
"""

ENCODER = """
[encoder]
counts_per_rev = 65536
sample_rate = 1000.0         # Hz
"""

DEVICE_HEAD = DEVICE_TABLE + SPRING + MOTOR + ENCODER

STAGE_1 = """
[[stage]]
gear_ratio = 0.7639320225    # lambda = tan(beta); 0 = outer frame locked
tare_inertia = 0.0           # M_tare(lambda), kg m^2, reduced to phi
nodes_deg = [0.0, 120.0, 240.0]
launch_speed = 6.0           # rad/s at the release
braking_torque = 0.005       # N m against the motion, braking pass
"""

STAGE_2 = """
[[stage]]
gear_ratio = 5.2360679775
tare_inertia = 0.0
nodes_deg = [60.0, 180.0, 300.0]
launch_speed = 2.5
braking_torque = 0.07
"""

DEVICE_BODY = """
[body]                       # optional
mass = 4.0                   # kg; with it, identify reports the centre of mass
"""

DEVICE_TOML = DEVICE_HEAD + STAGE_1 + STAGE_2 + DEVICE_BODY

SAMPLE_RATE = "sample_rate = 1000.0         # Hz\n"

CERTIFICATE = """\
error_cos = [2.0e-5, -5.0e-6]   # rad: e = sum c_n cos(n phi) + s_n sin(n phi)
error_sin = [1.5e-5, 3.0e-6]
error_std = [2.0e-6, 1.0e-6]
"""
"""The [encoder] keys of a maker's certificate of the reading error, orders 1 and 2."""

VIRTUAL_TOML = """\
[body]
mass = 4.0
inertia = [0.05, 0.06, 0.07, 0.002, -0.001, 0.003]   # Jx, Jy, Jz, Jxy, Jyz, Jxz
com = [0.001, -0.002, 0.01]

[friction]
coulomb = 1.0e-4
viscous = 1.0e-4
quadratic = 1.0e-3

[run]
release_angle_deg = -30.0
torque_noise = 1.0e-4
seed = 7

[controller]
speed_observer_bandwidth = 150
"""


def write(tmp_path, name, text):
    """Write a file for a test.

    Parameters
    ----------
    tmp_path : Path
        The test's folder.
    name : str
        The file's name in it.
    text : str
        Its text.

    Returns
    -------
    Path
        The file.
    """
    path = tmp_path / name
    path.write_text(text)
    return path


def edited(text, old, new):
    """An example with one change.

    Parameters
    ----------
    text : str
        The example.
    old, new : str
        The text to replace (it must be in the example) and its replacement.

    Returns
    -------
    str
        ``text`` with its first ``old`` replaced by ``new``.
    """
    assert old in text, f"test setup: {old!r} not in the example"
    return text.replace(old, new, 1)


def test_example_device_loads(tmp_path):
    device = load_device(write(tmp_path, "device.toml", DEVICE_TOML))
    assert device.name == "bench-A"
    assert device.gravity == 9.80665
    assert (device.spring.stiffness, device.spring.zero_angle) == (0.0, 0.0)
    assert (device.motor.torque_limit, device.motor.torque_rate_limit) == (0.5, 20.0)
    assert device.encoder.counts_per_rev == 65536
    assert isinstance(device.encoder.counts_per_rev, int)
    assert device.encoder.quantum == 2 * math.pi / 65536
    assert device.encoder.dt == 1e-3
    assert [s.gear_ratio for s in device.stages] == [0.7639320225, 5.2360679775]
    # The icosahedron gear ratios are 3 -+ sqrt 5 (docs/method.md §5).
    assert device.stages[0].gear_ratio == pytest.approx(3 - math.sqrt(5), abs=1e-10)
    assert device.stages[1].gear_ratio == pytest.approx(3 + math.sqrt(5), abs=1e-10)
    assert device.stages[0].nodes_deg == (0.0, 120.0, 240.0)
    np.testing.assert_allclose(device.stages[1].nodes, np.radians([60, 180, 300]))
    assert (device.stages[1].launch_speed, device.stages[1].braking_torque) == (2.5, 0.07)
    assert device.body is not None and device.body.mass == 4.0
    assert device.n_axes == 6


def test_optional_tables_and_keys_take_their_defaults(tmp_path):
    table = edited(DEVICE_TABLE, "gravity = 9.80665", "")
    stage = edited(STAGE_1, "tare_inertia = 0.0", "")
    text = table + MOTOR + ENCODER + stage + STAGE_2
    device = load_device(write(tmp_path, "device.toml", text))
    assert device.gravity == 9.80665
    assert (device.spring.stiffness, device.spring.zero_angle) == (0.0, 0.0)
    assert device.stages[0].tare_inertia == 0.0
    assert device.body is None


def test_integers_are_accepted_as_floats(tmp_path):
    text = edited(DEVICE_TOML, "sample_rate = 1000.0", "sample_rate = 1000")
    device = load_device(write(tmp_path, "device.toml", text))
    assert device.encoder.sample_rate == 1000.0
    assert isinstance(device.encoder.sample_rate, float)


def test_cone_plus_z_design_has_six_axes(tmp_path):
    # Five nodes on one cone and a lambda = 0 stage (docs/method.md §5). The z stage gives one
    # axis whatever its nodes, and a second z stage adds none.
    cone = edited(STAGE_1, "[0.0, 120.0, 240.0]", "[0.0, 72.0, 144.0, 216.0, 288.0]")
    z_axis = edited(STAGE_2, "gear_ratio = 5.2360679775", "gear_ratio = 0.0")
    device = load_device(write(tmp_path, "device.toml", DEVICE_HEAD + cone + z_axis + z_axis))
    assert device.n_axes == 6


def test_example_virtual_loads(tmp_path):
    virtual = load_virtual(write(tmp_path, "virtual.toml", VIRTUAL_TOML))
    body = virtual.body
    assert body.mass == 4.0
    np.testing.assert_array_equal(body.inertia, [0.05, 0.06, 0.07, 0.002, -0.001, 0.003])
    np.testing.assert_array_equal(body.com, [0.001, -0.002, 0.01])
    assert body.inertia.shape == (6,) and body.com.shape == (3,)
    assert not body.inertia.flags.writeable and not body.com.flags.writeable
    np.testing.assert_array_equal(
        body.tensor, [[0.05, 0.002, 0.003], [0.002, 0.06, -0.001], [0.003, -0.001, 0.07]]
    )
    assert (virtual.friction.coulomb, virtual.friction.viscous) == (1e-4, 1e-4)
    assert virtual.friction.quadratic == 1e-3
    assert virtual.run == RunSettings(release_angle_deg=-30.0, torque_noise=1e-4, seed=7)
    assert virtual.controller == ControllerSettings(speed_observer_bandwidth=150.0)


def test_virtual_run_and_controller_are_optional(tmp_path):
    virtual = load_virtual(write(tmp_path, "virtual.toml", VIRTUAL_TOML.partition("[run]")[0]))
    assert virtual.run == RunSettings()
    assert virtual.controller == ControllerSettings()


def test_true_body_built_in_code_is_read_only():
    body = TrueBody(mass=1.0, inertia=[1, 2, 2, 0, 0, 0], com=[0, 0, 0])
    assert body.inertia.dtype == float and not body.inertia.flags.writeable
    with pytest.raises(ValueError):
        body.com[0] = 1.0


def assert_one_line(error, *parts):
    message = str(error.value)
    assert "\n" not in message
    for part in parts:
        assert part in message, f"{part!r} not in {message!r}"


# Each case edits the example: old text -> new text; the message must name the key and the fault.
DEVICE_FAULTS = [
    pytest.param("torque_limit = 0.5", "", "motor.torque_limit", "missing", id="missing key"),
    pytest.param(
        "sample_rate = 1000.0",
        'sample_rate = "fast"',
        "encoder.sample_rate",
        "must be a number",
        id="wrong type",
    ),
    pytest.param(
        "gravity = 9.80665",
        "gravity = true",
        "device.gravity",
        "must be a number",
        id="boolean is no number",
    ),
    pytest.param(
        "gear_ratio = 5.2360679775",
        "gear_ratio = -0.5",
        "stage[2].gear_ratio",
        "must be >= 0, got -0.5",
        id="gear ratio < 0",
    ),
    pytest.param(
        "[60.0, 180.0, 300.0]",
        "[60.0, 180.0, 360.0]",
        "stage[2].nodes_deg[3]",
        "[0, 360)",
        id="node at 360",
    ),
    pytest.param(
        "[0.0, 120.0, 240.0]",
        "[-1.0, 120.0, 240.0]",
        "stage[1].nodes_deg[1]",
        "[0, 360)",
        id="node at -1",
    ),
    pytest.param(
        "[0.0, 120.0, 240.0]",
        "[0.0, 120.0, 0.0]",
        "stage[1].nodes_deg",
        "duplicate",
        id="duplicate node",
    ),
    pytest.param(
        STAGE_2,
        "",
        "stage",
        "3 distinct axes, 6 are needed",
        id="one stage of 3 nodes",
    ),
    pytest.param(
        "gear_ratio = 5.2360679775",
        "gear_ratio = 0.0",
        "stage",
        "4 distinct axes, 6 are needed",
        id="z stage gives one axis",
    ),
    pytest.param(
        "counts_per_rev = 65536",
        "counts_per_rev = 65536.0",
        "encoder.counts_per_rev",
        "must be an integer, got 65536.0",
        id="non-integer counts",
    ),
    pytest.param(
        "launch_speed = 2.5",
        "launch_sped = 2.5",
        "stage[2].launch_sped",
        "unknown key",
        id="unknown key",
    ),
    pytest.param(
        "braking_torque = 0.07",
        "braking_torque = 0.6",
        "stage[2].braking_torque",
        "must be <= motor.torque_limit = 0.5 (the motor applies it), got 0.6",
        id="braking beyond the motor",
    ),
    pytest.param("[spring]", "[sprng]", "sprng", "unknown table", id="unknown table"),
    pytest.param(
        ENCODER,
        "",
        "encoder",
        "missing required table",
        id="missing table",
    ),
    pytest.param("[motor]", "[motor", "line", "invalid TOML", id="bad TOML syntax"),
    # The encoder's certificate: sine and cosine coefficients of each order come in pairs.
    pytest.param(
        SAMPLE_RATE,
        SAMPLE_RATE + "error_sin = [1.5e-5]\n",
        "encoder.error_sin",
        "needs encoder.error_cos",
        id="error_sin without error_cos",
    ),
    pytest.param(
        SAMPLE_RATE,
        SAMPLE_RATE + "error_cos = [2.0e-5]\n",
        "encoder.error_sin",
        "missing: encoder.error_cos needs it",
        id="error_cos without error_sin",
    ),
    pytest.param(
        SAMPLE_RATE,
        SAMPLE_RATE + "error_std = [2.0e-6]\n",
        "encoder.error_std",
        "needs encoder.error_cos",
        id="error_std without error_cos",
    ),
    pytest.param(
        SAMPLE_RATE,
        SAMPLE_RATE + CERTIFICATE.replace("[2.0e-6, 1.0e-6]", "[2.0e-6]"),
        "encoder.error_std",
        "one entry per order of encoder.error_cos (2), got 1",
        id="error_std of another length",
    ),
    pytest.param(
        SAMPLE_RATE,
        SAMPLE_RATE + CERTIFICATE.replace("[1.5e-5, 3.0e-6]", "[1.5e-5, 3.0e-6, 0.0]"),
        "encoder.error_sin",
        "one entry per order of encoder.error_cos (2), got 3",
        id="error_sin of another length",
    ),
    pytest.param(
        SAMPLE_RATE,
        SAMPLE_RATE + CERTIFICATE.replace("[2.0e-6, 1.0e-6]", "[2.0e-6, -1.0e-6]"),
        "encoder.error_std[2]",
        "must be >= 0, got -1e-06",
        id="negative error_std",
    ),
]


@pytest.mark.parametrize("old, new, key, fault", DEVICE_FAULTS)
def test_bad_device_is_one_line_naming_file_and_key(tmp_path, old, new, key, fault):
    path = write(tmp_path, "device.toml", edited(DEVICE_TOML, old, new))
    with pytest.raises(InputError) as error:
        load_device(path)
    assert_one_line(error, str(path), key, fault)


def test_a_stage_may_leave_its_protocol_to_plan_which_the_other_commands_need(tmp_path):
    """launch_speed and braking_torque are what plan chooses: a device.toml without them
    loads (None), and require_protocol names the first stage and key missing, and plan."""
    text = edited(DEVICE_TOML, "braking_torque = 0.07\n", "")
    path = write(tmp_path, "device.toml", edited(text, "launch_speed = 6.0 ", "# no speed "))
    device = load_device(path)
    assert [(st.launch_speed, st.braking_torque) for st in device.stages] == [
        (None, 0.005),
        (2.5, None),
    ]
    with pytest.raises(InputError) as error:
        require_protocol(device, path)
    assert_one_line(error, f"{path}: stage[1].launch_speed: missing", f"rsp-inertia plan {tmp_path}")
    stated = dataclasses.replace(device.stages[0], launch_speed=6.0)
    with pytest.raises(InputError) as error:
        require_protocol(dataclasses.replace(device, stages=(stated, device.stages[1])), path)
    assert_one_line(error, "stage[2].braking_torque: missing")
    require_protocol(load_device(write(tmp_path, "full.toml", DEVICE_TOML)), path)


VIRTUAL_FAULTS = [
    pytest.param(
        "[0.05, 0.06,",
        "[0.05, -0.01,",
        "body.inertia",
        "Jy must be > 0, got -0.01",
        id="negative inertia",
    ),
    pytest.param(
        "[0.05, 0.06, 0.07, 0.002, -0.001, 0.003]",
        "[1, 1, 3, 0, 0, 0]",
        "body.inertia",
        "not a physical inertia tensor: principal moments [1, 1, 3]",
        id="triangle inequality",
    ),
    pytest.param(
        "0.002, -0.001, 0.003]",
        "0.06, 0, 0]",
        "body.inertia",
        "not a physical inertia tensor",
        id="not positive definite",
    ),
    pytest.param(
        "0.002, -0.001, 0.003]",
        "0.002, -0.001]",
        "body.inertia",
        "must have 6 entries",
        id="inertia of 5",
    ),
    pytest.param(
        "[0.001, -0.002, 0.01]",
        "[0.001, -0.002]",
        "body.com",
        "must have 3 entries",
        id="com of 2",
    ),
    pytest.param("viscous = 1.0e-4", "", "friction.viscous", "missing", id="missing friction"),
    pytest.param("seed = 7", "seed = -1", "run.seed", "must be >= 0", id="negative seed"),
    pytest.param(
        "bandwidth = 150",
        "bandwidth = 0",
        "controller.speed_observer_bandwidth",
        "must be > 0",
        id="zero bandwidth",
    ),
    pytest.param(
        "bandwidth = 150",
        "bandwidth = 150\n[logger]\ntime_jitter = 0.3",
        "logger.time_jitter",
        "must be <= 0.25",
        id="jitter beyond the logs' limit",
    ),
    pytest.param(
        "bandwidth = 150",
        "bandwidth = 150\n[logger]\ndropped_fraction = 0.5",
        "logger.dropped_fraction",
        "must be < 0.5",
        id="half the rows dropped",
    ),
    pytest.param(
        "bandwidth = 150",
        "bandwidth = 150\n[logger]\ncounts = 1",
        "logger.counts",
        "must be a boolean",
        id="counts not a boolean",
    ),
]


def test_logger_settings_are_read(tmp_path):
    text = VIRTUAL_TOML + "\n[logger]\ntime_jitter = 0.2\ndropped_fraction = 0.001\ncounts = true\n"
    logger = load_virtual(write(tmp_path, "virtual.toml", text)).logger
    assert (logger.time_jitter, logger.dropped_fraction, logger.counts) == (0.2, 0.001, True)
    assert load_virtual(write(tmp_path, "v.toml", VIRTUAL_TOML)).logger.time_jitter == 0.0


@pytest.mark.parametrize("old, new, key, fault", VIRTUAL_FAULTS)
def test_bad_virtual_is_one_line_naming_file_and_key(tmp_path, old, new, key, fault):
    path = write(tmp_path, "virtual.toml", edited(VIRTUAL_TOML, old, new))
    with pytest.raises(InputError) as error:
        load_virtual(path)
    assert_one_line(error, str(path), key, fault)


@pytest.mark.parametrize("load", [load_device, load_virtual])
def test_missing_file_is_one_line_naming_it(tmp_path, load):
    path = tmp_path / "absent.toml"
    with pytest.raises(InputError) as error:
        load(path)
    assert_one_line(error, str(path), "not found")


# --- directions of a stage; the rig's imperfections in virtual.toml -------------------------

STAGE_1_END = "braking_torque = 0.005       # N m against the motion, braking pass\n"


def test_stage_directions_default_to_forward_and_may_list_both(tmp_path):
    device = load_device(write(tmp_path, "device.toml", DEVICE_TOML))
    assert [st.directions for st in device.stages] == [("forward",), ("forward",)]
    both = edited(DEVICE_TOML, STAGE_1_END, STAGE_1_END + 'directions = ["forward", "backward"]\n')
    device = load_device(write(tmp_path, "device.toml", both))
    assert device.stages[0].directions == (Direction.FORWARD, Direction.BACKWARD)
    assert all(type(direction) is Direction for direction in device.stages[0].directions)
    back = edited(DEVICE_TOML, STAGE_1_END, STAGE_1_END + 'directions = ["backward"]\n')
    assert load_device(write(tmp_path, "device.toml", back)).stages[0].directions == ("backward",)


@pytest.mark.parametrize(
    "value, key, fault",
    [
        pytest.param('["sideways"]', "stage[1].directions[1]", "must be one of", id="unknown"),
        pytest.param('["forward", 1]', "stage[1].directions[2]", "must be a string", id="number"),
        pytest.param("[]", "stage[1].directions", "at least one", id="empty"),
        pytest.param('"forward"', "stage[1].directions", "must be an array", id="not an array"),
        pytest.param(
            '["backward", "backward"]',
            "stage[1].directions",
            "duplicate direction 'backward'",
            id="duplicate",
        ),
    ],
)
def test_bad_stage_directions_are_one_line(tmp_path, value, key, fault):
    text = edited(DEVICE_TOML, STAGE_1_END, STAGE_1_END + f"directions = {value}\n")
    path = write(tmp_path, "device.toml", text)
    with pytest.raises(InputError) as error:
        load_device(path)
    assert_one_line(error, f"{path}: {key}", fault)


FIXTURE = """
[fixture]
mass = 0.5
inertia = [0.004, 0.005, 0.008, 0.0002, 0.0001, -0.0003]
com = [0.01, 0.0, 0.0]
"""

RIG = """
[rig]
torque_gain = 1.02
tare_inertia = [0.004, 0.085]
"""

TRANSMISSION = """\
efficiency_driving = 0.95
efficiency_backdriven = 0.9
"""
"""[rig] keys of a transmission that loses power by the direction of its flow."""

ENCODER_ERROR = """\
encoder_error_amplitude = [2.0e-4, 5.0e-5]   # rad, e = sum A_n sin(n phi + p_n)
encoder_error_phase_deg = [30.0, -60.0]
"""
"""[rig] keys of an encoder that reads phi + e(phi), orders 1 and 2."""


def test_the_rigs_imperfections_load(tmp_path):
    text = edited(
        VIRTUAL_TOML, "quadratic = 1.0e-3\n", "quadratic = 1.0e-3\nbackward_scale = 1.2\n"
    )
    virtual = load_virtual(write(tmp_path, "virtual.toml", text + FIXTURE + RIG))
    assert virtual.fixture.mass == 0.5
    np.testing.assert_array_equal(virtual.fixture.com, [0.01, 0.0, 0.0])
    assert virtual.rig == Rig(torque_gain=1.02, tare_inertia=(0.004, 0.085))
    assert virtual.friction.backward_scale == 1.2
    assert virtual.friction_for(1) is virtual.friction
    backward = virtual.friction_for(-1)
    assert (backward.coulomb, backward.viscous, backward.quadratic) == (
        1e-4 * 1.2,
        1e-4 * 1.2,
        1e-3 * 1.2,
    )


def test_the_rig_tables_default_to_an_exact_symmetric_rig(tmp_path):
    virtual = load_virtual(write(tmp_path, "virtual.toml", VIRTUAL_TOML))
    assert virtual.fixture is None and virtual.friction_backward is None
    assert virtual.rig == Rig() and virtual.rig.torque_gain == 1.0
    assert virtual.friction.backward_scale == 1.0
    assert virtual.friction_for(-1) == virtual.friction_for(1) == virtual.friction
    # A lossless transmission and an exact encoder.
    assert virtual.rig.drive_gains == (1.0, 1.0)
    assert virtual.rig.encoder_error.size == 0
    encoder = load_device(write(tmp_path, "device.toml", DEVICE_TOML)).encoder
    assert (encoder.error_cos, encoder.error_sin, encoder.error_std) == (None, None, None)
    assert encoder.error.size == 0


def test_the_rigs_transducers_load(tmp_path):
    rig = load_virtual(
        write(tmp_path, "virtual.toml", VIRTUAL_TOML + RIG + TRANSMISSION + ENCODER_ERROR)
    ).rig
    assert (rig.efficiency_driving, rig.efficiency_backdriven) == (0.95, 0.9)
    assert rig.encoder_error_amplitude == (2e-4, 5e-5)
    assert rig.encoder_error_phase_deg == (30.0, -60.0)
    # h_d = eta_d / gain, h_b = 1 / (eta_b gain): received per unit of logged torque.
    assert rig.drive_gains == (0.95 / 1.02, 1 / (0.9 * 1.02))
    # theta_e = [c_1, s_1, c_2, s_2] of e = sum A_n sin(n phi + p_n): c = A sin p, s = A cos p.
    p = np.radians([30.0, -60.0])
    np.testing.assert_allclose(
        rig.encoder_error,
        [2e-4 * np.sin(p[0]), 2e-4 * np.cos(p[0]), 5e-5 * np.sin(p[1]), 5e-5 * np.cos(p[1])],
        rtol=1e-15,
    )


def test_an_encoder_certificate_loads(tmp_path):
    text = edited(DEVICE_TOML, SAMPLE_RATE, SAMPLE_RATE + CERTIFICATE)
    encoder = load_device(write(tmp_path, "device.toml", text)).encoder
    assert (encoder.error_cos, encoder.error_sin) == ((2e-5, -5e-6), (1.5e-5, 3e-6))
    assert encoder.error_std == (2e-6, 1e-6)
    # theta_e interleaves the orders: [c_1, s_1, c_2, s_2].
    np.testing.assert_array_equal(encoder.error, [2e-5, 1.5e-5, -5e-6, 3e-6])
    # The standard deviation may be left out (the stated error is then exact).
    exact = edited(text, "error_std = [2.0e-6, 1.0e-6]\n", "")
    assert load_device(write(tmp_path, "device.toml", exact)).encoder.error_std is None


def test_friction_backward_table_sets_the_backward_coefficients(tmp_path):
    table = "\n[friction_backward]\ncoulomb = 2.0e-4\nviscous = 3.0e-4\nquadratic = 4.0e-3\n"
    virtual = load_virtual(write(tmp_path, "virtual.toml", VIRTUAL_TOML + table))
    assert virtual.friction_for(-1) == Friction(coulomb=2e-4, viscous=3e-4, quadratic=4e-3)
    assert virtual.friction_for(1) == virtual.friction


def test_an_empty_fixture_run_has_no_body(tmp_path):
    text = VIRTUAL_TOML.partition("[friction]")
    virtual = load_virtual(write(tmp_path, "virtual.toml", text[1] + text[2] + FIXTURE))
    assert virtual.body is None and virtual.fixture is not None


BACKWARD_TABLE = "\n[friction_backward]\ncoulomb = 2.0e-4\nviscous = 3.0e-4\nquadratic = 4.0e-3\n"

RIG_FAULTS = [
    pytest.param(
        RIG.replace("torque_gain", "torque_gian"), "rig.torque_gian", "unknown key", id="typo"
    ),
    pytest.param(RIG.replace("1.02", "0.0"), "rig.torque_gain", "must be > 0", id="zero gain"),
    pytest.param(
        RIG.replace("0.004, 0.085", "0.004, -0.085"),
        "rig.tare_inertia[2]",
        "must be >= 0, got -0.085",
        id="negative tare",
    ),
    pytest.param(
        RIG.replace("[0.004, 0.085]", "0.004"),
        "rig.tare_inertia",
        "must be an array",
        id="tare not a list",
    ),
    pytest.param(
        FIXTURE.replace("0.004, 0.005, 0.008", "0.001, 0.001, 0.008"),
        "fixture.inertia",
        "not a physical inertia tensor",
        id="unphysical fixture",
    ),
    pytest.param(
        FIXTURE.replace("mass = 0.5\n", ""), "fixture.mass", "missing", id="fixture without mass"
    ),
    pytest.param(
        BACKWARD_TABLE.replace("viscous = 3.0e-4\n", ""),
        "friction_backward.viscous",
        "missing",
        id="incomplete backward friction",
    ),
    pytest.param(
        BACKWARD_TABLE.replace("coulomb", "coulomd"),
        "friction_backward.coulomd",
        "unknown key",
        id="unknown backward friction key",
    ),
    pytest.param("\n[rigg]\ntorque_gain = 1.0\n", "rigg", "unknown table", id="unknown table"),
    # An efficiency is a fraction of the power passed on: in (0, 1].
    pytest.param(
        RIG + "efficiency_driving = 0\n",
        "rig.efficiency_driving",
        "must be > 0, got 0.0",
        id="zero efficiency",
    ),
    pytest.param(
        RIG + "efficiency_backdriven = 1.5\n",
        "rig.efficiency_backdriven",
        "must be <= 1, got 1.5",
        id="efficiency above 1",
    ),
    pytest.param(
        RIG + "efficiency_driving = -0.1\n",
        "rig.efficiency_driving",
        "must be > 0, got -0.1",
        id="negative efficiency",
    ),
    pytest.param(
        RIG + "efficiency_driving = 1.5\n",
        "rig.efficiency_driving",
        "must be <= 1, got 1.5",
        id="driving efficiency above 1",
    ),
    pytest.param(
        RIG + "efficiency_backdriven = 0.0\n",
        "rig.efficiency_backdriven",
        "must be > 0, got 0.0",
        id="zero back-driven efficiency",
    ),
    # The encoder's error curve: one phase per amplitude, amplitudes >= 0.
    pytest.param(
        RIG + "encoder_error_amplitude = [2.0e-4, 5.0e-5]\n",
        "rig.encoder_error_phase_deg",
        "one entry per order of rig.encoder_error_amplitude (2), got 0",
        id="amplitude without phase",
    ),
    pytest.param(
        RIG + "encoder_error_phase_deg = [30.0, -60.0]\n",
        "rig.encoder_error_phase_deg",
        "one entry per order of rig.encoder_error_amplitude (0), got 2",
        id="phase without amplitude",
    ),
    pytest.param(
        RIG + ENCODER_ERROR.replace("[30.0, -60.0]", "[30.0, -60.0, 110.0]"),
        "rig.encoder_error_phase_deg",
        "one entry per order of rig.encoder_error_amplitude (2), got 3",
        id="phase of another length",
    ),
    pytest.param(
        RIG + ENCODER_ERROR.replace("[2.0e-4, 5.0e-5]", "[2.0e-4, -5.0e-5]"),
        "rig.encoder_error_amplitude[2]",
        "must be >= 0, got -5e-05",
        id="negative amplitude",
    ),
    # The conventions a rig may be built against (docs/method.md §1).
    pytest.param(
        RIG + 'gear_reversed = "yes"\n',
        "rig.gear_reversed",
        "must be a boolean, got a string ('yes')",
        id="gear sense not a boolean",
    ),
    pytest.param(
        RIG + "phi_left_handed = 1\n",
        "rig.phi_left_handed",
        "must be a boolean",
        id="handedness not a boolean",
    ),
    pytest.param(
        RIG + 'encoder_zero_deg = "3"\n',
        "rig.encoder_zero_deg",
        "must be a number, got a string ('3')",
        id="zero offset not a number",
    ),
]


@pytest.mark.parametrize("added, key, fault", RIG_FAULTS)
def test_bad_rig_tables_are_one_line_naming_file_and_key(tmp_path, added, key, fault):
    path = write(tmp_path, "virtual.toml", VIRTUAL_TOML + added)
    with pytest.raises(InputError) as error:
        load_virtual(path)
    assert_one_line(error, f"{path}: {key}", fault)


@pytest.mark.parametrize("scale, fault", [("2.0", "not both"), ("-1.0", "must be >= 0")])
def test_backward_scale_is_checked(tmp_path, scale, fault):
    text = edited(
        VIRTUAL_TOML, "quadratic = 1.0e-3\n", f"quadratic = 1.0e-3\nbackward_scale = {scale}\n"
    )
    path = write(tmp_path, "virtual.toml", text + (BACKWARD_TABLE if fault == "not both" else ""))
    with pytest.raises(InputError) as error:
        load_virtual(path)
    key = "friction_backward" if fault == "not both" else "friction.backward_scale"
    assert_one_line(error, f"{path}: {key}", fault)


def test_a_tare_list_of_the_wrong_length_names_the_virtual_file(tmp_path):
    device = load_device(write(tmp_path, "device.toml", DEVICE_TOML))
    path = write(tmp_path, "virtual.toml", VIRTUAL_TOML + RIG.replace("0.085]", "0.085, 0.1]"))
    rig = load_virtual(path).rig  # the length is checked where the device is known
    with pytest.raises(InputError) as error:
        rig.true_tare(device, 1, source=str(path))
    assert_one_line(error, f"{path}: rig.tare_inertia", "one entry per [[stage]]", "(2), got 3")
    good = load_virtual(write(tmp_path, "virtual.toml", VIRTUAL_TOML + RIG)).rig
    assert (good.true_tare(device, 1), good.true_tare(device, 2)) == (0.004, 0.085)
    assert Rig().true_tare(device, 2) == device.stages[1].tare_inertia


def test_stage_release_angle_is_optional(tmp_path):
    device = load_device(write(tmp_path, "device.toml", DEVICE_TOML))
    assert [st.release_angle_deg for st in device.stages] == [None, None]
    stated = edited(DEVICE_TOML, STAGE_1_END, STAGE_1_END + "release_angle_deg = -45\n")
    assert load_device(write(tmp_path, "device.toml", stated)).stages[0].release_angle_deg == -45.0
    wrong = edited(DEVICE_TOML, STAGE_1_END, STAGE_1_END + 'release_angle_deg = "early"\n')
    with pytest.raises(InputError, match=r"stage\[1\]\.release_angle_deg: must be a number"):
        load_device(write(tmp_path, "device.toml", wrong))


# --- writing: every file reads back equal -----------------------------------------------------

DEFAULTS = Path(rsp_inertia.plant.__file__).parent / "defaults"
DEFAULT_DEVICES = sorted(DEFAULTS.rglob("device.toml"))
DEFAULT_VIRTUALS = sorted(DEFAULTS.rglob("virtual.toml"))


def test_every_default_file_is_found():
    assert len(DEFAULT_DEVICES) == len(DEFAULT_VIRTUALS) == 4
    assert (DEFAULTS / "rig" / "reference" / "reference.toml").exists()


@pytest.mark.parametrize("source", DEFAULT_DEVICES, ids=lambda p: str(p.relative_to(DEFAULTS)))
def test_default_devices_round_trip(tmp_path, source):
    device = load_device(source)
    write_device(tmp_path / "device.toml", device)
    assert load_device(tmp_path / "device.toml") == device


@pytest.mark.parametrize("source", DEFAULT_VIRTUALS, ids=lambda p: str(p.relative_to(DEFAULTS)))
def test_default_virtuals_round_trip(tmp_path, source):
    virtual = load_virtual(source)
    write_virtual(tmp_path / "virtual.toml", virtual)
    assert load_virtual(tmp_path / "virtual.toml") == virtual


def test_reference_round_trips(tmp_path):
    reference = load_reference(DEFAULTS / "rig" / "reference" / "reference.toml")
    write_reference(tmp_path / "reference.toml", reference)
    assert load_reference(tmp_path / "reference.toml") == reference


EVERY_DEVICE_KEY = (
    DEVICE_TOML.replace(
        "torque_rate_limit = 20.0     # N m/s, |du/dt| <= this\n",
        "torque_rate_limit = 20.0\ntorque_gain_std = 0.002\n",
    )
    .replace(SAMPLE_RATE, "sample_rate = 1000.0\ncounter_bits = 32\n" + CERTIFICATE)
    .replace(
        STAGE_1_END,
        STAGE_1_END + 'directions = ["backward", "forward"]\ntare_inertia_std = 4e-5\n'
        "release_angle_deg = -45.5\n",
    )
) + """
[pendulum]
stiffness = 2.0
stiffness_std = 0.004
amplitude_deg = 4.0
duration = 20.0

[plan]
box = [0.2, 0.1, 0.05]
friction = [1e-4, 1e-4, 1e-3]
com_offset = 0.003
torque_noise = 1e-4
max_duration = 120.0

[mounting]
rotation = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]
origin = [0.0, 0.01, -0.02]
"""

EVERY_VIRTUAL_KEY = VIRTUAL_TOML + FIXTURE + RIG + "pendulum_stiffness = 2.01\n" + (
    TRANSMISSION + ENCODER_ERROR
) + (
    "\n[logger]\ntime_jitter = 0.1\ndropped_fraction = 0.001\ncounts = true\n"
) + BACKWARD_TABLE + "\n[mounting]\nmisalignment_deg = [0.5, -0.25, 0.0]\n"


def test_every_optional_key_round_trips(tmp_path):
    device = load_device(write(tmp_path, "in-device.toml", EVERY_DEVICE_KEY))
    assert None not in (
        device.motor.torque_gain_std, device.encoder.counter_bits, device.plan, device.mounting
    )
    encoder = device.encoder
    assert None not in (encoder.error_cos, encoder.error_sin, encoder.error_std)
    write_device(tmp_path / "device.toml", device)
    assert load_device(tmp_path / "device.toml") == device
    inertia = dataclasses.replace(device.plan, box=None, inertia=(0.02, 0.025, 0.03))
    device = dataclasses.replace(device, body=None, plan=inertia)
    write_device(tmp_path / "device.toml", device)
    assert load_device(tmp_path / "device.toml") == device

    virtual = load_virtual(write(tmp_path, "in-virtual.toml", EVERY_VIRTUAL_KEY))
    assert None not in (
        virtual.fixture, virtual.friction_backward, virtual.rig.tare_inertia, virtual.mounting
    )
    assert virtual.logger.counts and virtual.rig.pendulum_stiffness == 2.01
    assert (virtual.rig.efficiency_driving, virtual.rig.efficiency_backdriven) == (0.95, 0.9)
    assert virtual.rig.encoder_error.size == 4
    write_virtual(tmp_path / "virtual.toml", virtual)
    assert load_virtual(tmp_path / "virtual.toml") == virtual


def test_a_variation_is_a_replaced_field_written_back(tmp_path):
    """What the benchmarks do: load, change a field with dataclasses.replace, write."""
    path = write(tmp_path, "device.toml", DEVICE_TOML)
    device = load_device(path)
    encoder = dataclasses.replace(device.encoder, counts_per_rev=4096)
    write_device(path, dataclasses.replace(device, encoder=encoder))
    assert load_device(path).encoder.counts_per_rev == 4096
    assert dataclasses.replace(load_device(path), encoder=device.encoder) == device

    path = write(tmp_path, "virtual.toml", VIRTUAL_TOML)
    virtual = load_virtual(path)
    friction = virtual.friction
    scaled = dataclasses.replace(
        friction, coulomb=2 * friction.coulomb, viscous=2 * friction.viscous
    )
    body = dataclasses.replace(virtual.body, com=[0.0, 0.0, 0.02])
    changed = dataclasses.replace(
        virtual,
        friction=scaled,
        body=body,
        run=dataclasses.replace(virtual.run, seed=12),
        logger=dataclasses.replace(virtual.logger, time_jitter=0.2),
        rig=Rig(torque_gain=1.01, tare_inertia=(0.004, 0.085)),
    )
    write_virtual(path, changed)
    assert load_virtual(path) == changed
    assert load_virtual(path) != virtual


def test_written_files_are_deterministic_and_commented_with_units(tmp_path):
    device = load_device(DEFAULTS / "device.toml")
    write_device(tmp_path / "a.toml", device)
    write_device(tmp_path / "b.toml", load_device(tmp_path / "a.toml"))
    text = (tmp_path / "a.toml").read_text()
    assert text == (tmp_path / "b.toml").read_text()
    assert "gravity = 9.80665  # m/s^2\n" in text
    assert "counter_bits" not in text and "[plan]" not in text  # None is not written
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.toml", "b.toml"]


def test_writing_what_the_loader_refuses_raises_and_writes_nothing(tmp_path):
    path = write(tmp_path, "device.toml", DEVICE_TOML)
    device = load_device(path)
    bad = [
        (
            dataclasses.replace(
                device, encoder=dataclasses.replace(device.encoder, counts_per_rev=0)
            ),
            "encoder.counts_per_rev: must be > 0, got 0",
        ),
        (dataclasses.replace(device, stages=device.stages[:1]), "3 distinct axes, 6 are needed"),
        (
            dataclasses.replace(
                device, stages=(dataclasses.replace(device.stages[0], nodes_deg=(0.0, 360.0)),)
            ),
            "stage[1].nodes_deg[2]: must be in [0, 360), got 360.0",
        ),
        (
            dataclasses.replace(
                device, encoder=dataclasses.replace(device.encoder, error_sin=(1e-5,))
            ),
            "encoder.error_sin: needs encoder.error_cos",
        ),
    ]
    for value, fault in bad:
        with pytest.raises(ValueError) as error:
            write_device(path, value)
        assert_one_line(error, f"{path}: ", fault)
    assert path.read_text() == DEVICE_TOML

    path = write(tmp_path, "virtual.toml", VIRTUAL_TOML)
    virtual = load_virtual(path)
    scaled = dataclasses.replace(virtual.friction, backward_scale=2.0)
    bad = [
        (
            dataclasses.replace(virtual, friction=scaled, friction_backward=virtual.friction),
            "friction_backward: give either friction.backward_scale or [friction_backward]",
        ),
        (
            dataclasses.replace(virtual, friction_backward=scaled),
            "friction_backward.backward_scale: 2.0 would be read back as 1.0",
        ),
        (dataclasses.replace(virtual, models=("a model",)), "models: ('a model',)"),
        (dataclasses.replace(virtual, run=RunSettings(seed=-1)), "run.seed: must be >= 0, got -1"),
        (
            dataclasses.replace(virtual, rig=Rig(efficiency_backdriven=0.0)),
            "rig.efficiency_backdriven: must be > 0, got 0.0",
        ),
        (
            dataclasses.replace(virtual, rig=Rig(encoder_error_amplitude=(1e-4,))),
            "rig.encoder_error_phase_deg: must have one entry per order",
        ),
    ]
    for value, fault in bad:
        with pytest.raises(ValueError) as error:
            write_virtual(path, value)
        assert_one_line(error, f"{path}: ", fault)
    assert path.read_text() == VIRTUAL_TOML
    with pytest.raises(ValueError, match="not a physical inertia tensor"):
        write_reference(tmp_path / "reference.toml", TrueBody(1.0, [1, 1, 3, 0, 0, 0], [0, 0, 0]))
    assert not (tmp_path / "reference.toml").exists()


def test_true_bodies_compare_by_value():
    body = TrueBody(mass=1.0, inertia=[1, 2, 2, 0, 0, 0], com=[0, 0, 0])
    assert body == TrueBody(mass=1.0, inertia=(1.0, 2.0, 2.0, 0.0, 0.0, 0.0), com=(0, 0, 0))
    assert body != TrueBody(mass=1.0, inertia=[1, 2, 2, 0, 0, 0], com=[0, 0, 1e-9])
    assert body != TrueBody(mass=2.0, inertia=[1, 2, 2, 0, 0, 0], com=[0, 0, 0])


# Property: any valid Device, Virtual or reference body reads back equal.

finite = st.floats(allow_nan=False, allow_infinity=False)
non_negative = st.floats(min_value=0.0, allow_infinity=False)
positive = non_negative.filter(lambda x: x > 0)


def maybe(values):
    return st.none() | values


def triples(values):
    return st.tuples(values, values, values)


@st.composite
def harmonics(draw, *values):
    """Coefficient arrays of one harmonic series, one per strategy of ``values``: as many
    entries each (the orders, none to four)."""
    orders = draw(st.integers(0, 4))
    return tuple(tuple(draw(st.lists(v, min_size=orders, max_size=orders))) for v in values)


@st.composite
def stages(draw, torque_limit: float):
    """One to three stages whose nodes give at least six axes, each braked within
    ``torque_limit`` or with its protocol left to plan."""
    count = draw(st.integers(1, 3))
    ratios = draw(st.lists(non_negative, min_size=count, max_size=count, unique=True))
    result = []
    for k, ratio in enumerate(ratios):
        nodes = draw(
            st.lists(
                st.floats(min_value=0.0, max_value=360.0, exclude_max=True),
                min_size=6 if k == 0 else 1,
                max_size=8,
                unique=True,
            )
        )
        result.append(
            Stage(
                gear_ratio=ratio,
                tare_inertia=draw(non_negative),
                nodes_deg=tuple(nodes),
                launch_speed=draw(maybe(positive)),
                braking_torque=draw(maybe(st.floats(0.0, torque_limit))),
                directions=draw(
                    st.sampled_from(
                        [(Direction.FORWARD,), (Direction.BACKWARD,), tuple(reversed(Direction))]
                    )
                ),
                tare_inertia_std=draw(maybe(non_negative)),
                release_angle_deg=draw(maybe(finite)),
            )
        )
    return tuple(result)


@st.composite
def devices(draw):
    body = draw(maybe(st.builds(Body, mass=positive)))
    # An encoder's certificate: cosine and sine coefficients, with or without their stds.
    cos, sin, std = draw(maybe(harmonics(finite, finite, non_negative))) or (None, None, None)
    if std is not None and draw(st.booleans()):
        std = None
    shape = draw(st.sampled_from(["none", "inertia"] + (["box"] if body else [])))
    plan = draw(
        maybe(
            st.builds(
                PlanGuess,
                inertia=triples(non_negative) if shape == "inertia" else st.none(),
                box=triples(non_negative) if shape == "box" else st.none(),
                friction=triples(non_negative),
                com_offset=non_negative,
                torque_noise=maybe(non_negative),
                max_duration=maybe(positive),
            )
        )
    )
    motor = Motor(draw(positive), draw(positive), draw(maybe(non_negative)))
    return Device(
        name=draw(st.text()),
        gravity=draw(positive),
        spring=Spring(stiffness=draw(non_negative), zero_angle=draw(finite)),
        motor=motor,
        encoder=Encoder(
            draw(st.integers(1, 2**62)),
            draw(positive),
            draw(maybe(st.integers(1, 64))),
            error_cos=cos,
            error_sin=sin,
            error_std=std,
        ),
        stages=draw(stages(motor.torque_limit)),
        body=body,
        pendulum=draw(
            maybe(st.builds(Pendulum, positive, positive, positive, maybe(non_negative)))
        ),
        plan=plan,
        mounting=draw(maybe(st.builds(Mounting, rotation=rotations(), origin=triples(finite)))),
    )


@st.composite
def rotations(draw):
    """A rotation matrix, from a unit quaternion."""
    quaternion = np.array(draw(st.tuples(*[st.floats(-1, 1)] * 4)))
    assume(np.linalg.norm(quaternion) > 0.1)
    w, x, y, z = quaternion / np.linalg.norm(quaternion)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


@st.composite
def true_bodies(draw):
    """A physical body: principal moments obeying the triangle inequality, turned."""
    m1, m2 = draw(st.floats(1e-3, 10.0)), draw(st.floats(1e-3, 10.0))
    m3 = abs(m1 - m2) + draw(st.floats(0.05, 0.95)) * (m1 + m2 - abs(m1 - m2))
    turn = draw(rotations())
    tensor = draw(st.floats(1e-4, 1e2)) * turn @ np.diag([m1, m2, m3]) @ turn.T
    inertia = [tensor[0, 0], tensor[1, 1], tensor[2, 2], tensor[0, 1], tensor[1, 2], tensor[0, 2]]
    return TrueBody(mass=draw(positive), inertia=inertia, com=draw(triples(finite)))


@st.composite
def virtuals(draw):
    friction = st.builds(Friction, non_negative, non_negative, non_negative)
    scaled = draw(st.builds(Friction, non_negative, non_negative, non_negative, non_negative))
    backward = draw(maybe(friction))
    efficiency = st.floats(0.0, 1.0, exclude_min=True)
    amplitude, phase = draw(maybe(harmonics(non_negative, finite))) or (None, None)
    return Virtual(
        body=draw(maybe(true_bodies())),
        friction=dataclasses.replace(scaled, backward_scale=1.0) if backward else scaled,
        run=RunSettings(draw(finite), draw(non_negative), draw(st.integers(0, 2**63 - 1))),
        controller=ControllerSettings(draw(positive)),
        fixture=draw(maybe(true_bodies())),
        rig=Rig(
            torque_gain=draw(positive),
            tare_inertia=draw(maybe(st.lists(non_negative, max_size=4).map(tuple))),
            pendulum_stiffness=draw(maybe(positive)),
            efficiency_driving=draw(efficiency),
            efficiency_backdriven=draw(efficiency),
            encoder_error_amplitude=amplitude,
            encoder_error_phase_deg=phase,
        ),
        friction_backward=backward,
        logger=LoggerSettings(
            draw(st.floats(0.0, 0.25)),
            draw(st.floats(0.0, 0.5, exclude_max=True)),
            draw(st.booleans()),
        ),
        mounting=draw(maybe(st.builds(VirtualMounting, triples(finite)))),
    )


ROUND_TRIPS = settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


@ROUND_TRIPS
@given(device=devices())
def test_any_device_round_trips(tmp_path, device):
    assume(device.n_axes >= 6)
    write_device(tmp_path / "device.toml", device)
    assert load_device(tmp_path / "device.toml") == device


@ROUND_TRIPS
@given(virtual=virtuals())
def test_any_virtual_round_trips(tmp_path, virtual):
    write_virtual(tmp_path / "virtual.toml", virtual)
    assert load_virtual(tmp_path / "virtual.toml") == virtual


@ROUND_TRIPS
@given(body=true_bodies())
def test_any_reference_body_round_trips(tmp_path, body):
    write_reference(tmp_path / "reference.toml", body)
    assert load_reference(tmp_path / "reference.toml").body == body
