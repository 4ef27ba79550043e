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


def _overlaps_any_axes(fig, legend) -> bool:
    box = legend.get_window_extent()
    return any(box.overlaps(ax.get_window_extent()) for ax in fig.axes)


def test_the_encoder_figure_shows_every_curve_and_its_std():
    # A calibration of two orders whose stds are 1% of the error (the demo's are 0.4%): a
    # band of +- 1 std around e would be a few pixels at most; the figure draws the std on
    # its own axes, where it fills them, and keeps the legends beside the axes.
    from rsp_inertia.estimation.known_terms import KnownTerms
    from rsp_inertia.plots import encoder_error_figure

    coefficients = np.array([2e-4, 1e-4, -5e-5, 3e-5])
    exact = KnownTerms.exact(2, encoder=coefficients)
    cov = np.zeros_like(exact.cov)
    part = exact.layout.slice("encoder")
    cov[part, part] = np.diag((0.01 * coefficients) ** 2)
    fig = encoder_error_figure(KnownTerms(exact.gains, exact.inertia, exact.gravity, cov,
                                          calibrated=True, encoder=coefficients))
    fig.canvas.draw()
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 3  # e with its orders, e', the stds
    for legend in legends:
        assert not _overlaps_any_axes(fig, legend)
    std_axes = fig.axes[2]
    for ax in (std_axes, fig.axes[3]):  # the std of e, and of e' on the twin axis
        (line,) = ax.get_lines()
        low, high = ax.get_ylim()
        # The curve reaches past half the axes' height: visible, unlike the band it replaces.
        assert line.get_ydata().max() > low + 0.5 * (high - low)


def test_a_free_motion_that_swings_back_stays_drawn_and_its_turns_are_marked():
    # A damped motion whose speed changes sign at known times: cos(2 pi t / 8) crosses zero
    # at t = 2, 6, 10 s. Drawn as a signed speed above a floor of 0, its swings back vanished.
    t = np.linspace(0.0, 12.0, 1201)
    damped = (t, 3.0 * np.cos(2 * np.pi * t / 8.0))
    braking = (t[:601], np.linspace(12.0, 0.0, 601))
    fig = motion_figure(braking, braking, None, damped, "stage 1")
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    (label,) = [name for name in lines if name.startswith("(3)")]
    assert np.all(lines[label].get_ydata() >= 0)
    assert np.abs(lines[label].get_ydata()).max() == 3.0
    markers = [line for line in ax.get_lines() if line.get_marker() == "v"]
    assert markers and np.allclose(markers[0].get_xdata(), [2.0, 6.0, 10.0], atol=1e-3)
    assert "turns back" in label


def test_titles_and_labels_say_what_is_shown(tmp_path):
    # No "paper Fig." for a reader without the paper, no control jargon ("output y").
    from rsp_inertia.plots import cone_conditioning_figure, tracking_figure

    t = np.linspace(0.0, 5.0, 50)
    figures = [
        tracking_figure(t, -t, -t * 1.001, "Stage 1: reverse run, programmed and measured speed"),
        cone_conditioning_figure(),
    ]
    for fig in figures:
        fig.canvas.draw()
        texts = [text.get_text() for text in fig.findobj(lambda o: hasattr(o, "get_text"))]
        joined = " | ".join(texts)
        assert "paper" not in joined and "Fig." not in joined, joined
        assert "output y" not in joined and "reference r" not in joined, joined


def test_the_figures_drawn_from_logs_say_what_they_show(default_logs):
    # The motion figures of a simulated folder, as report draws them: their
    # titles and labels name the quantities, not the paper's figure numbers or control terms.
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.plots import experiment_figures

    figures = experiment_figures(open_experiment(default_logs))
    # (no program.csv there, an ideal reverse: the tracking figures' labels are checked above)
    assert {name for name, _ in figures} == {"motion_stage1.png", "motion_stage2.png"}
    for name, fig in figures:
        fig.canvas.draw()
        joined = " | ".join(t.get_text() for t in fig.findobj(lambda o: hasattr(o, "get_text")))
        assert "paper" not in joined and "Fig." not in joined, (name, joined)
        assert "output y" not in joined and "reference r" not in joined, (name, joined)
