"""Figures (PNG, matplotlib Agg): what people would rather look at than read.

Only drawing here; the numbers come from the library. Every figure is written atomically
(temporary file in the same folder, then renamed).
"""

from __future__ import annotations

import io
import os
import tempfile
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = [
    "encoder_error_figure",
    "errors_figure",
    "experiment_figures",
    "figure_png",
    "motion_figure",
    "plan_figure",
    "plot_tracking",
    "save_figure",
    "tracking_figure",
]

ARCSEC = np.degrees(1.0) * 3600.0
"""Arcseconds per radian."""


def save_figure(fig: Figure, path: str | os.PathLike) -> None:
    """Write ``fig`` as PNG to ``path`` atomically, with the usual file permissions."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".png", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, format="png")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def plot_tracking(
    path: str | os.PathLike,
    t: np.ndarray,
    reference: np.ndarray,
    output: np.ndarray,
    title: str,
) -> None:
    """The paper's Fig. 4 (:func:`tracking_figure`) written to ``path``."""
    save_figure(tracking_figure(t, reference, output, title), path)


def tracking_figure(t: np.ndarray, reference: np.ndarray, output: np.ndarray, title: str) -> Figure:
    """The paper's Fig. 4: reference speed (r), output (y) and error (e) of the reverse pass.

    Parameters
    ----------
    t : array
        s, reverse-pass time.
    reference, output : arrays
        rad/s, the mirrored speed and the speed the body had (or its estimate).
    title : str
        The figure's title.
    """
    fig = Figure(figsize=(7.0, 5.0), dpi=120)
    FigureCanvasAgg(fig)
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    top.plot(t, reference, color="C0", label="reference r (mirror of the braking)")
    top.plot(t, output, color="C1", linestyle="--", label="output y")
    top.set_ylabel("speed [rad/s]")
    top.legend(loc="best", fontsize="small")
    top.grid(True, alpha=0.3)
    top.set_title(title)
    bottom.plot(t, output - reference, color="C3", linewidth=0.6, label="error e = y - r")
    bottom.set_xlabel("reverse time t' [s]")
    bottom.set_ylabel("error [rad/s]")
    bottom.grid(True, alpha=0.3)
    bottom.legend(loc="best", fontsize="small")
    fig.tight_layout()
    return fig


def plot_motion(
    path: str | os.PathLike,
    braking: tuple[np.ndarray, np.ndarray],
    reverse: tuple[np.ndarray, np.ndarray],
    undamped: tuple[np.ndarray, np.ndarray],
    damped: tuple[np.ndarray, np.ndarray],
    title: str,
) -> None:
    """The paper's Fig. 3: the symmetric semi-program motion (1), free undamped (2), damped (3).

    Each argument is (t, Omega): the braking from the release, the reverse (its time shifted
    to follow the braking, its speed as a magnitude so that the symmetry shows), and the two
    free motions from the same release with the motor off.
    """
    save_figure(motion_figure(braking, reverse, undamped, damped, title), path)


