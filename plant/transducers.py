"""The rig's transducers: the angle encoder's reading error and the drive's transmission, the
two imperfections that act on every pass (docs/method.md §3, "Encoder and drive").

**Encoder.** A real encoder reads phi_r = phi + z + e(phi): z its zero offset (what it reads
where the body frame's phi = 0, body y up: docs/method.md §1; an encoder zeroed off that
position), e periodic in the encoder's angle (an eccentric disc or ring, bearing runout,
graduation errors). Its harmonic series,

    e(phi) = sum_n c_n cos(n phi) + s_n sin(n phi),      n = 1 .. N,

is linear in the coefficients theta_e = [c_1, s_1, c_2, s_2, ...] (rad): :func:`error_basis`
gives the columns, :func:`error_slope_basis` their derivative e'(phi). The simulator reads
floor((phi + z + e(phi)) / q) q (:func:`encoder_reading`); the estimators take the reading
back to the true angle (:func:`true_angle`). An error curve stated as an amplitude and a phase per
order, e = sum_n A_n sin(n phi + p_n), has c_n = A_n sin p_n and s_n = A_n cos p_n
(:func:`error_coefficients`).

**Drive.** The logged torque tau is the motor's. Between motor and body a transmission loses
a fraction of the power it carries: while the motor drives the body (tau Omega > 0) the body
receives eta_d tau; while the body drives the motor back (tau Omega < 0) the body must give
tau / eta_b. With the torque constant's gain g (logged = g x the motor's actual torque),
the body receives h_d tau or h_b tau (:func:`drive_gains`),

    h_d = eta_d / g,       h_b = 1 / (eta_b g),

by the direction of power flow (:func:`power_flow_split`, the one place the split is made:
the simulator's :func:`delivered_torque` and the estimators' split of the logged work both
call it). Only h_d and h_b enter any work-energy balance: the torque constant and the two
efficiencies are not separable by such a measurement, only their two combinations are.

**Temperature.** A motor's torque constant follows its magnets' temperature: k(T_mag) =
k(T_ref) (1 + alpha (T_mag - T_ref)), alpha about -0.0011/K for NdFeB. Where the logger
logs a (winding or housing) temperature T, the magnets follow it through a first-order lag,
dT_mag/dt = (T - T_mag) / tau (:func:`magnet_temperature`), and the torque the body
receives per unit of logged torque carries the factor 1 + alpha (T_mag - T_ref)
(:func:`thermal_torque_factor`, docs/method.md §3, "Temperature"): h_d and h_b are the
gains at T_ref. Where no temperature is logged, the magnets' rise can be modelled from the
logged torque itself: the winding heated by its squares through its thermal time constant,
the magnets behind it (:func:`motor_rises`, the shape of the warming identify fits).
The virtual device's drive applies the same factor to both gains
(:func:`thermal_gains`).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "angle_error",
    "delivered_torque",
    "drive_gains",
    "encoder_reading",
    "error_basis",
    "error_coefficients",
    "error_slope_basis",
    "logged_torque",
    "magnet_temperature",
    "motor_rises",
    "power_flow_split",
    "thermal_gains",
    "thermal_torque_factor",
    "torque_constant_factor",
    "true_angle",
]


def error_basis(phi, orders: int) -> np.ndarray:
    """de/dtheta_e at each angle: columns cos(phi), sin(phi), cos(2 phi), ... sin(orders phi),
    shape phi.shape + (2 orders,) (module docstring)."""
    phi = np.asarray(phi, dtype=float)
    n = np.arange(1, orders + 1)
    angle = phi[..., None] * n
    out = np.empty(phi.shape + (2 * orders,))
    out[..., 0::2] = np.cos(angle)
    out[..., 1::2] = np.sin(angle)
    return out


def error_slope_basis(phi, orders: int) -> np.ndarray:
    """de'/dtheta_e, e' = de/dphi: columns -n sin(n phi), n cos(n phi), shape as
    :func:`error_basis`."""
    phi = np.asarray(phi, dtype=float)
    n = np.arange(1, orders + 1)
    angle = phi[..., None] * n
    out = np.empty(phi.shape + (2 * orders,))
    out[..., 0::2] = -n * np.sin(angle)
    out[..., 1::2] = n * np.cos(angle)
    return out


def angle_error(phi, coefficients) -> np.ndarray:
    """e(phi), rad: the encoder's reading error at true angle ``phi`` (rad) for coefficients
    theta_e = [c_1, s_1, c_2, s_2, ...] (module docstring)."""
    coefficients = np.asarray(coefficients, dtype=float)
    if coefficients.size == 0:
        return np.zeros(np.shape(phi))
    return error_basis(phi, coefficients.size // 2) @ coefficients


def error_coefficients(amplitude, phase_deg) -> np.ndarray:
    """theta_e of e = sum_n A_n sin(n phi + p_n): c_n = A_n sin p_n, s_n = A_n cos p_n."""
    amplitude = np.asarray(amplitude, dtype=float)
    phase = np.radians(np.asarray(phase_deg, dtype=float))
    out = np.empty(2 * amplitude.size)
    out[0::2] = amplitude * np.sin(phase)
    out[1::2] = amplitude * np.cos(phase)
    return out


def encoder_reading(
    phi, quantum: float, coefficients=(), zero: float = 0.0
) -> np.ndarray | float:
    """What the encoder reads at true angle ``phi``: floor((phi + z + e(phi)) / q) q
    (docs/files.md, logs; z the encoder's zero offset, module docstring).

    Parameters
    ----------
    phi : float or array_like
        rad, the true angle.
    quantum : float
        q, rad, the encoder's step.
    coefficients : sequence of float, optional
        theta_e, rad, of the reading error e (module docstring); e = 0 without them.
    zero : float, optional
        z, rad: the encoder's zero offset, what it reads at phi = 0 (module docstring).

    Returns
    -------
    float or numpy.ndarray
        rad, the reading: a number for a number (a drive's loop).
    """
    read = np.asarray(phi, dtype=float)
    if len(coefficients):
        read = read + angle_error(read, coefficients)
    if zero:
        read = read + zero
    out = np.floor(read / quantum) * quantum
    return float(out) if out.ndim == 0 else out


def true_angle(reading, coefficients, zero: float = 0.0) -> np.ndarray:
    """The true angle phi whose reading is ``reading``: phi + z + e(phi) = reading, solved by
    fixed-point iteration (|e'| << 1: each step gains the factor |e'|, so four steps leave
    (|e'|)^4 of e, far below rounding for any real encoder).

    Parameters
    ----------
    reading : float or array_like
        rad, what the encoder read.
    coefficients : sequence of float
        theta_e, rad, of the reading error e (module docstring).
    zero : float, optional
        z, rad, the encoder's zero offset.

    Returns
    -------
    numpy.ndarray
        rad, the true angle.
    """
    reading = np.asarray(reading, dtype=float) - zero
    coefficients = np.asarray(coefficients, dtype=float)
    if coefficients.size == 0 or not np.any(coefficients):
        return reading
    phi = reading - angle_error(reading, coefficients)
    for _ in range(3):
        phi = reading - angle_error(phi, coefficients)
    return phi


def drive_gains(
    torque_gain: float = 1.0, efficiency_driving: float = 1.0, efficiency_backdriven: float = 1.0
) -> tuple[float, float]:
    """(h_d, h_b): the torque the body receives per unit of logged torque while the motor
    drives it, and while the body drives the motor back (module docstring).

    Parameters
    ----------
    torque_gain : float, optional
        g, logged torque per unit of the motor's actual torque.
    efficiency_driving : float, optional
        eta_d, the transmission's efficiency while the motor drives the body.
    efficiency_backdriven : float, optional
        eta_b, its efficiency while the body drives the motor back.

    Returns
    -------
    h_d, h_b : float
        eta_d / g and 1 / (eta_b g).
    """
    return efficiency_driving / torque_gain, 1.0 / (efficiency_backdriven * torque_gain)


def thermal_gains(gains: tuple, tempco: float, rise) -> tuple:
    """(h_d, h_b) of a motor whose magnets are ``rise`` kelvin above the torque constant's
    reference temperature: both times 1 + alpha rise (module docstring).

    Parameters
    ----------
    gains : tuple of float
        (h_d, h_b) at the reference temperature, :func:`drive_gains`.
    tempco : float
        alpha, 1/K, the torque constant's relative change per kelvin.
    rise : float or array_like
        K, T_magnet - T_ref: a number, or one per row.

    Returns
    -------
    tuple
        (h_d, h_b) x (1 + alpha rise): numbers, or arrays shaped like ``rise``; ``gains``
        itself when alpha = 0 (the gains then do not depend on the temperature).
    """
    if tempco == 0.0:
        return gains
    factor = torque_constant_factor(tempco, rise)
    return gains[0] * factor, gains[1] * factor


def torque_constant_factor(alpha: float, rise):
    """Kt(T_mag) / Kt(T_ref) = 1 + alpha (T_mag - T_ref) (module docstring): the one formula
    behind :func:`thermal_gains` (the virtual device) and :func:`thermal_torque_factor`
    (the compensation of logged torques).

    Parameters
    ----------
    alpha : float
        1/K, the torque constant's relative change per kelvin of the magnets.
    rise : float or array_like
        K, T_mag - T_ref.

    Returns
    -------
    float or numpy.ndarray
        The factor, shaped like ``rise``.
    """
    return 1.0 + alpha * (rise if np.ndim(rise) == 0 else np.asarray(rise, dtype=float))


def _back_driven(torque, motion):
    """Where the body drives the motor back: torque x motion < 0 (numbers or arrays)."""
    return torque * motion < 0.0


def power_flow_split(torque, motion) -> tuple[np.ndarray, np.ndarray]:
    """``torque`` split by the direction of power flow: (its driving part, where torque x motion
    >= 0, and its back-driven part, where torque x motion < 0); the two add up to ``torque``.

    ``motion`` is the sign of the speed, or an angle increment (its sign is the direction).
    Where nothing moves (motion 0) the torque counts as driving: it does no work anyway, and
    a drive that starts a body from rest drives it.
    """
    torque = np.asarray(torque, dtype=float)
    back = _back_driven(torque, np.asarray(motion, dtype=float))
    return np.where(back, 0.0, torque), np.where(back, torque, 0.0)


def delivered_torque(command, motion, gains: tuple[float, float]) -> np.ndarray | float:
    """The torque the body receives, N m, for the logged ``command``: h_d x the driving part
    + h_b x the back-driven part.

    Parameters
    ----------
    command : float or array_like
        N m, the logged command.
    motion : float or array_like
        The direction the body moves in (a sign, or an angle increment).
    gains : tuple of float
        (h_d, h_b), :func:`drive_gains`.

    Returns
    -------
    float or numpy.ndarray
        N m: a number for numbers.
    """
    if np.ndim(command) == 0 and np.ndim(motion) == 0:  # one sample: plain numbers, fast
        return float(command) * (gains[1] if _back_driven(command, motion) else gains[0])
    driving, back = power_flow_split(command, motion)
    return gains[0] * driving + gains[1] * back


def logged_torque(torque, motion, gains: tuple[float, float]) -> np.ndarray | float:
    """The logged command, N m, that makes the body receive ``torque``: the inverse of
    :func:`delivered_torque` (both gains are positive, so the command has the torque's sign
    and the same split applies).

    Parameters
    ----------
    torque : float or array_like
        N m, the torque the body receives.
    motion : float or array_like
        The direction the body moves in (a sign, or an angle increment).
    gains : tuple of float
        (h_d, h_b), :func:`drive_gains`.

    Returns
    -------
    float or numpy.ndarray
        N m, the command: a number for numbers.
    """
    if np.ndim(torque) == 0 and np.ndim(motion) == 0:
        return float(torque) / (gains[1] if _back_driven(torque, motion) else gains[0])
    driving, back = power_flow_split(torque, motion)
    return driving / gains[0] + back / gains[1]


def magnet_temperature(
    temperature, t, lag: float | None, start_lag: float = 0.0
) -> np.ndarray:
    """T_mag at each row: the logged temperature through the first-order lag dT_mag/dt =
    (T - T_mag) / tau, T linear between rows, T_mag = T + ``start_lag`` at the first row
    (module docstring).

    Exact for any time stamps: over a step h with slope s = (T_{k+1} - T_k) / h the lag
    e = T_mag - T obeys de/dt = -e / tau - s, so e_{k+1} = (e_k + s tau) exp(-h / tau) - s tau.

    Parameters
    ----------
    temperature : array_like, shape (n,)
        degrees C, the logged temperature T.
    t : array_like, shape (n,)
        s, the rows' time stamps, increasing.
    lag : float or None
        tau, s; None: no lag, T_mag = T.
    start_lag : float, optional
        K, T_mag - T at the first row (0: the magnets at the logged temperature; a reverse
        pass that follows its braking starts where the braking left them,
        rsp_inertia.plant.logs.reverse_start_lag).

    Returns
    -------
    numpy.ndarray, shape (n,)
        degrees C, T_mag.

    Examples
    --------
    >>> magnet_temperature([20.0, 30.0, 30.0], [0.0, 0.0 + 1e-12, 1.0], 1.0).round(4)
    array([20.    , 20.    , 26.3212])
    """
    temperature = np.asarray(temperature, dtype=float)
    if lag is None or temperature.size == 0:
        return temperature.copy()
    h = np.diff(np.asarray(t, dtype=float))
    slope_tau = np.diff(temperature) / h * lag
    decay = np.exp(-h / lag)
    lagging = np.empty(temperature.size)  # e = T_mag - T
    e = float(start_lag)
    lagging[0] = e
    for k, (d, st) in enumerate(zip(decay.tolist(), slope_tau.tolist(), strict=True), 1):
        e = (e + st) * d - st
        lagging[k] = e
    return temperature + lagging


def motor_rises(
    heat_rate, t, tau_w: float, tau_m: float | None, start: tuple[float, float] = (0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """The winding's and the magnets' rises at each row of a two-node thermal model driven by
    ``heat_rate`` held over each step (module docstring, "Temperature"):

        tau_w dw/dt = P - w,        tau_m dm/dt = w - m      (tau_m None or 0: m = w),

    in the units of P (unit thermal resistance: a rise per unit of P, identify's warming
    shape). Exact for any time stamps: over a step h at a held P,
    w' = e_w w + (1 - e_w) P and m' = e_m m + g w + (1 - e_m - g) P, e = exp(-h / tau),
    g = tau_w (e_w - e_m) / (tau_w - tau_m) (h e_m / tau_m at tau_w = tau_m).

    Parameters
    ----------
    heat_rate : array_like, shape (n - 1,)
        P over each step [t_k, t_k+1).
    t : array_like, shape (n,)
        s, the rows' time stamps, increasing.
    tau_w : float
        s, > 0, the winding's time constant.
    tau_m : float or None
        s, the magnets' lag behind the winding; None or 0: none.
    start : (float, float)
        (w, m) at the first row.

    Returns
    -------
    winding, magnet : numpy.ndarray, shape (n,)
        The rises at the rows, in P's units.

    Examples
    --------
    >>> w, m = motor_rises([1.0, 1.0], [0.0, 1.0, 2.0], 1.0, None)
    >>> bool(np.allclose(w, 1 - np.exp(-np.array([0.0, 1.0, 2.0]))) and np.all(m == w))
    True
    """
    P = np.asarray(heat_rate, dtype=float)
    h = np.diff(np.asarray(t, dtype=float))
    ew = np.exp(-h / tau_w)
    # x' = a x + b over each step: the winding's (a, b) = (e_w, (1 - e_w) P).
    w = _recurrence(ew, (1.0 - ew) * P, start[0])
    if not tau_m:
        return w, w.copy()
    em = np.exp(-h / tau_m)
    if abs(tau_w - tau_m) <= 1e-9 * tau_w:  # the double root: the limit of the general form
        g = h / tau_m * em
    else:
        g = tau_w * (ew - em) / (tau_w - tau_m)
    return w, _recurrence(em, g * w[:-1] + (1.0 - em - g) * P, start[1])


RECURRENCE_BLOCK = 65536
"""Rows :func:`_recurrence` takes into Python floats at a time (its memory, whatever the
log's length)."""


def _recurrence(a: np.ndarray, b: np.ndarray, x0: float) -> np.ndarray:
    """x_0 = ``x0``, x_k = a_k x_(k-1) + b_k (k from 1; ``a``, ``b`` of the steps): a first-order
    linear recurrence, in blocks of :data:`RECURRENCE_BLOCK` rows (time linear in the rows,
    memory bounded by the arrays')."""
    x = np.empty(a.size + 1)
    x[0] = last = float(x0)
    for lo in range(0, a.size, RECURRENCE_BLOCK):
        hi = min(lo + RECURRENCE_BLOCK, a.size)
        block = []
        for ak, bk in zip(a[lo:hi].tolist(), b[lo:hi].tolist()):
            last = ak * last + bk
            block.append(last)
        x[lo + 1 : hi + 1] = block
    return x


def thermal_torque_factor(
    temperature, t, alpha: float, lag: float | None, t_ref: float, start_lag: float = 0.0
) -> np.ndarray:
    """1 + alpha (T_mag - T_ref) at each row: the torque the body receives per unit of the
    torque logged at T_ref's scale (module docstring; docs/method.md §3, "Temperature").

    Parameters
    ----------
    temperature : array_like, shape (n,)
        degrees C, the logged temperature T.
    t : array_like, shape (n,)
        s, the rows' time stamps.
    alpha : float
        1/K, the torque constant's relative change per kelvin of the magnets.
    lag : float or None
        s, tau of :func:`magnet_temperature`; None: no lag.
    t_ref : float
        degrees C, the magnet temperature at which the torque's scale holds.
    start_lag : float, optional
        K, T_mag - T at the first row (:func:`magnet_temperature`).

    Returns
    -------
    numpy.ndarray, shape (n,)
        The factor, dimensionless.
    """
    return torque_constant_factor(
        alpha, magnet_temperature(temperature, t, lag, start_lag) - t_ref
    )
