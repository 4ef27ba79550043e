"""What the benchmark programs write: Markdown tables, figures, the command that made them."""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

__all__ = [
    "command_line",
    "fmt",
    "fmt_z",
    "markdown_table",
    "new_figure",
    "table_lines",
]


def command_line(program: str, argv: Sequence[str] | None = None) -> str:
    """``python -m benchmarks.<program> ARGS`` as typed: ``argv``, or this process's."""
    args = sys.argv[1:] if argv is None else list(argv)
    return " ".join(["python -m benchmarks." + program, *args])


def table_lines(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown table of already formatted cells: header, separator, one line per row."""
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(cells) + " |" for cells in rows]
    return lines


def markdown_table(rows: Sequence[dict], keys: Sequence[str], spec: Callable[[str], str]) -> list[str]:
    """The columns ``keys`` of dict rows; ``spec(key)`` is the format spec of a column."""
    return table_lines(keys, [[format(r[k], spec(k)) for k in keys] for r in rows])


def fmt(value: float | None, spec: str = ".1e") -> str:
    """``value`` formatted, or ``-`` for None."""
    return "-" if value is None else format(value, spec)


def fmt_z(value: float | None) -> str:
    """|err|/std: one decimal up to 1000, then a power of ten; ``-`` for None."""
    if value is None:
        return "-"
    return format(value, ".1f") if value < 1000 else format(value, ".0e")


def new_figure(panels: int, height: float):
    """A matplotlib Figure (no pyplot) of ``panels`` side by side sharing y; (fig, axes).

    Save it with :func:`rsp_inertia.plots.save_figure` (atomic).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.2 * panels + 1.0, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(1, panels, sharey=True, squeeze=False)[0]