def motion_figure(braking, reverse, undamped, damped, title: str) -> Figure:
    """:func:`plot_motion`'s figure, its legend below the axes (inside, it covered the
    curves of a long braking). ``undamped`` and ``damped`` may be None (a real rig's logs
    have no free motions: only the virtual device can release the body with the motor off
    in a simulation)."""
    fig = Figure(figsize=(7.0, 4.8), dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    tb, wb = braking
    tr, wr = reverse
    ax.plot(tb, wb, color="C0", label="(1) braking, then reverse (semi-program motion)")
    ax.plot(tb[-1] + tr, np.abs(wr), color="C0", linestyle="--")
    if undamped is not None:
        ax.plot(*undamped, color="C2", linewidth=0.8, label="(2) free undamped motion")
    if damped is not None:
        ax.plot(*damped, color="C3", linewidth=0.8, label="(3) free damped motion")
    ax.axvline(tb[-1], color="grey", linewidth=0.6, alpha=0.6)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|speed| [rad/s]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    fig.legend(loc="outside lower center", fontsize="small", ncol=2)
    ax.set_title(title)
    return fig


def plot_errors(
    path: str | os.PathLike, labels: list[str], errors: dict[str, np.ndarray], title: str
) -> None:
    """Bar chart of |relative error| per axis for each method (log scale)."""
    save_figure(errors_figure(labels, errors, title), path)


def errors_figure(
    labels: list[str],
    errors: dict[str, np.ndarray],
    title: str,
    ylabel: str = "|relative error| of J_k",
) -> Figure:
    """:func:`plot_errors`'s figure, its legend below the axes (inside, it covered the
    tallest bars). ``ylabel`` names what the bars are (a real rig has no true values: its
    report shows each method's difference from the least squares)."""
    fig = Figure(figsize=(7.5, 4.8), dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    width = 0.8 / max(len(errors), 1)
    x = np.arange(len(labels))
    for i, (method, values) in enumerate(errors.items()):
        ax.bar(x + (i - (len(errors) - 1) / 2) * width, np.abs(values), width, label=method)
    ax.set_yscale("log")
    ax.set_xticks(x, labels, fontsize="small")
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.3)
    fig.legend(loc="outside lower center", fontsize="small", ncol=3)
    ax.set_title(title)
    return fig


def figure_png(fig: Figure) -> bytes:
    """``fig`` as PNG bytes (the report inlines them; nothing is written)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()


PLOT_POINTS = 20_000
"""At most this many points per curve of :func:`experiment_figures` (a 10 kHz log of ten
minutes has six million rows; the figure cannot show more than its pixels)."""


def experiment_figures(exp, virtual=None) -> list[tuple[str, Figure]]:
    """The figures an experiment folder's logs allow, as (file name, figure), per stage:

    - ``motion_stageN.png`` (paper Fig. 3): the forward run's smoothed braking speed, then
      the reverse's, from the logs; with the free undamped and damped motions from the same
      release when ``virtual`` (the virtual device, rsp_inertia.plant.config.Virtual) is
      given: a simulation can release the body with the motor off, a rig's logs hold no
      such run, and ``report`` never reads virtual.toml;
    - ``tracking_stageN.png`` (paper Fig. 4), when the stage has its ``program.csv``: the
      program's reference speed against the reverse log's smoothed speed.

    A stage without its forward braking and reverse logs is left out.
    """
    from rsp_inertia.estimation.smoothing import smooth_log
    from rsp_inertia.plant.logs import read_device_log, read_program
    from rsp_inertia.plant.virtual import free_motion

    device = exp.device
    figures = []
    for st in exp.stages():
        if not (exp.braking_path(st).is_file() and exp.reverse_path(st).is_file()):
            continue
        braking = read_device_log(exp.braking_path(st), device, "braking")
        reverse = read_device_log(exp.reverse_path(st), device, "reverse")
        sb = smooth_log(braking, device.encoder.quantum)
        sr = smooth_log(reverse, device.encoder.quantum)
        every_b = max(1, len(sb.t) // PLOT_POINTS)
        every_r = max(1, len(sr.t) // PLOT_POINTS)
        free = (None, None)
        if virtual is not None:
            duration = float(braking.t[-1] + reverse.t[-1])
            free = tuple(
                free_motion(device, st, virtual, duration, damped=damped)[::2]
                for damped in (False, True)
            )
        figures.append((
            f"motion_stage{st}.png",
            motion_figure(
                (sb.t[::every_b], sb.omega[::every_b]),
                (sr.t[::every_r], sr.omega[::every_r]),
                *free,
                f"Stage {st}: RSP motion" + (" and free motions" if virtual else "")
                + " (paper Fig. 3)",
            ),
        ))
        if exp.program_path(st).is_file():
            prog = read_program(exp.program_path(st), device.encoder)
            n = min(len(prog.t), len(sr.t))
            figures.append((
                f"tracking_stage{st}.png",
                tracking_figure(
                    prog.t[:n:every_r],
                    prog.omega_ref[:n:every_r],
                    sr.omega[:n:every_r],
                    f"Stage {st}: reverse pass, reference and smoothed output (paper Fig. 4)",
                ),
            ))
    return figures


def plan_figure(plan, path: str | os.PathLike) -> Path:
    """``rsp-inertia plan``'s trade-off: predicted worst std against duration and launch speed.

    Left: the best predicted worst std of J_k within each total duration (the plan's front),
    the chosen plan and device.toml's protocol before. Right: per stage, the predicted worst
    std of the stage's own J_k against the launch speed (the best braking torque at each,
    other stages as chosen), the chosen speed starred.
    """
    fig = Figure(figsize=(11, 4.5))
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2)
    front = plan.front
    left.step(front[:, 0], front[:, 1], where="post", label="best within the duration")
    left.plot(plan.duration, plan.worst, "o", color="C3", label="plan")
    if plan.current_std is not None:
        now = sum(c.run_time for c in plan.current)
        left.plot(now, plan.current_std, "s", color="C2", label="device.toml before")
    left.axvline(plan.max_duration, color="0.6", ls="--", lw=1, label="budget")
    left.set_xlabel("experiment's motion time, s")
    left.set_ylabel("predicted worst std of J_k, kg m^2")
    left.set_yscale("log")
    left.legend(fontsize=8)
    left.grid(alpha=0.3)
    stages = sorted({row[0] for row in plan.tradeoff})
    for stage in stages:
        rows = [r for r in plan.tradeoff if r[0] == stage and r[2] is not None]
        if not rows:
            continue
        line = right.plot([r[1] for r in rows], [r[3] for r in rows], "o-", label=f"stage {stage}")
        chosen = plan.chosen[stage - 1]
        own = plan.axis_std[plan.axis_stage == stage].max()
        right.plot(chosen.launch_speed, own, "*", ms=14, color=line[0].get_color())
    right.set_xlabel("launch speed, rad/s")
    right.set_ylabel("predicted worst std of the stage's J_k, kg m^2")
    right.set_yscale("log")
    right.legend(fontsize=8)
    right.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    return Path(path)


def encoder_error_figure(known, path: str | os.PathLike, title: str = "") -> Path:
    """``rsp-inertia calibrate``'s encoder error curve: what the encoder reads beyond the true
    angle, e(phi), over a turn, with its 1-std band, and each order's part; below, e'(phi), by
    which the encoder scales every speed (the kinetic energy by 2 e').

    ``known``: the calibrated terms (rsp_inertia.estimation.tensor.KnownTerms) with encoder
    coefficients theta_e and their covariance.
    """
    from rsp_inertia.plant.transducers import error_basis, error_slope_basis

    orders = known.orders
    phi = np.linspace(0.0, 2.0 * np.pi, 721)
    cov = known.cov[known.encoder_slice, known.encoder_slice]
    fig = Figure(figsize=(8.0, 6.0), dpi=120)
    FigureCanvasAgg(fig)
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    deg = np.degrees(phi)
    for ax, basis, scale, label in (
        (top, error_basis(phi, orders), ARCSEC, "reading error e [arcsec]"),
        (bottom, error_slope_basis(phi, orders), 1e6, "speed scale error e' [ppm]"),
    ):
        value = basis @ known.encoder * scale
        std = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", basis, cov, basis), 0.0)) * scale
        unit = "arcsec" if ax is top else "ppm"
        ax.fill_between(
            deg, value - std, value + std, color="C0", alpha=0.3, lw=0,
            label=f"+- 1 std (at most {std.max():.2g} {unit})",
        )
        ax.plot(deg, value, color="C0", lw=2, label="e, all orders" if ax is top else "e'")
        if ax is top:
            for n in range(orders):
                part = basis[:, 2 * n : 2 * n + 2] @ known.encoder[2 * n : 2 * n + 2] * scale
                ax.plot(deg, part, lw=1, ls="--", color=f"C{n + 1}", label=f"order {n + 1}")
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small", ncol=2)
    bottom.set_xlabel("encoder angle phi [deg]")
    bottom.set_xticks(np.arange(0, 361, 45))
    top.set_title(title or "encoder reading error from the calibration")
    fig.tight_layout()
    save_figure(fig, path)
    return Path(path)
