"""``rsp-inertia export``: a result in another frame, against independent truths.

The truth is a body of point masses, whose tensor about any point in any axes is the sum of
m (|r|^2 I - r r^T) over its points, written out here; the parallel-axis theorem is written
out too. rsp_inertia.exporting uses rsp_inertia.plant.geometry.place_body.
"""

from __future__ import annotations

import csv
import io
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.exporting import (
    OUTPUT_KEYS,
    Frame,
    SourceBody,
    _FrameFile,
    frame_properties,
)
from rsp_inertia.infra.toml_schema import accepted_keys
from rsp_inertia.plant.geometry import small_rotation
from rsp_inertia.provenance import sealed_json
from tests.test_combine_cli import _mounting, one_line_error

KEYS = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")
ROTATION = small_rotation([30.0, -50.0, 110.0])
"""A frame turned about every axis."""
ORIGIN = np.array([0.02, 0.01, -0.03])


def _entries(J: np.ndarray) -> np.ndarray:
    return np.array([J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[1, 2], J[0, 2]])


def _point_tensor(points: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """sum m (|r|^2 I - r r^T): the tensor of point masses about the coordinates' origin."""
    return sum(m * (r @ r * np.eye(3) - np.outer(r, r)) for r, m in zip(points, masses))


@pytest.fixture(scope="module")
def points():
    """Seven point masses (kg) at points (m) of the body's own axes, off its origin."""
    rng = np.random.default_rng(7)
    where = rng.normal(scale=0.05, size=(7, 3)) + [0.01, -0.02, 0.03]
    return where, rng.uniform(0.1, 0.5, size=7)


def _body_json(folder, entries, com, mass, cov=None):
    """A body.json as combine writes it (sealed), with a stated covariance."""
    folder.mkdir(parents=True, exist_ok=True)
    cov = np.diag([1e-7] * 6 + [1e-6] * 3) ** 2 if cov is None else cov
    document = {
        "tensor": dict(zip(KEYS, map(float, entries))),
        "com": dict(zip("xyz", map(float, com))),
        "covariance": np.asarray(cov).tolist(),
        "consistency": {"chi2": 1.0, "dof": 7, "p": 0.5},
        "warnings": [],
        "mass": float(mass),
    }
    (folder / "body.json").write_text(sealed_json(document))
    return folder / "body.json"


def _frame_toml(path, rotation, origin):
    rows = ", ".join("[" + ", ".join(repr(float(c)) for c in row) + "]" for row in rotation)
    at = ", ".join(repr(float(c)) for c in origin)
    path.write_text(f"[frame]\nrotation = [{rows}]\norigin = [{at}]\n")
    return path


def _source(entries, com, mass, cov=None, mass_std=0.0):
    cov = np.zeros((9, 9)) if cov is None else cov
    jac = np.diag([1.0] * 6 + [mass] * 3)
    return SourceBody(None, "body.json", "body axes", np.asarray(entries, float),
                      mass * np.asarray(com, float), jac @ cov @ jac.T, mass, mass_std)


# --- the transformation against the parallel-axis theorem written out -----------------------


def test_the_frame_tensor_is_the_point_masses_tensor_and_the_parallel_axis_theorem(points):
    where, masses = points
    m = masses.sum()
    c = masses @ where / m
    body = _source(_entries(_point_tensor(where, masses)), c, m)
    values, _, determined = frame_properties(body, Frame(rotation=ROTATION, origin=ORIGIN))
    assert determined.all()
    # The point masses in the frame: v_frame = F (v - p), summed directly.
    in_frame = (where - ORIGIN) @ ROTATION.T
    about_com = (where - c) @ ROTATION.T
    scale = 1e-12 * _point_tensor(where, masses).max()  # rounding of sums of ~1e-3 kg m^2
    assert values[0] == m
    assert values[1:4] == pytest.approx(ROTATION @ (c - ORIGIN), abs=1e-15)
    assert values[4:10] == pytest.approx(_entries(_point_tensor(in_frame, masses)), abs=scale)
    assert values[10:] == pytest.approx(_entries(_point_tensor(about_com, masses)), abs=scale)
    # The parallel-axis theorem written out: J_p = J_c + m (|d|^2 I - d d^T), d = c - p,
    # turned into the frame.
    J_c = _point_tensor(where - c, masses)
    d = c - ORIGIN
    J_p = ROTATION @ (J_c + m * (d @ d * np.eye(3) - np.outer(d, d))) @ ROTATION.T
    assert values[4:10] == pytest.approx(_entries(J_p), abs=scale)


def test_a_rotation_carries_the_covariance_exactly():
    """About the source's origin the map is J -> F J F^T, linear: cov' = M cov M^T with M the
    6 x 6 map of the entries, built here from the basis tensors."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(9, 9))
    cov = A @ A.T * 1e-14
    entries = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    body = _source(entries, [0.003, -0.002, 0.004], 2.0, cov)
    values, out, _ = frame_properties(body, Frame(rotation=ROTATION))
    M = np.empty((6, 6))
    for i in range(6):
        e = np.zeros(6)
        e[i] = 1.0
        T = np.array([[e[0], e[3], e[5]], [e[3], e[1], e[4]], [e[5], e[4], e[2]]])
        M[:, i] = _entries(ROTATION @ T @ ROTATION.T)
    exact = M @ cov[:6, :6] @ M.T
    # rounding of the central differences: ~1e-12 of the entries' scale, relative to cov
    assert out[4:10, 4:10] == pytest.approx(exact, rel=1e-8, abs=1e-9 * np.abs(exact).max())
    assert values[4:10] == pytest.approx(M @ entries, abs=1e-17)


def test_the_propagated_covariance_is_the_monte_carlos():
    """Seeded draws of [entries, com, mass] from their covariance, each carried into the frame
    by the parallel-axis theorem written out: the sample covariance of the outputs is the
    propagated one within the Monte Carlo's sampling error."""
    rng = np.random.default_rng(20261128)
    entries = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    com = np.array([0.003, -0.002, 0.004])
    m, m_std = 2.0, 0.01  # a 0.5 % mass std: the shift's mass term matters
    A = rng.normal(size=(9, 9))
    cov = A @ A.T
    stds = np.array([2e-5] * 6 + [2e-4] * 3)
    cov = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov))) * np.outer(stds, stds)
    body = _source(entries, com, m, cov, m_std)
    frame = Frame(rotation=ROTATION, origin=ORIGIN)
    values, out, _ = frame_properties(body, frame)

    n = 40_000
    # the source's unknowns: entries, q = m c (what the rig measures) and the mass
    jac = np.diag([1.0] * 6 + [m] * 3)
    theta = rng.multivariate_normal(np.concatenate([entries, m * com]), jac @ cov @ jac.T, n)
    mass = rng.normal(m, m_std, n)
    c = theta[:, 6:] / mass[:, None]
    J = np.array([[theta[:, 0], theta[:, 3], theta[:, 5]],
                  [theta[:, 3], theta[:, 1], theta[:, 4]],
                  [theta[:, 5], theta[:, 4], theta[:, 2]]]).transpose(2, 0, 1)
    # parallel-axis theorem, written out: about c, then about p, then turned
    about_c = J - mass[:, None, None] * (np.einsum("ni,ni->n", c, c)[:, None, None] * np.eye(3)
                                         - np.einsum("ni,nj->nij", c, c))
    d = c - ORIGIN
    about_p = about_c + mass[:, None, None] * (
        np.einsum("ni,ni->n", d, d)[:, None, None] * np.eye(3) - np.einsum("ni,nj->nij", d, d))
    turned = ROTATION @ about_p @ ROTATION.T
    samples = np.column_stack([
        mass, (c - ORIGIN) @ ROTATION.T,
        turned[:, 0, 0], turned[:, 1, 1], turned[:, 2, 2],
        turned[:, 0, 1], turned[:, 1, 2], turned[:, 0, 2],
    ])
    sample_cov = np.cov(samples, rowvar=False)
    propagated = out[:10, :10]
    sample_std, std = np.sqrt(np.diag(sample_cov)), np.sqrt(np.diag(propagated))
    # The std of a sample std is std / sqrt(2 n) = 0.35 %: 1.5 % is over 4 of them.
    assert sample_std == pytest.approx(std, rel=0.015)
    # correlations: their sampling std is at most 1 / sqrt(n) = 0.005
    corr = propagated / np.outer(std, std)
    sample_corr = sample_cov / np.outer(sample_std, sample_std)
    assert np.abs(corr - sample_corr).max() < 0.025
    assert samples.mean(axis=0) == pytest.approx(values[:10], abs=4 * (std / np.sqrt(n)).max()
                                                 + 1e-12)


