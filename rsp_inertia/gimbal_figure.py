"""The gimbal's conventions as a figure (docs/method.md §1, docs/gimbal.png).

One drawing of the biaxial gimbal with every convention the files and the commands share:
the inertial axes x1 y1 z1 (z1 up) and their origin O, where the two hinge axes meet; the
outer frame turning about z1 by psi and the horizontal shaft it carries, about which the
body turns by phi; the body's axes x y z at phi = 0 (y up, z along the shaft); the senses
of psi and phi; the gear (psi = lambda phi, lambda >= 0); the motor and the encoder on the
shaft's hinge. Beside the perspective, the two views a technician checks the senses in:
from above (psi, and the gear's sense) and from the +z end of the shaft (phi, the encoder,
the motor's torque).

The geometry is the model's (rsp_inertia.plant.geometry.axis_direction: the body-to-world
rotation Rz(psi) Rx(pi/2) Rz(phi), so the vertical in body axes is (sin phi, cos phi, 0)):
at psi = 0 the shaft's +z points along -y1 and the body's x along x1. The drawing turns the
outer frame by PSI_DRAWN so that no axis of the body hides one of the room's.

``python -m rsp_inertia.gimbal_figure [OUT]`` writes it (default docs/gimbal.png of the
source tree); the same code gives the same bytes (fixed size and resolution, no time stamp
or software name in the file), so tests/test_gimbal_figure.py can check the committed file.
"""

from __future__ import annotations

import io
import math
import sys
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, FancyArrowPatch, Rectangle

from rsp_inertia.infra.files import write_atomic

__all__ = [
    "DEFAULT_PATH",
    "DPI",
    "PSI_DRAWN",
    "SIZE",
    "VIEW_AZIMUTH_DEG",
    "gimbal_figure",
    "gimbal_png",
    "main",
]

SIZE = (14.0, 6.4)
"""Inches, the figure's width and height."""

DPI = 100
"""Dots per inch of the PNG."""

PSI_DRAWN = math.radians(20.0)
"""rad, the outer frame's angle psi in the perspective (any value: nothing depends on psi's
zero)."""

VIEW_AZIMUTH_DEG = -35.0
"""deg, the perspective's camera: between the shaft's +z end and the body's +x side, so that
both the outer frame's ring and the turn of phi show open."""

DEFAULT_PATH = Path(__file__).resolve().parent.parent / "docs" / "gimbal.png"
"""Where ``python -m rsp_inertia.gimbal_figure`` writes without an argument."""

_METADATA = {"Software": None}
"""PNG text chunks: none (matplotlib writes its version otherwise; Agg writes no date)."""

# Colours: the room grey, the outer frame blue, the shaft and body orange, the transducers.
_ROOM = "0.35"
_FRAME = "tab:blue"
_BODY = "tab:orange"
_AXES = {"x": "tab:red", "y": "tab:green", "z": "tab:purple"}
_MOTOR = "0.25"
_ENCODER = "tab:cyan"
_GEAR = "tab:brown"


