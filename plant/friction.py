"""The friction law: the model's dissipative torque D (docs/method.md §3) and what follows from it.

:class:`FrictionLaw` is the law as a small object, :data:`FRICTION` the one the package uses
(the paper's Coulomb, viscous and quadratic friction). Everything that depends on the law
derives from it: the model's D and the parameter vector's friction entries
(rsp_inertia.plant.model), the balances' regressors and slope prior
(rsp_inertia.estimation.balance), the fits' bounds and unknowns
(rsp_inertia.estimation.modulated, rsp_inertia.ocp.nominal, rsp_inertia.design.pilot), the
planning's top speed (rsp_inertia.design.candidates) and device.toml's friction guess
(rsp_inertia.plant.device_config). Another law is another :class:`FrictionLaw` here, and
every user follows (tests/plant/test_friction.py). The module needs numpy only, so that
device.toml's reader stays light; D is built with the arithmetic operators on whatever symbols
it is given (the model's CasADi ones).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import casadi as ca

    from rsp_inertia.plant.model import ModelParameters

__all__ = ["FRICTION", "FrictionLaw"]


@dataclass(frozen=True)
class FrictionLaw:
    """A dissipative torque linear in its coefficients: a sum of powers of the speed.

    ``D(Omega) = sum_k a_k |Omega|^n_k sign(Omega)`` (docs/method.md §3), written with the
    sign of the motion as an explicit input ``direction`` (even powers times ``direction``,
    odd ones as Omega^n_k, which is |Omega|^n_k sign(Omega) while ``direction`` = sign(Omega)).
    The one home of the law: the model's D, the balances' regressors
    (rsp_inertia.estimation.balance), the fits' bounds (rsp_inertia.estimation.modulated) and
    the planning's top speed (rsp_inertia.design.candidates) all derive from it, so that
    another law is this object with other fields (:data:`FRICTION`).

    Its slopes: ``D'(w) = sum_j d_j w^(n_j - 1)`` over the terms with n_j >= 1, with
    ``d_j = n_j a_j`` (:attr:`slope_jacobian`).
    """

    names: tuple[str, ...]
    """The coefficients' names in the parameter vector p, in order."""
    powers: tuple[int, ...]
    """n_k, the power of |Omega| each coefficient multiplies."""
    fields: tuple[str, ...]
    """The :class:`ModelParameters` field that holds each coefficient."""

    def __post_init__(self) -> None:
        if not len(self.names) == len(self.powers) == len(self.fields):
            raise ValueError("a friction law needs a power and a field per coefficient")
        if len(set(self.powers)) != len(self.powers) or min(self.powers) < 0:
            raise ValueError(f"distinct non-negative powers, not {self.powers}")

    @property
    def static(self) -> str:
        """The name of the constant term (n = 0): the static friction at rest."""
        return self.names[self.powers.index(0)]

    @property
    def sloped(self) -> tuple[str, ...]:
        """The names of the terms that change with the speed (n >= 1), whose slopes the
        tracking mismatch sees (:attr:`slope_jacobian`) and a braking pass can fit (the
        constant one looks like the braking torque, rsp_inertia.ocp.nominal)."""
        return tuple(name for name, n in zip(self.names, self.powers) if n >= 1)

    @property
    def slope_names(self) -> tuple[str, ...]:
        """d1, d2, ...: the slopes' coefficients, one per :attr:`sloped` term."""
        return tuple(f"d{j + 1}" for j in range(len(self.sloped)))

    @property
    def slope_jacobian(self) -> np.ndarray:
        """d[d1, d2, ...] / d[sloped coefficients]: diag(n_j) (D'(w) = sum_j n_j a_j w^(n_j-1))."""
        return np.diag([float(n) for n in self.powers if n >= 1])

    @property
    def non_negative(self) -> tuple[str, ...]:
        """The coefficients bounded below by 0: all of them (a dissipation is non-negative
        and grows with the speed)."""
        return self.names

    def torque(self, Omega: ca.SX, direction: ca.SX, coefficients: Sequence[ca.SX]) -> ca.SX:
        """D as a CasADi expression: (even-power terms) direction + odd-power terms.

        Parameters
        ----------
        Omega, direction : casadi.SX
            The speed (rad/s) and the sign of the motion.
        coefficients : sequence of casadi.SX
            The coefficients, in the order of :attr:`names`.

        Returns
        -------
        casadi.SX
            N m, the dissipative torque.
        """
        even = [_power_term(a, Omega, n) for a, n in zip(coefficients, self.powers) if n % 2 == 0]
        odd = [_power_term(a, Omega, n) for a, n in zip(coefficients, self.powers) if n % 2 == 1]
        D = _sum(even) * direction if even else 0
        return D + _sum(odd) if odd else D

    def basis(self, speed: np.ndarray) -> list[np.ndarray]:
        """|Omega|^n_k per coefficient at speeds ``speed`` >= 0: D = basis . coefficients.

        Parameters
        ----------
        speed : numpy.ndarray
            rad/s, |Omega|.

        Returns
        -------
        list of numpy.ndarray
            One array of the shape of ``speed`` per coefficient.
        """
        speed = np.asarray(speed, dtype=float)
        return [np.ones_like(speed) if n == 0 else _power(speed, n) for n in self.powers]

    def mismatch_integrands(self, speed: np.ndarray, delta: np.ndarray) -> list[np.ndarray]:
        """Per slope d_j, its share of D(w + delta) - D(w) to second order in delta.

        With g_j(w) = w^m (m = n_j - 1) the slope's basis, g_j(w) delta + g_j'(w) delta^2 / 2
        (exact for a law of degree 2 or less): delta, then w delta + delta^2 / 2, ...

        Parameters
        ----------
        speed : numpy.ndarray
            rad/s, w = |Omega| of the braking.
        delta : numpy.ndarray
            rad/s, the reverse's speed minus it.

        Returns
        -------
        list of numpy.ndarray
            One array per slope (:attr:`slope_names`).
        """
        out = []
        for n in self.powers:
            m = n - 1
            if m == 0:
                out.append(delta)
            elif m == 1:
                out.append(speed * delta + delta**2 / 2)
            elif m > 1:
                out.append(_power(speed, m) * delta + m * _power(speed, m - 1) * delta**2 / 2)
        return out

    def coefficients(self, params: ModelParameters) -> list[float]:
        """The law's coefficients of a model (its :attr:`fields`), in the order of :attr:`names`."""
        return [getattr(params, name) for name in self.fields]

    def model_fields(self, values: Mapping[str, float]) -> dict[str, float]:
        """:class:`ModelParameters` keyword arguments from coefficients by name."""
        return {f: values[name] for name, f in zip(self.names, self.fields)}

    def fields_of(self, holder: object) -> dict[str, float]:
        """:class:`ModelParameters` keyword arguments from an object that holds the
        coefficients under the same fields (a model, the virtual device's ``[friction]``)."""
        return {f: getattr(holder, f) for f in self.fields}

    def speed_at(self, coefficients: Sequence[float], torque: float, factor: float = 1.0) -> float:
        """The speed w >= 0 at which ``factor`` D(w) = ``torque``, forward motion.

        0 when factor D(0) already reaches the torque, inf when D never does. Closed form for
        a law of degree 2 or less, with non-negative coefficients (D grows with w); else the
        root of the monotonic D by bisection (scipy.optimize.brentq).

        Parameters
        ----------
        coefficients : sequence of float
            The coefficients, in the order of :attr:`names` (non-negative).
        torque : float
            N m, what ``factor`` D must reach.
        factor : float, optional
            How many times D counts (2: the mirror of a braking pass).

        Returns
        -------
        float
            rad/s, the speed (inf if none).
        """
        terms = {n: factor * a for a, n in zip(coefficients, self.powers)}
        c = (terms.pop(0) if 0 in terms else 0.0) - torque
        if c >= 0:
            return 0.0
        if set(terms) <= {1, 2}:
            b, a = terms.get(1, 0.0), terms.get(2, 0.0)
            if a > 0:
                return (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
            if b > 0:
                return -c / b
            return math.inf
        if not any(a > 0 for a in terms.values()):
            return math.inf

        def excess(w: float) -> float:
            return c + sum(a * w**n for n, a in terms.items())

        return _bisect(excess)


def _power(speed: np.ndarray, n: int) -> np.ndarray:
    """speed^n, products for the low powers as the law's regressors have always been made."""
    if n == 1:
        return speed
    if n == 2:
        return speed * speed
    return speed**n


def _power_term(a: ca.SX, Omega: ca.SX, n: int) -> ca.SX:
    """a Omega^n as a CasADi expression: a, a Omega or a Omega**n."""
    if n == 0:
        return a
    return a * Omega if n == 1 else a * Omega**n


def _bisect(excess: Callable[[float], float]) -> float:
    """The root of an increasing function with excess(0) < 0, to the last bit (bisection)."""
    low, high = 0.0, 1.0
    while excess(high) < 0:
        low, high = high, 2 * high
    while True:
        mid = low + (high - low) / 2
        if mid in (low, high):
            return high
        if excess(mid) < 0:
            low = mid
        else:
            high = mid


def _sum(terms: list[ca.SX]) -> ca.SX:
    total = terms[0]
    for term in terms[1:]:
        total = total + term
    return total


FRICTION = FrictionLaw(
    names=("a1", "a2", "a3"), powers=(0, 1, 2), fields=("coulomb", "viscous", "quadratic")
)
"""The paper's dissipation D = (a1 + a3 Omega^2) sign(Omega) + a2 Omega (docs/method.md §3):
Coulomb, viscous and quadratic friction."""
