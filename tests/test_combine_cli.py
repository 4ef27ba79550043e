"""``rsp-inertia combine``: folders of mountings -> OUT/body.json, and its refusals.

The mountings' result.json here are made from a known body through the mounting formula
(rsp_inertia.plant.geometry.place_body) with a stated covariance, so that what combine
finds can be compared with the body itself; the whole chain on the virtual device (simulate,
identify, combine) is benchmarks/mountings.py's and tests/estimation/test_combine.py's.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.plant.geometry import place_body
from rsp_inertia.scenarios import create_default_experiment

INERTIA = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
COM = np.array([0.003, -0.002, 0.004])
MASS, G = 2.0, 9.80665
TURNED_X90 = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
STD = np.array([1e-7] * 6 + [1e-6] * 2)


def _mounting(folder, rotation, *, mass=MASS, name=None, result=True):
    """An experiment folder whose result.json is the body measured exactly, with STD."""
    root = create_default_experiment(folder)
    device = root / "device.toml"
    text = device.read_text()
    if name is not None:
        text = text.replace('name = "virtual-paper"', f'name = "{name}"', 1)
    text = text.replace("mass = 2.0 ", f"mass = {mass!r} ", 1)
    rows = ", ".join(str(list(map(float, row))) for row in rotation)
    device.write_text(text + f"\n[mounting]\nrotation = [{rows}]\norigin = [0.0, 0.0, 0.0]\n")
    if result:
        inertia, com = place_body(INERTIA, COM, MASS, np.array(rotation), np.zeros(3))
        keys = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")
        document = {
            "tensor": dict(zip(keys, map(float, inertia))),
            "gravity_torque": {"m_g_xc": MASS * G * com[0], "m_g_yc": MASS * G * com[1]},
            "covariance": np.diag(STD**2).tolist(),
        }
        (root / "result.json").write_text(json.dumps(document))
    return root


def one_line_error(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for needle in needles:
        assert needle in err, err


def test_two_mountings_give_the_whole_centre_of_mass(tmp_path, capsys):
    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(tmp_path / "b", TURNED_X90)
    out = tmp_path / "body"
    assert main(["combine", str(first), str(second), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.rstrip().endswith(f"body -> {out / 'body.json'}")
    body = json.loads((out / "body.json").read_text())
    entries = np.array([body["tensor"][k] for k in ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")])
    com = np.array([body["com"][k] for k in "xyz"])
    assert entries == pytest.approx(INERTIA, abs=1e-12)
    assert com == pytest.approx(COM, abs=1e-12)
    assert body["com_std"]["z"] > 0 and body["consistency"]["dof"] == 7
    # Hand-made result.json files record no inputs: combine cannot check them, and says so.
    assert any("records no inputs" in w for w in body["warnings"])


@pytest.mark.parametrize(
    "case",
    ["one mounting", "same folder twice", "other device", "other mass", "no result", "out is a file"],
)
def test_what_combine_refuses(tmp_path, capsys, case):
    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(
        tmp_path / "b", TURNED_X90,
        name="another-rig" if case == "other device" else None,
        mass=2.5 if case == "other mass" else MASS,
        result=case != "no result",
    )
    out = tmp_path / "body"
    folders = {"one mounting": [first], "same folder twice": [first, tmp_path / "a" / "."]}
    argv = [str(f) for f in folders.get(case, [first, second])]
    if case == "out is a file":
        out.write_text("")
    capsys.readouterr()
    assert main(["combine", *argv, "--out", str(out)]) == 2
    needles = {
        "one mounting": ("z", "rotation = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]"),
        "same folder twice": ("given twice",),
        "other device": ("device.name = 'another-rig'", "one device"),
        "other mass": ("body.mass = 2.5", "one body"),
        "no result": (f"{second / 'result.json'}: not found", "identify"),
        "out is a file": ("--out: is a file",),
    }[case]
    one_line_error(capsys, *needles)
    assert not (out / "body.json").exists()


def test_body_json_keys_are_documented_and_exist(tmp_path):
    from tests.test_docs import _documented, _paths

    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(tmp_path / "b", TURNED_X90)
    assert main(["combine", str(first), str(second), "--out", str(tmp_path / "o")]) == 0
    real = _paths(json.loads((tmp_path / "o" / "body.json").read_text()))
    documented = set(_documented("body.json"))
    assert documented == real, (sorted(documented - real), sorted(real - documented))
