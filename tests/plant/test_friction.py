"""The friction law has one home (rsp_inertia.plant.friction): change it there and every user
follows; nobody restates it.

The swap test copies the package's source, changes the one definition of FRICTION in the copy
(the quadratic term a3 Omega^2 becomes a cubic a4 |Omega|^3, which also has no closed-form
top speed) and asks the copy's users what they now compute: the model's D, the parameter
names, the balances' regressors, the slope prior's mapping, the fits' name lists and bounds,
device.toml's key names and the planning's top speed. The scan then fails on any module that
writes the law's coefficient names or the model's friction fields by hand.
"""

from __future__ import annotations

import ast
import dataclasses
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

import rsp_inertia
from rsp_inertia.plant import model
from rsp_inertia.plant.friction import FRICTION, FrictionLaw

ROOT = Path(rsp_inertia.__file__).resolve().parents[1]
"""The source tree: the layers' folders side by side (pyproject's package-dir)."""

LAYERS = {"rsp_inertia": "rsp_inertia", "infra": "rsp_inertia/infra", "plant": "rsp_inertia/plant",
          "virtual": "rsp_inertia/virtual", "estimation": "rsp_inertia/estimation",
          "ocp": "rsp_inertia/ocp", "design": "rsp_inertia/design"}
"""Folder -> where it sits in an importable copy of the package."""

HOME = ROOT / "plant" / "friction.py"

PAPER = 'names=("a1", "a2", "a3"), powers=(0, 1, 2)'
CUBIC = 'names=("a1", "a2", "a4"), powers=(0, 1, 3)'
"""The law's definition, and the other law the swap test puts in its place (the cubic term kept
in the model's ``quadratic`` field: the test changes the one definition, nothing else)."""

PROBE = r"""
import dataclasses, json, types
import numpy as np
from rsp_inertia.plant import friction, model, device_config
from rsp_inertia.plant.config import load_device
from rsp_inertia.estimation import balance, modulated
from rsp_inertia.ocp import nominal
from rsp_inertia.design import candidates, pilot

out = {"home": friction.__file__, "parameter_names": model.PARAMETER_NAMES}
p = model.ModelParameters(np.ones(5), coulomb=0.01, viscous=0.002, quadratic=0.0003)
w = np.array([0.5, 2.0, 7.0])
out["dissipation"] = model.dissipation(w, p).tolist()
out["dissipation_regressor"] = model.dissipation_regressor(w, p)[:, 9:].tolist()
phi = np.linspace(0.0, 3.0, 31)
omega = 5.0 + np.sin(phi)
out["shape"] = balance.friction_shape(phi, omega).tolist()
out["mismatch"] = balance.mismatch_regressors(phi, omega, omega + 0.01 * np.cos(phi)).tolist()
# The slope prior with the passes' fit replaced: values 1, 2, 3, ... in the fit's order.
balance.fit_modulated = lambda device, passes, unknowns, *a, **k: (
    {name: float(i + 1) for i, name in enumerate(unknowns)}, 1e-6 * np.eye(len(unknowns)))
fake = types.SimpleNamespace(log=None, smoothed=types.SimpleNamespace(t=np.arange(9) * 1e-3),
                             source="pass", sigma_torque=1e-4)
device = load_device(%r)
out["slope_prior"] = balance.friction_slope_prior(device, fake, fake)[0].tolist()
out["prior_unknowns"] = balance.PRIOR_UNKNOWNS
out["pilot_unknowns"] = pilot.PILOT_UNKNOWNS
out["nominal_unknowns"] = nominal.UNKNOWN
out["non_negative"] = modulated.NON_NEGATIVE
field = {f.name: f for f in dataclasses.fields(device_config.PlanGuess)}["friction"]
out["device_toml_names"] = field.metadata["names"]
out["usable"] = (1 - candidates.TORQUE_MARGIN) * device.motor.torque_limit
out["top_speed"] = candidates._top_speed(device, p)
import os, sys
out["files"] = sorted(m.__file__ for name, m in sys.modules.items()
                      if name.startswith("rsp_inertia") and getattr(m, "__file__", None))
print(json.dumps(out))
"""


