"""A decision against a specification (ISO/IEC 17025 section 7.8.6, ILAC-G8:09/2019): each
quantity that ``EXP/spec.toml`` limits is passed, failed or left indeterminate by the
decision rule, and the part by all of them. result.json's ``decision`` (docs/files.md).

The rules, for a value y with expanded uncertainty U and limits [low, high]:

- simple acceptance: pass if low <= y <= high, else fail; U plays no part, so the specific
  risk of a false pass is not controlled (near 50 % for a value at a limit);
- guarded acceptance, a guard band of U: pass if low <= y - U and y + U <= high; fail if
  y + U < low or y - U > high; else (the interval y +- U straddles a limit) indeterminate.

The part fails if any quantity fails, else is indeterminate if any is, else passes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.geometry import ENTRY_KEYS, principal
from rsp_inertia.plant.record_config import Rule, SpecFile

if TYPE_CHECKING:
    from rsp_inertia.estimation.results import Identification

__all__ = [
    "FAIL",
    "INDETERMINATE",
    "PASS",
    "Decision",
    "check_quantities",
    "decide",
    "decide_quantity",
    "expanded_for_decision",
    "part_verdict",
    "result_quantities",
]

PASS, FAIL, INDETERMINATE = "pass", "fail", "indeterminate"
"""The verdicts of a quantity and of the part."""

STATEMENTS = {
    Rule.SIMPLE: (
        "simple acceptance (ILAC-G8:09/2019): a value inside its limits passes, outside "
        "fails, its uncertainty aside; the specific risk of a false pass is not controlled "
        "(up to 50 % for a value at a limit)"
    ),
    Rule.GUARDED: (
        "guarded acceptance with a guard band of the expanded uncertainty U (ILAC-G8:09/2019): "
        "a value passes only if value +- U lies inside its limits, fails only if value +- U "
        "lies outside them, and is indeterminate otherwise"
    ),
}
"""The decision rule as the report and result.json state it."""


def decide_quantity(value: float, U: float, limits: tuple[float, float], rule: Rule) -> str:
    """The verdict on one quantity (the module's rules).

    Parameters
    ----------
    value : float
        The measured value.
    U : float
        Its expanded uncertainty (>= 0); the simple rule ignores it.
    limits : (float, float)
        ``[low, high]``, inclusive.
    rule : Rule
        'simple' or 'guarded'.

    Returns
    -------
    str
        'pass', 'fail' or 'indeterminate' (guarded only).

    Examples
    --------
    >>> decide_quantity(1.0, 0.2, (0.0, 1.1), Rule.GUARDED)
    'indeterminate'
    """
    low, high = limits
    if rule is Rule.SIMPLE:
        return PASS if low <= value <= high else FAIL
    if low <= value - U and value + U <= high:
        return PASS
    if value + U < low or value - U > high:
        return FAIL
    return INDETERMINATE


def part_verdict(verdicts: list[str]) -> str:
    """The part's verdict from its quantities': fail if any fails, else indeterminate if any
    is, else pass."""
    if FAIL in verdicts:
        return FAIL
    return INDETERMINATE if INDETERMINATE in verdicts else PASS


@dataclass(frozen=True)
class Decision:
    """The decision against spec.toml: result.json's ``decision``."""

    rule: Rule
    """The decision rule."""
    quantities: dict[str, str]
    """Each limited quantity (spec.toml's dotted key) -> 'pass', 'fail' or 'indeterminate'."""
    limits: dict[str, tuple[float, float]]
    """Each limited quantity -> its [low, high]."""
    values: dict[str, tuple[float, float]]
    """Each limited quantity -> (value, U) compared with its limits."""
    part: str
    """The part's verdict (:func:`part_verdict`)."""

    @property
    def statement(self) -> str:
        """The decision rule in one sentence, with the risk it leaves."""
        return STATEMENTS[self.rule]

    def to_dict(self) -> dict[str, Any]:
        """result.json's ``decision``."""
        return {
            "rule": self.rule.value,
            "statement": self.statement,
            "quantities": dict(self.quantities),
            "limits": {name: list(limits) for name, limits in self.limits.items()},
            "values": {name: {"value": v, "U": u} for name, (v, u) in self.values.items()},
            "part": self.part,
        }

    def __str__(self) -> str:
        failed = [name for name, verdict in self.quantities.items() if verdict != PASS]
        detail = ", ".join(f"{name} {self.quantities[name]}" for name in failed)
        return (
            f"part against spec.toml ({self.rule.value} rule): {self.part}"
            + (f" ({detail})" if detail else f" (all {len(self.quantities)} within limits)")
        )


def decide(
    spec: SpecFile, values: dict[str, tuple[float, float]], source: str = "spec.toml"
) -> Decision:
    """Decide every quantity ``spec`` limits, and the part.

    Parameters
    ----------
    spec : SpecFile
        The limits and the rule (rsp_inertia.plant.record_config.load_spec).
    values : dict
        Quantity (``tensor.Jx``, ``com.x``, ``principal.moments[1]``, ...) -> (value, U),
        in SI units: what the result gives (:func:`expanded_for_decision`).
    source : str
        spec.toml's path, for the message.

    Returns
    -------
    Decision
        Each quantity's verdict, its limits and (value, U), and the part's verdict.

    Raises
    ------
    InputError
        A limit on a quantity ``values`` does not hold (one line naming it).
    """
    limits = spec.limits()
    check_quantities(spec, set(values), source)
    rule = spec.decision.rule
    quantities = {
        name: decide_quantity(*values[name], bounds, rule) for name, bounds in limits.items()
    }
    return Decision(
        rule=rule,
        quantities=quantities,
        limits=limits,
        values={name: (float(values[name][0]), float(values[name][1])) for name in limits},
        part=part_verdict(list(quantities.values())),
    )


def check_quantities(spec: SpecFile, names: set[str], source: str = "spec.toml") -> None:
    """Refuse a spec that limits a quantity the result will not have (identify calls it
    before its computation, with the names the device's result will hold).

    Parameters
    ----------
    spec : SpecFile
        The specification.
    names : set of str
        The quantities the result has (:func:`expanded_for_decision`'s keys).
    source : str
        spec.toml's path, for the message.

    Raises
    ------
    InputError
        The first limit on a missing quantity: one line saying why the result lacks it.
    """
    for name in spec.limits():
        if name in names:
            continue
        if name == "com.z":
            why = "one mounting does not measure z_c (rsp-inertia combine of mountings does)"
        elif name.startswith("com."):
            why = "the result has no centre of mass: device.toml gives no [body] mass"
        else:
            why = "the result has no such quantity"
        raise InputError(f"{source}: {name}: {why}; remove the limit")


def result_quantities(has_com: bool) -> set[str]:
    """The quantities an identify result holds: the six entries, the three principal
    moments, and with the body's mass x_c and y_c."""
    names = {f"tensor.{name}" for name in ENTRY_KEYS}
    names |= {f"principal.moments[{k}]" for k in (1, 2, 3)}
    if has_com:
        names |= {"com.x", "com.y"}
    return names


def expanded_for_decision(identification: Identification) -> dict[str, tuple[float, float]]:
    """Each quantity of an identification with the expanded uncertainty U the decision uses:
    the result's own GUM statement (its ``expanded_uncertainty``,
    rsp_inertia.estimation.coverage: U = k std of the entries and the centre of mass, the
    principal moments' U from their Monte Carlo intervals), the one place the decision takes
    its U from.

    Parameters
    ----------
    identification : Identification
        What identify found.

    Returns
    -------
    dict
        ``tensor.<entry>``, ``principal.moments[1..3]`` (ascending) and, with a centre of
        mass, ``com.x``, ``com.y`` -> (value, U).
    """
    stated = identification.expanded_uncertainty.to_dict()
    entries = np.asarray(identification.entries, dtype=float)
    moments, _ = principal(entries)
    out = {
        f"tensor.{name}": (value, stated["tensor"][name])
        for name, value in zip(ENTRY_KEYS, entries, strict=True)
    }
    out |= {
        f"principal.moments[{i}]": (value, U)
        for i, (value, U) in enumerate(zip(moments, stated["principal_moments"], strict=True), 1)
    }
    if identification.com is not None:
        out |= {
            f"com.{axis}": (value, stated["com"][axis])
            for axis, value in zip("xy", identification.com, strict=True)
        }
    return {name: (float(value), float(U)) for name, (value, U) in out.items()}
