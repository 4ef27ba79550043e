"""``rsp-inertia design``: the conditioning of axis designs, and of mountings for the centre
of mass.

Both paper designs (the icosahedron; the cone + z design at the opening that minimises
cond(V), rsp_inertia.design.mountings.best_cone_opening), each experiment's device.toml
design, and for several experiments (or one with ``[mounting]``) the mountings'
conditioning for the centre of mass (rsp_inertia.design.mountings.mounting_conditioning);
the paper's Fig. 1 written as a PNG. Its result object, with the text it prints, is
:class:`rsp_inertia.results.AxisDesignResult`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rsp_inertia.design.mountings import best_cone_opening, mounting_conditioning
from rsp_inertia.figure_files import save_figure
from rsp_inertia.infra.files import check_writable
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.experiment import DEVICE_FILE
from rsp_inertia.plant.geometry import cone_plus_z_design, device_design, icosahedron_design
from rsp_inertia.plots import AXIS_DESIGN_FIGURE, axis_design_figures
from rsp_inertia.results.axis_designs import AxisDesignResult

__all__ = ["axis_designs"]


def axis_designs(
    paths: list[Path] | Path | None = None, plot: Path | None = None
) -> AxisDesignResult:
    """The command behind :func:`rsp_inertia.api.axis_designs`, documented there (and in
    this module's docstring); ``paths`` may be one folder. A plot that cannot be written is
    refused (InputError) before anything is computed."""
    if paths is None:
        paths = []
    elif isinstance(paths, (str, Path)):
        paths = [paths]
    devices = [load_device(Path(exp) / DEVICE_FILE) for exp in paths]
    if plot is None:
        plot = (Path(paths[0]) if paths else Path(".")) / AXIS_DESIGN_FIGURE
    check_writable(plot)  # a read-only folder: one line, before the search below
    best_deg, best_cond = best_cone_opening()
    designs = [icosahedron_design(), cone_plus_z_design(best_deg)]
    designs += [device_design(device) for device in devices]
    names, rotations, condition, gain = (), (), None, None
    if len(devices) > 1 or any(device.mounting is not None for device in devices):
        names = tuple(str(exp) for exp in paths)
        rotations = tuple(
            np.eye(3) if d.mounting is None else d.mounting.rotation for d in devices
        )
        condition, gain = mounting_conditioning(list(rotations))
    result = AxisDesignResult(
        designs=tuple(designs),
        best_opening_deg=best_deg,
        best_condition=best_cond,
        mountings=names,
        rotations=rotations,
        mounting_condition=condition,
        mounting_gain=gain,
        figure=Path(plot),
        drawer=axis_design_figures,
    )
    for _name, figure in result.draw():
        save_figure(figure, plot)
    return result
