"""The ``design`` command's result: the conditioning of axis designs (docs/method.md §5 "Axis
designs") and of mountings for the centre of mass, and its report."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rsp_inertia.figure_files import save_figures
from rsp_inertia.infra.frozen import freeze_arrays
from rsp_inertia.plant.geometry import AxisDesign
from rsp_inertia.results.common import Drawer, Drawn, json_text

__all__ = ["AxisDesignResult", "axis_design_report", "mounting_report"]


def _axes_table(design: AxisDesign) -> list[str]:
    """One line per axis: stage, lambda, cone opening, node, direction."""
    header = (
        f"  {'axis':>4} {'stage':>5} {'lambda':>9} {'2beta[deg]':>10} {'node[deg]':>9}"
        f" {'ex':>9} {'ey':>9} {'ez':>9}"
    )
    lines = [header]
    for k, (stage, lam, phi, e) in enumerate(
        zip(design.stages, design.gear_ratios, design.phis, design.directions, strict=True),
        start=1,
    ):
        opening = 2.0 * np.degrees(np.arctan(abs(lam)))
        lines.append(
            f"  {k:>4d} {stage:>5d} {lam:>9.4f} {opening:>10.3f} {np.degrees(phi):>9.3f}"
            f" {e[0]:>9.5f} {e[1]:>9.5f} {e[2]:>9.5f}"
        )
    return lines


def _angles_table(angles: np.ndarray) -> list[str]:
    """The angle matrix between the axes (deg) and its off-diagonal min/max/mean."""
    n = angles.shape[0]
    header = "  " + " " * 4 + "".join(f"{j:>8d}" for j in range(1, n + 1))
    lines = ["  Angles between the axes [deg]:", header]
    for i in range(n):
        lines.append(f"  {i + 1:>4d}" + "".join(f"{a:>8.2f}" for a in angles[i]))
    if n > 1:
        off = angles[np.triu_indices(n, k=1)]
        lines.append(
            f"  {off.size} angles off the diagonal: min {off.min():.4f}  max {off.max():.4f}"
            f"  mean {off.mean():.4f} deg"
        )
    return lines


def axis_design_report(designs: list[AxisDesign]) -> str:
    """Human-readable report of axis designs (docs/method.md §5 "Axis designs").

    Parameters
    ----------
    designs : list of AxisDesign
        Designs to describe, in order.

    Returns
    -------
    str
        For each design: its name, a table of its axes (stage, gear ratio lambda, cone
        opening 2 beta = 2 arctan lambda, node angle, unit direction), the matrix of angles
        between the axes with the min/max/mean of the off-diagonal ones, and cond(V) to four
        decimals. Ends with a newline.

    Examples
    --------
    >>> from rsp_inertia.plant.geometry import icosahedron_design
    >>> "cond(V) = 1.5811" in axis_design_report([icosahedron_design()])
    True
    """
    blocks = []
    for design in designs:
        stages = np.unique(design.stages)
        lines = [f"Axis design: {design.name}  ({design.n_axes} axes, {stages.size} stages)"]
        lines += _axes_table(design)
        lines += _angles_table(design.angles_deg)
        lines.append(f"  cond(V) = {design.condition:.4f}   (2-norm, V is {design.n_axes}x6)")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def mounting_report(
    names: list[str], rotations: list[np.ndarray], condition: float, gain: np.ndarray
) -> str:
    """The mountings' part of the axis-design report.

    Parameters
    ----------
    names : list of str
        The mountings' experiment folders.
    rotations : list of numpy.ndarray, shape (3, 3) each
        Each mounting's R, body axes -> rig axes (device.toml ``[mounting] rotation``).
    condition : float
        cond(G) of the set (rsp_inertia.design.mountings.mounting_conditioning; infinite when
        a body direction stays on the shaft in every mounting).
    gain : numpy.ndarray, shape (3,)
        The std of x_c, y_c, z_c over one mounting's std of x_c (infinite: not measured).

    Returns
    -------
    str
        Each mounting's body direction on the shaft (which gravity does not see), the gains
        and cond(G), and what to add when the centre of mass is not determined. Ends with a
        newline.
    """
    lines = [f"Mountings for the centre of mass ({len(names)}):"]
    for name, R in zip(names, rotations):
        R = np.asarray(R, dtype=float)
        shaft = R[2]  # the body direction that lies along the shaft (rig z)
        lines.append(
            f"  {name}: body direction on the shaft (not seen by gravity) "
            f"[{', '.join(f'{c:+.3f}' for c in shaft)}]"
        )
    lines.append(
        "  std of x_c, y_c, z_c over one mounting's std of x_c: "
        + ", ".join("not measured" if not math.isfinite(g) else f"{g:.3f}" for g in gain)
        + (f"; cond(G) = {condition:.4f}" if math.isfinite(condition) else "")
    )
    if not math.isfinite(condition):
        lines.append(
            "  the centre of mass is not determined: add a mounting turned 90 deg about the "
            "rig's x axis (rotation = [[1, 0, 0], [0, 0, -1], [0, 1, 0]] from a body as drawn)"
        )
    return "\n".join(lines) + "\n"


@dataclass(frozen=True, eq=False)
class AxisDesignResult(Drawn):
    """The conditioning of axis designs: the paper's two, and each experiment's.

    Returned by ``rsp-inertia design`` (:func:`rsp_inertia.api.axis_designs`).

    Attributes
    ----------
    designs : tuple of rsp_inertia.plant.geometry.AxisDesign
        The icosahedron, the cone + z design at its optimum opening, then each experiment's
        device.toml design, in that order.
    best_opening_deg : float
        deg, the cone opening 2 beta of the cone + z design that minimises cond(V)
        (rsp_inertia.design.mountings.best_cone_opening).
    best_condition : float
        cond(V) there.
    mountings : tuple of str
        The experiment folders whose mountings are reported for the centre of mass (several,
        or one with ``[mounting]``); empty otherwise.
    rotations : tuple of numpy.ndarray, shape (3, 3) each
        Each of those mountings' rotation, body axes -> rig axes (the identity without
        ``[mounting]``).
    mounting_condition : float or None
        cond(G) of the mountings for the centre of mass (infinite when a body direction
        stays on the shaft in every mounting); None without mountings.
    mounting_gain : numpy.ndarray, shape (3,), or None
        The std of x_c, y_c, z_c over one mounting's std of x_c; None without mountings.
    figure : pathlib.Path
        The figure written: 1/cond(V) of the cone + z design against its opening (the
        paper's Fig. 1).
    drawer : callable or None
        What draws the figures (:meth:`draw`): the function of rsp_inertia.plots its command
        handed it; None for a result made without one.

    Examples
    --------
    >>> designs = rsp_inertia.api.axis_designs(["bench-A"])    # doctest: +SKIP
    >>> designs.best_opening_deg, designs.best_condition        # doctest: +SKIP
    (141.967..., 1.48925...)
    """

    designs: tuple[AxisDesign, ...]
    best_opening_deg: float
    best_condition: float
    mountings: tuple[str, ...]
    rotations: tuple[np.ndarray, ...] = field(repr=False)
    mounting_condition: float | None
    mounting_gain: np.ndarray | None
    figure: Path
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the result is frozen

    def __str__(self) -> str:
        mountings = ""
        if self.mountings:
            mountings = "\n" + mounting_report(
                list(self.mountings), list(self.rotations), self.mounting_condition,
                self.mounting_gain,
            )
        return (
            axis_design_report(list(self.designs))
            + mountings
            + f"\ncone + z: cond(V) is least at 2beta = {self.best_opening_deg:.3f} deg, "
            f"cond(V) = {self.best_condition:.4f}"
            + " (paper Fig. 1: 140 deg, 1.4899)"
            + f"\nplot of 1/cond(V) against 2beta -> {self.figure}"
        )

    def to_json(self) -> str:
        """The designs as JSON.

        Returns
        -------
        str
            ``{"designs": [{"name", "condition", "axes": [{"stage", "gear_ratio",
            "node_deg", "direction"}, ...]}, ...], "best_opening_deg", "best_condition",
            "mountings": {"folders", "rotations", "condition", "gain"} or null, "figure"}``
            (infinities written as null).
        """
        designs = [
            {
                "name": d.name,
                "condition": d.condition,
                "axes": [
                    {
                        "stage": stage,
                        "gear_ratio": lam,
                        "node_deg": np.degrees(phi),
                        "direction": e,
                    }
                    for stage, lam, phi, e in zip(d.stages, d.gear_ratios, d.phis, d.directions)
                ],
            }
            for d in self.designs
        ]
        mountings = None
        if self.mountings:
            mountings = {
                "folders": self.mountings,
                "rotations": self.rotations,
                "condition": self.mounting_condition,
                "gain": self.mounting_gain,
            }
        return json_text(
            {
                "designs": designs,
                "best_opening_deg": self.best_opening_deg,
                "best_condition": self.best_condition,
                "mountings": mountings,
                "figure": self.figure,
            }
        )

    def figures(self, folder: str | Path | None = None) -> list[Path]:
        """Draw 1/cond(V) of the cone + z design against its opening (design has written it).

        Parameters
        ----------
        folder : str or pathlib.Path, optional
            Where to write it (created if needed), under the name of ``figure``. Default:
            the folder of ``figure``.

        Returns
        -------
        list of pathlib.Path
            ``[folder / figure.name]``.
        """
        return save_figures(self.draw(), self.figure.parent if folder is None else folder)