def _probe(root: Path) -> dict:
    """What the users of the law compute, with the package imported from ``root``."""
    env = dict(os.environ, PYTHONPATH=str(root))
    script = PROBE % str(ROOT / "plant" / "defaults" / "device.toml")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=False,
                         env=env, cwd=root)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def _copy_with_law(tmp: Path, definition: str) -> Path:
    """An importable copy of the package whose friction law is ``definition``."""
    for folder, place in LAYERS.items():
        shutil.copytree(ROOT / folder, tmp / place,
                        ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    home = tmp / "rsp_inertia" / "plant" / "friction.py"
    source = home.read_text()
    assert source.count(PAPER) == 1
    home.write_text(source.replace(PAPER, definition))
    return tmp


def _paper(a, w):
    return a[0] + a[1] * w + a[2] * w**2


def _cubic(a, w):
    return a[0] + a[1] * w + a[2] * w**3


@pytest.fixture(scope="module")
def probes(tmp_path_factory) -> tuple[dict, dict]:
    """(this tree's users, a copy's users under the cubic law)."""
    copy = _copy_with_law(tmp_path_factory.mktemp("cubic"), CUBIC)
    return _probe(ROOT), _probe(copy)


@pytest.mark.parametrize("which", [0, 1], ids=["paper", "cubic"])
def test_every_user_follows_the_law(probes, which):
    out = probes[which]
    names, law = (("a1", "a2", "a3"), _paper) if which == 0 else (("a1", "a2", "a4"), _cubic)
    n_top = 2 if which == 0 else 3
    a = [0.01, 0.002, 0.0003]
    assert Path(out["home"]).is_relative_to(ROOT) == (which == 0)
    # the whole package from one tree: a copy that lacks a layer would mix in this tree's
    assert all(Path(f).is_relative_to(ROOT) == (which == 0) for f in out["files"])
    assert tuple(out["parameter_names"][9:]) == names
    w = np.array([0.5, 2.0, 7.0])
    np.testing.assert_allclose(out["dissipation"], law(a, w), rtol=1e-14)
    np.testing.assert_allclose(out["dissipation_regressor"],
                               np.column_stack([np.ones(3), w, w**n_top]), rtol=1e-14)
    phi = np.linspace(0.0, 3.0, 31)
    omega = 5.0 + np.sin(phi)
    delta = 0.01 * np.cos(phi)
    shape = np.column_stack([phi - phi[0]] + [cumulative_trapezoid(omega**n, phi, initial=0.0)
                                              for n in (1, n_top)])
    np.testing.assert_allclose(out["shape"], shape, rtol=1e-13, atol=1e-15)
    # D(w + delta) - D(w) to second order, per slope: delta, then g(w) delta + g'(w) delta^2/2
    # with g = w^(n - 1).
    m = n_top - 1
    second = omega**m * delta + m * omega ** (m - 1) * delta**2 / 2
    mismatch = np.column_stack([cumulative_trapezoid(f, phi, initial=0.0) for f in (delta, second)])
    np.testing.assert_allclose(out["mismatch"], mismatch, rtol=1e-13, atol=1e-18)
    unknowns = ("M0", *names, "Mc2", "Ms2", "Gs", "Gc", "Ms1", "Mc1")
    assert tuple(out["prior_unknowns"]) == tuple(out["pilot_unknowns"]) == unknowns
    assert tuple(out["nominal_unknowns"]) == tuple(u for u in unknowns if u != "a1")
    assert tuple(out["non_negative"]) == ("M0", *names)
    assert tuple(out["device_toml_names"]) == names
    # The fake fit's values are 1, 2, ... in the unknowns' order: d1 = a2, d2 = n a_top.
    assert out["slope_prior"] == [unknowns.index(names[1]) + 1, n_top * (unknowns.index(names[2]) + 1)]
    # The top speed: 2 D(w) = the usable torque.
    assert 0 < out["top_speed"] < 50
    assert 2 * law(a, out["top_speed"]) == pytest.approx(out["usable"], rel=1e-12)


def test_the_model_builds_its_dissipation_from_the_law():
    a1, a2, a3 = model.ca.vertsplit(model.MODEL.p)[9:]
    Omega, direction = model.MODEL.Omega, model.MODEL.direction
    assert str(model.MODEL.D) == str((a1 + a3 * Omega**2) * direction + a2 * Omega)
    assert model.PARAMETER_NAMES[9:] == FRICTION.names
    params = model.ModelParameters(np.ones(5), coulomb=1.0, viscous=2.0, quadratic=3.0)
    assert FRICTION.coefficients(params) == [1.0, 2.0, 3.0]
    assert params.vector[9:].tolist() == [1.0, 2.0, 3.0]


def test_the_paper_law_slopes_and_bounds():
    assert FRICTION.static == "a1"
    assert FRICTION.sloped == ("a2", "a3")
    assert FRICTION.slope_names == ("d1", "d2")
    np.testing.assert_array_equal(FRICTION.slope_jacobian, np.diag([1.0, 2.0]))
    assert FRICTION.non_negative == ("a1", "a2", "a3")
    w = np.array([0.0, 1.5, 3.0])
    basis = FRICTION.basis(w)
    np.testing.assert_array_equal(np.column_stack(basis), np.column_stack([w**0, w, w * w]))


@pytest.mark.parametrize("a1, a2, a3", [(0.01, 0.002, 3e-4), (0.0, 1e-4, 1e-3), (0.2, 0.03, 0.0),
                                        (1e-4, 1e-4, 1e-3), (0.1, 0.0, 0.0), (0.3, 0.1, 0.1)])
def test_the_top_speed_is_the_root_of_the_law(a1, a2, a3):
    """The closed form the planning has always used, bit for bit, and the bisection that a law
    without one falls back to agrees with it."""
    usable = 0.5
    c = 2 * a1 - usable
    if c >= 0:
        old = 0.0
    elif a3 > 0:
        old = (-2 * a2 + math.sqrt(4 * a2 * a2 - 8 * a3 * c)) / (4 * a3)
    elif a2 > 0:
        old = -c / (2 * a2)
    else:
        old = math.inf
    assert FRICTION.speed_at([a1, a2, a3], usable, factor=2) == old
    # The same law with an unused cubic term has no closed form here: bisection.
    quartic = FrictionLaw(("a1", "a2", "a3", "a4"), (0, 1, 2, 3), ("w", "x", "y", "z"))
    assert quartic.speed_at([a1, a2, a3, 0.0], usable, factor=2) == pytest.approx(old, rel=1e-14)


def test_a_law_needs_distinct_powers_and_a_field_per_coefficient():
    with pytest.raises(ValueError):
        FrictionLaw(("a1", "a2"), (0, 0), ("coulomb", "viscous"))
    with pytest.raises(ValueError):
        FrictionLaw(("a1", "a2"), (0, 1), ("coulomb",))


# --- nobody restates the law -----------------------------------------------------------

SCANNED = ("infra", "plant", "virtual", "estimation", "ocp", "design", "rsp_inertia", "benchmarks")
"""The folders whose modules must take the law from its home."""

BUILDERS = {"ModelParameters", "replace"}
"""Calls whose keyword arguments set a model's friction fields."""


def restatements(source: str, law: FrictionLaw = FRICTION) -> list[str]:
    """The places in ``source`` that write the law by hand: a string literal that is one of its
    coefficients' names (a name list, a key into a fit's values), or a model built with its
    friction fields as keywords. Docstrings and comments are text, not code."""
    tree = ast.parse(source)
    text = {id(node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)}
    found = []
    for node in ast.walk(tree):
        if (isinstance(node, ast.Constant) and node.value in law.names
                and id(node) not in text):
            found.append(f"line {node.lineno}: {node.value!r}")
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if name in BUILDERS:
                found += [f"line {node.lineno}: {k.arg}=" for k in node.keywords
                          if k.arg in law.fields]
    return found


KNOWN = {
    "benchmarks/experiments.py": "an experiment on the paper's law: it scales its Coulomb and "
    "viscous terms and, by design, not the quadratic one (its docstring)",
}
"""Modules allowed to name terms of the law, and why."""


def test_no_module_restates_the_friction_law():
    found = {}
    for folder in SCANNED:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path == HOME or str(path.relative_to(ROOT)) in KNOWN:
                continue
            hits = restatements(path.read_text())
            if hits:
                found[str(path.relative_to(ROOT))] = hits
    assert not found, f"the friction law restated outside {HOME.name}: {found}"


def test_the_scan_finds_a_restated_law():
    assert restatements('NON_NEGATIVE = ("M0", "a1", "a2", "a3")') == [
        "line 1: 'a1'", "line 1: 'a2'", "line 1: 'a3'"]
    assert restatements("x = values['a2']") == ["line 1: 'a2'"]
    assert restatements("m = ModelParameters(h, coulomb=a1, viscous=a2)") == [
        "line 1: coulomb=", "line 1: viscous="]
    assert restatements("m = dataclasses.replace(m, quadratic=0.0)") == ["line 1: quadratic="]
    # Text is not code, and the law's own users are not restating it.
    assert restatements('"""a1, a2 and a3 are the friction."""\nx = FRICTION.names') == []
    assert restatements("m = ModelParameters(h, **FRICTION.fields_of(f))") == []


def test_the_law_is_a_frozen_value():
    with pytest.raises(dataclasses.FrozenInstanceError):
        FRICTION.names = ("b",)