# --- the files -----------------------------------------------------------------------------


def test_urdf_parsed_back_is_the_bodys_tensor_about_its_centre_of_mass(points, tmp_path, capsys):
    where, masses = points
    m = masses.sum()
    c = masses @ where / m
    source = _body_json(tmp_path / "body", _entries(_point_tensor(where, masses)), c, m)
    frame = _frame_toml(tmp_path / "cad.toml", ROTATION, ORIGIN)
    out = tmp_path / "body.urdf"
    assert main(["export", str(source.parent), "--format", "urdf", "--frame", str(frame),
                 "--mass-std", "0.001", "--out", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"export (urdf) -> {out}"
    root = ET.parse(out).getroot()
    assert root.tag == "inertial"
    xyz = np.array(root.find("origin").get("xyz").split(), dtype=float)
    assert xyz == pytest.approx(ROTATION @ (c - ORIGIN), abs=1e-15)
    assert root.find("origin").get("rpy") == "0 0 0"
    assert float(root.find("mass").get("value")) == m
    inertia = root.find("inertia")
    in_frame = (where - c) @ ROTATION.T  # the points about the centre of mass, frame axes
    truth = _point_tensor(in_frame, masses)
    scale = 1e-12 * truth.max()
    for name, (i, j) in {"ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2), "ixy": (0, 1),
                         "iyz": (1, 2), "ixz": (0, 2)}.items():
        assert float(inertia.get(name)) == pytest.approx(truth[i, j], abs=scale), name
    # URDF's sign: ixy is the tensor's entry, -sum m x y
    minus_sum = -np.sum(masses * in_frame[:, 0] * in_frame[:, 1])
    assert float(inertia.get("ixy")) == pytest.approx(minus_sum, abs=scale)
    comment = out.read_text().splitlines()[1]
    assert comment.startswith("<!--") and "standard deviations: mass 0.001 kg" in comment


def test_json_and_csv_hold_values_stds_and_covariance(points, tmp_path, capsys):
    from tests.test_docs import _documented, _paths

    where, masses = points
    m = masses.sum()
    c = masses @ where / m
    source = _body_json(tmp_path / "body", _entries(_point_tensor(where, masses)), c, m)
    frame = _frame_toml(tmp_path / "cad.toml", ROTATION, ORIGIN)
    argv = ["export", str(source), "--frame", str(frame), "--out"]
    assert main([*argv, str(tmp_path / "out.json")]) == 0
    # without --mass-std: a note on stderr, and the mass's std is 0
    assert "note: the mass's std is not stated" in capsys.readouterr().err
    document = json.loads((tmp_path / "out.json").read_text())
    assert set(_paths(document)) == set(_documented("export: JSON, CSV, URDF"))
    assert document["covariance_order"] == list(OUTPUT_KEYS)
    cov = np.array(document["covariance"])
    assert cov.shape == (10, 10) and np.allclose(cov, cov.T, rtol=1e-12, atol=0)
    for i, key in enumerate(KEYS):
        assert document["tensor_std"][key] == pytest.approx(np.sqrt(cov[4 + i, 4 + i]))
    assert document["mass_std"] == 0.0
    assert main([*argv, str(tmp_path / "out.csv"), "--format", "csv"]) == 0
    rows = list(csv.DictReader(io.StringIO((tmp_path / "out.csv").read_text())))
    assert [r["quantity"] for r in rows] == [
        "mass", "x_c", "y_c", "z_c", *KEYS, *(f"{k}_com" for k in KEYS)]
    by_name = {r["quantity"]: r for r in rows}
    assert float(by_name["Jxy"]["value"]) == document["tensor"]["Jxy"]
    assert float(by_name["z_c"]["std"]) == document["com_std"]["z"]
    assert by_name["Jx_com"]["unit"] == "kg m^2" and by_name["x_c"]["unit"] == "m"


def test_the_frame_file_keys_are_documented():
    from tests.test_docs import _documented

    documented = set(_documented("FRAME.toml"))
    accepted = {f"{t}.{k}" for t, keys in accepted_keys(_FrameFile).items() if t for k in keys}
    assert documented == accepted


def test_a_result_json_exports_what_one_mounting_determines(tmp_path, capsys):
    """One mounting: the tensor about O turned, x_c and y_c turned about the shaft; z_c and
    what needs it are null, and a URDF or a shifted origin is refused."""
    from tests.test_combine_cli import COM, INERTIA, MASS

    root = _mounting(tmp_path / "a", np.eye(3))
    about_z = small_rotation([0.0, 0.0, 35.0])
    frame = _frame_toml(tmp_path / "z.toml", about_z, [0.0, 0.0, 0.0])
    out = tmp_path / "out.json"
    assert main(["export", str(root / "result.json"), "--frame", str(frame), "--out",
                 str(out)]) == 0
    err = capsys.readouterr().err
    assert "records no integrity" in err  # the hand-made result.json of test_combine_cli
    document = json.loads(out.read_text())
    J = np.array([[INERTIA[0], INERTIA[3], INERTIA[5]], [INERTIA[3], INERTIA[1], INERTIA[4]],
                  [INERTIA[5], INERTIA[4], INERTIA[2]]])
    truth = _entries(about_z @ J @ about_z.T)
    assert [document["tensor"][k] for k in KEYS] == pytest.approx(truth, abs=1e-15)
    assert [document["com"][k] for k in "xy"] == pytest.approx((about_z @ COM)[:2], abs=1e-15)
    assert document["com"]["z"] is None and document["tensor_about_com"]["Jx"] is None
    assert document["mass"] == MASS

    shifted = _frame_toml(tmp_path / "p.toml", np.eye(3), [0.0, 0.0, 0.01])
    for extra in (["--format", "urdf"], ["--frame", str(shifted)]):
        assert main(["export", str(root), *extra, "--out", str(tmp_path / "x")]) == 2
        one_line_error(capsys, "z_c", "combine")
        assert not (tmp_path / "x").exists()


@pytest.mark.parametrize(
    "case",
    ["edited", "reflection", "not orthonormal", "unknown key", "no mass", "other mass",
     "both files", "out is a folder", "no source"],
)
def test_what_export_refuses(tmp_path, capsys, case):
    entries = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    source = _body_json(tmp_path / "body", entries, [0.003, -0.002, 0.004], 2.0)
    frame = tmp_path / "f.toml"
    rotation = np.eye(3)
    if case == "reflection":
        rotation = np.diag([1.0, 1.0, -1.0])
    elif case == "not orthonormal":
        rotation = np.array([[1.0, 0.001, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    _frame_toml(frame, rotation, [0.0, 0.0, 0.0])
    if case == "unknown key":
        frame.write_text(frame.read_text() + "scale = 1.0\n")
    document = json.loads(source.read_text())
    if case == "edited":
        document["tensor"]["Jx"] = 0.03
        source.write_text(json.dumps(document))
    elif case in ("no mass", "other mass"):
        document["mass"] = None
        source.write_text(sealed_json(document))
    elif case == "both files":
        (source.parent / "result.json").write_text("{}")
    out = tmp_path / "out.json"
    if case == "out is a folder":
        out.mkdir()
    src = tmp_path / "none" if case == "no source" else source.parent
    extra = ["--mass", "2.5"] if case == "other mass" else []
    if case == "other mass":
        document["mass"] = 2.0
        source.write_text(sealed_json(document))
    capsys.readouterr()
    assert main(["export", str(src), "--frame", str(frame), *extra, "--out", str(out)]) == 2
    needles = {
        "edited": (f"{source}: edited after it was written",),
        "reflection": (f"{frame}: frame.rotation: must have determinant +1",),
        "not orthonormal": (f"{frame}: frame.rotation: must be orthonormal",),
        "unknown key": (f"{frame}", "scale"),
        "no mass": ("states no mass", "--mass"),
        "other mass": ("--mass 2.5 differs", "mass = 2.0"),
        "both files": ("both result.json and body.json",),
        "out is a folder": (f"{out}: cannot be written",),
        "no source": ("not found",),
    }[case]
    one_line_error(capsys, *needles)
    assert not out.is_file()


def test_a_stated_mass_exports_a_body_json_without_one(tmp_path, capsys):
    entries = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    source = _body_json(tmp_path / "body", entries, [0.003, -0.002, 0.004], 2.0)
    document = json.loads(source.read_text())
    del document["mass"]  # an older combine's
    source.write_text(sealed_json(document))
    out = tmp_path / "out.csv"
    assert main(["export", str(source), "--format", "csv", "--mass", "2.0", "--mass-std",
                 "0.002", "--out", str(out)]) == 0
    assert out.read_text().splitlines()[1] == "mass,2.0,0.002,kg"
