"""The figures' legends keep off the data: below the axes, never over bars or curves."""

import numpy as np

from rsp_inertia.plots import errors_figure, motion_figure


def _legend_and_axes(fig):
    fig.canvas.draw()
    legend = fig.legends[0].get_window_extent()
    axes = fig.axes[0].get_window_extent()
    return legend, axes


def test_the_errors_legend_covers_no_bar():
    # The demo's errors.png: the pendulum's bars reach the top at the last axes, where the
    # legend sat ("best" found no free corner).
    labels = [f"s{s} {d} deg" for s in (1, 2) for d in (0, 120, 240)]
    errors = {
        name: np.full(6, value)
        for name, value in (("RSP least squares", 1e-5), ("RSP node formula", 1e-4),
                            ("pendulum classic", 5e-2), ("pendulum damped fit", 5e-2),
                            ("pendulum best practice", 2e-4))
    }
    legend, axes = _legend_and_axes(errors_figure(labels, errors, "errors"))
    assert not legend.overlaps(axes)


def test_the_motion_legend_covers_no_curve():
    t = np.linspace(0.0, 30.0, 300)
    speed = 12.0 * (1 - t / 30.0)
    legend, axes = _legend_and_axes(
        motion_figure((t, speed), (t, -speed[::-1]), (t, np.full_like(t, 12.0)),
                      (t, 12.0 * np.exp(-t / 10)), "stage 2")
    )
    assert not legend.overlaps(axes)