def _frame_vectors(psi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body's x, y, z in room axes at phi = 0 for the outer frame at ``psi``: the columns
    of Rz(psi) Rx(pi/2)."""
    c, s = math.cos(psi), math.sin(psi)
    return np.array([c, s, 0.0]), np.array([0.0, 0.0, 1.0]), np.array([s, -c, 0.0])


def _circle(centre, u, v, radius: float, start_deg: float, stop_deg: float, n: int = 90):
    """Points of an arc centre + r (cos t u + sin t v), t from start to stop (deg): positive
    about u x v."""
    t = np.radians(np.linspace(start_deg, stop_deg, n))
    u, v = np.asarray(u, float)[:, None], np.asarray(v, float)[:, None]
    return np.asarray(centre, float)[:, None] + radius * (np.cos(t) * u + np.sin(t) * v)


def _line(ax, a, b, **style) -> None:
    ax.plot(*np.stack([a, b], axis=1), **style)


def _arrow3d(ax, start, vector, color, width: float = 2.0, ratio: float = 0.12) -> None:
    ax.quiver(*start, *vector, color=color, linewidth=width, arrow_length_ratio=ratio)


def _arc_arrow3d(ax, points: np.ndarray, normal, color: str) -> None:
    """An arc with a filled arrowhead at its end, in the arc's plane (of unit ``normal``):
    the sense of the rotation."""
    tip, before = points[:, -1], points[:, -6]
    d = tip - before
    d /= np.linalg.norm(d)
    side = np.cross(np.asarray(normal, float), d)
    length, half = 0.2, 0.09
    ax.plot(*points[:, :-4], color=color, linewidth=2.2)
    back = tip - length * d
    corners = np.array([[tip, tip], [back - half * side, back + half * side]])
    ax.plot_surface(corners[..., 0], corners[..., 1], corners[..., 2], color=color,
                    linewidth=0, shade=False)


def _cylinder(ax, centre, axis, u, v, radius: float, length: float, color: str) -> None:
    """A cylinder of ``radius`` along the unit ``axis`` (u, v across it), centred at
    ``centre``."""
    t = np.linspace(0.0, 2 * np.pi, 40)
    h = np.array([-length / 2, length / 2])
    T, H = np.meshgrid(t, h)
    points = (
        np.asarray(centre)[:, None, None]
        + radius * (np.cos(T)[None] * u[:, None, None] + np.sin(T)[None] * v[:, None, None])
        + H[None] * axis[:, None, None]
    )
    ax.plot_surface(*points, color=color, alpha=0.85, linewidth=0, shade=True)
    for end in h:
        ring = _circle(np.asarray(centre) + end * axis, u, v, radius, 0, 360, 40)
        ax.plot(*ring, color="0.1", linewidth=0.8)


def _box(ax, ex, ey, ez, half: tuple[float, float, float], color: str) -> None:
    """The body: a box centred at O with edges along the body's axes."""
    a, b, c = (h * e for h, e in zip(half, (ex, ey, ez)))
    for axis, (p, q) in ((a, (b, c)), (b, (c, a)), (c, (a, b))):
        for sign in (-1.0, 1.0):
            corners = np.array(
                [[sign * axis + i * p + j * q for j in (-1.0, 1.0)] for i in (-1.0, 1.0)]
            )
            ax.plot_surface(
                corners[..., 0], corners[..., 1], corners[..., 2],
                color=color, alpha=0.35, linewidth=0.6, edgecolor="0.3", shade=False,
            )


def _perspective(ax) -> None:
    """The 3-D drawing: room, outer frame, shaft, body, motor, encoder, gear, senses."""
    x, y, z = _frame_vectors(PSI_DRAWN)
    up = np.array([0.0, 0.0, 1.0])
    o = np.zeros(3)
    ring = 1.0  # the outer frame's radius
    base = -1.55

    # The room: z1 the vertical hinge axis through O; x1, y1 (horizontal) drawn as a triad
    # in a corner of the floor, parallel to the axes through O; the floor.
    _line(ax, [0, 0, base], [0, 0, 1.75], color=_ROOM, linewidth=1.0, linestyle="--")
    _arrow3d(ax, [0, 0, 1.45], [0, 0, 0.45], _ROOM, width=1.6, ratio=0.35)
    ax.text(0.08, 0.0, 1.78, "z1 (up)", color="k", fontsize=11)
    corner = np.array([-0.35, -1.2, base])
    for vector, name in (([0.5, 0, 0], "x1"), ([0, 0.5, 0], "y1"), ([0, 0, 0.5], "z1")):
        _arrow3d(ax, corner, vector, _ROOM, width=1.4, ratio=0.25)
        ax.text(*(corner + 1.25 * np.array(vector)), name, color="k", fontsize=10)
    floor = np.array([[[-1.25, -1.25], [1.25, -1.25]], [[-1.25, 1.25], [1.25, 1.25]]])
    ax.plot_surface(floor[..., 0], floor[..., 1], np.full((2, 2), base), color="0.85",
                    alpha=0.5, linewidth=0, shade=False)

    # The gear: a crown fixed to the floor round the vertical hinge, a pinion on the outer
    # frame rolling on it, driven from the shaft's -z end (the train drawn dotted).
    crown_at = np.array([0, 0, base + 0.12])
    ax.plot(*_circle(crown_at, [1, 0, 0], [0, 1, 0], 0.42, 0, 360, 80), color=_GEAR,
            linewidth=3.0)
    pinion_at = crown_at - 0.42 * z + 0.09 * up
    ax.plot(*_circle(pinion_at, up, z, 0.09, 0, 360, 40), color=_GEAR, linewidth=2.5)
    train = np.stack([-1.1 * z, -1.1 * z - 0.5 * up, pinion_at + 0.09 * up], axis=1)
    ax.plot(*train, color=_GEAR, linewidth=1.8, linestyle=":")
    ax.text(*(crown_at - 0.75 * z + 0.55 * x - 0.25 * up), "gear: psi = lambda phi",
            color=_GEAR, fontsize=11, zorder=10)

    # The outer frame: a ring in the vertical plane of the shaft, on the vertical hinge.
    ax.plot(*_circle(o, z, up, ring, 0, 360, 120), color=_FRAME, linewidth=3.0)
    _line(ax, -ring * up, crown_at, color=_FRAME, linewidth=4.0)
    ax.text(*(0.72 * z + 0.85 * up), "outer frame", color=_FRAME, fontsize=11, ha="right")

    # psi: about +z1, counter-clockwise seen from above.
    _arc_arrow3d(ax, _circle([0, 0, 1.3], [1, 0, 0], [0, 1, 0], 0.38, -265, 15), up, _FRAME)
    ax.text(*(np.array([0, 0, 1.36]) + 0.4 * x), "psi", color=_FRAME, fontsize=13)

    # The shaft along z, through O, in the frame's bearings.
    _line(ax, -1.15 * z, 1.5 * z, color=_BODY, linewidth=3.5)

    # The body at phi = 0 and its axes: y up, z along the shaft, x = y cross z.
    _box(ax, x, y, z, (0.26, 0.16, 0.2), _BODY)
    for name, vector, length in (("x", x, 0.8), ("y", y, 0.72), ("z", z, 0.62)):
        _arrow3d(ax, o, length * vector, _AXES[name], width=2.6, ratio=0.2)
    ax.text(*(0.9 * x - 0.08 * up), "x", color=_AXES["x"], fontsize=13, fontweight="bold")
    ax.text(*(0.75 * y - 0.12 * x), "y", color=_AXES["y"], fontsize=13, fontweight="bold")
    ax.text(*(0.5 * z - 0.18 * up), "z", color=_AXES["z"], fontsize=13, fontweight="bold")
    ax.text(*(-0.15 * x - 0.12 * up + 0.0 * z), "O", color="k", fontsize=13, fontweight="bold")
    ax.scatter(*o, color="k", s=18)

    # phi: about +z, counter-clockwise seen from the +z end.
    _arc_arrow3d(ax, _circle(0.72 * z, x, y, 0.24, -150, 120), z, _BODY)
    ax.text(*(0.72 * z + 0.3 * y - 0.3 * x), "phi", color=_BODY, fontsize=13)

    # Motor and encoder on the shaft's hinge, at the +z end (stators on the outer frame).
    _cylinder(ax, 1.16 * z, z, x, y, 0.13, 0.22, _MOTOR)
    ax.text(*(1.16 * z - 0.45 * up), "motor", color=_MOTOR, fontsize=11, ha="center")
    _cylinder(ax, 1.4 * z, z, x, y, 0.17, 0.04, _ENCODER)
    ax.text(*(1.45 * z + 0.22 * up), "encoder", color="tab:blue", fontsize=11, ha="center")

    ax.set_xlim(-1.25, 1.25)
    ax.set_ylim(-1.25, 1.25)
    ax.set_zlim(-1.6, 1.9)
    ax.set_box_aspect((1.0, 1.0, 1.35), zoom=1.25)
    ax.view_init(elev=20, azim=VIEW_AZIMUTH_DEG)
    ax.set_axis_off()
    ax.set_title("The gimbal at phi = 0 (body y up);\nO, where the vertical axis z1 meets "
                 "the shaft", fontsize=12)
    # Drawn in the order given (floor first, the transducers last): mplot3d's depth sort
    # put the floor over the gear's label and the body over its own axes.
    ax.computed_zorder = False


def _arc_arrow(ax, radius: float, start_deg: float, stop_deg: float, color: str,
               width: float = 2.0) -> None:
    """A 2-D arc about the view's centre with an arrowhead at ``stop_deg``."""
    t0, t1 = math.radians(start_deg), math.radians(stop_deg)
    t = np.linspace(t0, t1, 60)
    ax.plot(radius * np.cos(t[:-3]), radius * np.sin(t[:-3]), color=color, linewidth=width)
    a = radius * np.array([math.cos(t[-4]), math.sin(t[-4])])
    b = radius * np.array([math.cos(t1), math.sin(t1)])
    ax.add_patch(FancyArrowPatch(a, b, arrowstyle="-|>", mutation_scale=18, color=color,
                                 linewidth=width))


def _axis_arrow(ax, vector, name: str, color: str, label_at: float = 1.13) -> None:
    ax.add_patch(FancyArrowPatch((0, 0), vector, arrowstyle="-|>", mutation_scale=16,
                                 color=color, linewidth=2.2))
    ax.text(label_at * vector[0], label_at * vector[1], name, color=color, fontsize=12,
            ha="center", va="center", fontweight="bold")


def _top_view(ax) -> None:
    """Seen from above (looking down z1): psi, and the gear's sense."""
    c, s = math.cos(PSI_DRAWN), math.sin(PSI_DRAWN)
    z = np.array([s, -c])  # the shaft's +z in (x1, y1)
    for vector, name in (((1.0, 0.0), "x1"), ((0.0, 1.0), "y1")):
        ax.add_patch(FancyArrowPatch((0, 0), vector, arrowstyle="-|>", mutation_scale=14,
                                     color=_ROOM, linewidth=1.2, linestyle="--"))
        ax.text(1.1 * vector[0], 1.1 * vector[1], name, fontsize=11, ha="center", va="center")
    ax.plot(*np.stack([-0.95 * z, 0.95 * z], axis=1), color=_FRAME, linewidth=5,
            solid_capstyle="butt", alpha=0.5)
    ax.plot(*np.stack([-0.8 * z, 0.8 * z], axis=1), color=_BODY, linewidth=2.5)
    _axis_arrow(ax, 0.8 * z, "+z", _AXES["z"], 1.2)
    ax.text(-0.95 * z[0] - 0.08, -0.95 * z[1], "outer frame", color=_FRAME, fontsize=10,
            ha="right")
    ax.add_patch(Rectangle((0.78 * z[0] - 0.09, 0.78 * z[1] - 0.09), 0.18, 0.18,
                           angle=0.0, color=_MOTOR, alpha=0.6))
    _arc_arrow(ax, 0.45, 200, 320, _FRAME, 2.4)
    ax.text(-0.05, -0.28, "psi", color=_FRAME, fontsize=13, ha="center")
    ax.plot(0, 0, "o", color="k", markersize=6)
    ax.text(-0.08, 0.1, "O (z1 up,\ntowards you)", fontsize=10, ha="right")
    ax.text(0.0, -1.32,
            "psi: about z1, counter-clockwise from above.\n"
            "Gear: phi turning + (counter-clockwise\nseen from the +z end) turns the frame\n"
            "+ by lambda times as much: psi = lambda phi.",
            fontsize=10, ha="center", va="top")
    ax.set_xlim(-1.35, 1.35)
    ax.set_ylim(-2.25, 1.3)
    ax.set_aspect("equal")
    ax.set_axis_off()
    ax.set_title("From above", fontsize=13)


def _end_view(ax) -> None:
    """Seen from the +z end of the shaft (looking along -z): phi, phi = 0, encoder, motor."""
    ax.add_patch(Circle((0, 0), 0.62, facecolor="#cfe8ee", edgecolor=_ENCODER, linewidth=2))
    for k in range(24):  # the encoder's graduation
        t = 2 * math.pi * k / 24
        ax.plot([0.55 * math.cos(t), 0.62 * math.cos(t)], [0.55 * math.sin(t), 0.62 * math.sin(t)],
                color=_ENCODER, linewidth=1)
    ax.add_patch(Rectangle((-0.32, -0.22), 0.64, 0.44, facecolor=_BODY, alpha=0.4,
                           edgecolor="0.3"))
    _axis_arrow(ax, (0.95, 0.0), "x", _AXES["x"])
    _axis_arrow(ax, (0.0, 0.95), "y", _AXES["y"])
    ax.add_patch(Circle((0, 0), 0.05, facecolor="white", edgecolor=_AXES["z"], linewidth=2))
    ax.plot(0, 0, "o", color=_AXES["z"], markersize=3)
    ax.text(-0.2, -0.12, "z", color=_AXES["z"], fontsize=12, fontweight="bold")
    ax.text(0.08, 1.08, "phi = 0: y up (vertical)", fontsize=10)
    tilted = 0.85 * np.array([-math.sin(math.radians(35)), math.cos(math.radians(35))])
    ax.plot([0, tilted[0]], [0, tilted[1]], color=_AXES["y"], linestyle=":", linewidth=1.5)
    ax.text(tilted[0] - 0.05, tilted[1] - 0.02, "y at phi > 0", color=_AXES["y"],
            fontsize=9, ha="right")
    _arc_arrow(ax, 0.78, 95, 122, _BODY, 2.0)
    ax.text(-0.36, 0.93, "phi", color=_BODY, fontsize=13, ha="center")
    _arc_arrow(ax, 0.75, 200, 290, _MOTOR, 2.4)
    ax.text(-0.68, -0.72, "u > 0", color=_MOTOR, fontsize=11, ha="center")
    _arc_arrow(ax, 0.75, -40, 40, _ENCODER, 2.4)
    ax.text(1.12, 0.32, "encoder\ncounts up", color="tab:blue", fontsize=10, ha="center")
    ax.text(0.0, -1.15,
            "z points at you: the shaft's +z end,\n"
            "where the motor and the encoder sit.\n"
            "phi: about z, counter-clockwise from here.\n"
            "The encoder counts up, and a positive\n"
            "torque u turns the shaft, this way;\n"
            "the encoder's zero is phi = 0 (y up).",
            fontsize=10, ha="center", va="top")
    ax.set_xlim(-1.3, 1.4)
    ax.set_ylim(-2.0, 1.3)
    ax.set_aspect("equal")
    ax.set_axis_off()
    ax.set_title("From the +z end of the shaft", fontsize=13)


def gimbal_figure() -> Figure:
    """The gimbal and its conventions (docs/method.md §1), as a matplotlib Figure.

    Returns
    -------
    matplotlib.figure.Figure
        Left, the perspective: the room's axes x1 y1 z1 and O, the outer frame turning by psi
        about z1, the shaft, the body at phi = 0 with its axes x y z, the senses of psi and
        phi, the gear, the motor and the encoder; right, the views from above and from the
        shaft's +z end. ``SIZE`` inches at ``DPI``.
    """
    fig = Figure(figsize=SIZE, dpi=DPI)
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(1, 3, width_ratios=(1.55, 1.0, 1.0), left=0.0, right=0.99,
                            bottom=0.02, top=0.93, wspace=0.05)
    _perspective(fig.add_subplot(grid[0], projection="3d"))
    _top_view(fig.add_subplot(grid[1]))
    _end_view(fig.add_subplot(grid[2]))
    return fig


def gimbal_png() -> bytes:
    """docs/gimbal.png's bytes: :func:`gimbal_figure` as PNG, without metadata that changes."""
    buffer = io.BytesIO()
    gimbal_figure().savefig(buffer, format="png", dpi=DPI, metadata=_METADATA)
    return buffer.getvalue()


def main(argv: list[str] | None = None) -> int:
    """``python -m rsp_inertia.gimbal_figure [OUT]``: write the figure to OUT (default
    docs/gimbal.png); returns the exit status."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) > 1:
        print("usage: python -m rsp_inertia.gimbal_figure [OUT]", file=sys.stderr)
        return 2
    out = Path(args[0]) if args else DEFAULT_PATH
    write_atomic(out, gimbal_png())
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
