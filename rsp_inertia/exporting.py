"""``rsp-inertia export``: a result's mass properties in the frame a CAD model or a robot
description uses, as JSON, CSV or a URDF ``<inertial>`` element.

The source is identify's result.json (rig axes, about the rig's centre O) or combine's
body.json (body axes, about the body frame's origin), refused when edited after it was
written (rsp_inertia.provenance.integrity_state). A frame file FRAME.toml states the target
frame in the source's axes::

    [frame]
    rotation = [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # rows: frame axes
    origin = [0.01, 0.0, 0.02]                                        # m, in source axes

so that a point's coordinates in the frame are v_frame = F (v_source - p). The tensor about
the frame's origin in its axes, the centre of mass in the frame and the tensor about the
centre of mass in the frame's axes are rsp_inertia.plant.geometry.place_body's (the body's
origin placed at -F p, turned by F): one formula for a mounting and for an export. The
covariance goes through the same map to first order (docs/method.md, "Exporting in another
frame"): the rig measures m x_c, not x_c (the gravity torque m g x_c), so the unknowns are
the entries, q = m c and the mass, in which the tensor about any fixed point is linear: its
covariance is exact, G C G^T; the centre of mass q / m and the tensor about it are not, and
are linearised.

The mass is not measured by the rig: it is the one the source's centre of mass was computed
with (result.json: its folder's device.toml ``[body] mass``; body.json: its ``mass``), else
``mass`` (``--mass``); its std is ``mass_std`` (``--mass-std``), taken as 0 with a note when
not given.
"""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rsp_inertia.estimation.combine import COM_KEYS
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable, write_atomic
from rsp_inertia.infra.frozen import freeze_arrays, read_only
from rsp_inertia.infra.toml_schema import ContentError, config_class, key, read_file, read_table
from rsp_inertia.plant.device_config import _rotation
from rsp_inertia.plant.experiment import BODY_FILE, RESULT_FILE, open_experiment
from rsp_inertia.plant.geometry import ENTRY_KEYS, place_body
from rsp_inertia.provenance import integrity_state

__all__ = [
    "COM_KEYS",
    "EXPORT_FORMATS",
    "OUTPUT_KEYS",
    "Exported",
    "Frame",
    "SourceBody",
    "export",
    "frame_properties",
    "load_frame",
    "read_source",
]

EXPORT_FORMATS = ("json", "csv", "urdf")
"""What ``export`` writes."""

OUTPUT_KEYS = ("mass", *COM_KEYS, *ENTRY_KEYS)
"""The order of :attr:`Exported.cov`: the mass (kg), the centre of mass (m) and the tensor
about the frame's origin (kg m^2)."""

URDF_KEYS = ("ixx", "iyy", "izz", "ixy", "iyz", "ixz")
"""URDF's names of the entries, in the order of ENTRY_KEYS: URDF's ``ixy`` is the tensor's
entry, -integral of x y dm, as ``Jxy`` is (docs/files.md, export)."""

_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@config_class
class Frame:
    """The frame to export in (FRAME.toml ``[frame]``), given in the source's axes: the
    coordinates of a point in it are v_frame = F (v_source - p)."""

    rotation: tuple[tuple[float, ...], ...] = key(
        _IDENTITY,
        names=("x", "y", "z"),
        check=_rotation,
        doc="F, source axes -> frame axes (v_frame = F (v_source - origin)), given by rows: row "
        "k is the frame's axis k in the source's axes; orthonormal with determinant +1; shape "
        "(3, 3), read-only.",
    )
    origin: tuple[float, float, float] = key(
        (0.0, 0.0, 0.0),
        unit="m",
        names=("x", "y", "z"),
        doc="p, the frame's origin in the source's axes, from the source's origin (result.json: "
        "the rig's centre O; body.json: the body frame's origin); shape (3,), read-only.",
    )

    def __post_init__(self) -> None:
        # Own read-only copies, so that a frozen frame stays frozen however it was built.
        for name, shape in (("rotation", (3, 3)), ("origin", (3,))):
            array = np.array(getattr(self, name), dtype=float)
            if array.shape != shape:
                raise ValueError(f"Frame.{name} must have shape {shape}, got {array.shape}")
            array.flags.writeable = False
            object.__setattr__(self, name, array)


@config_class
class _FrameFile:
    """FRAME.toml: the frame to export in."""

    frame: Frame = key(doc="The frame, in the source's axes (identity and 0 without it).")


def load_frame(path: str | os.PathLike) -> Frame:
    """Read a frame file (``export --frame FRAME.toml``).

    Parameters
    ----------
    path : str or os.PathLike
        The TOML file, with ``[frame] rotation`` (3 x 3, rows: the frame's axes in the
        source's axes) and ``origin`` (m, in the source's axes); both optional.

    Returns
    -------
    Frame

    Raises
    ------
    InputError
        One line naming the file and the key: not TOML, an unknown key, a rotation that is not
        3 x 3, orthonormal with determinant +1 (to 1e-9), an origin that is not 3 numbers.
    """
    doc = read_file(path)
    try:
        return read_table(_FrameFile, doc).frame
    except ContentError as error:
        raise InputError(f"{path}: {error}") from None


@dataclass(frozen=True)
class SourceBody:
    """The mass properties a result file states, in its own axes and about its own origin."""

    path: Path
    """The result.json or body.json read."""
    kind: str
    """``"result.json"`` or ``"body.json"``."""
    axes: str
    """What the source's axes and origin are, in words."""
    entries: np.ndarray
    """(6,) [Jx, Jy, Jz, Jxy, Jyz, Jxz], kg m^2, about the source's origin."""
    moment: np.ndarray
    """(3,) q = m c, kg m: the mass times the centre of mass (the rig measures m g c, not c);
    NaN where the source does not determine it (z of a result.json: along the shaft)."""
    cov: np.ndarray
    """(9, 9) covariance of [entries, moment] (kg^2 m^4, kg^2 m^3, kg^2 m^2); 0 in a row
    the source does not determine."""
    mass: float
    """kg."""
    mass_std: float
    """kg."""
    notes: tuple[str, ...] = ()
    """What the reader assumed: a mass std not stated, a source without integrity."""

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen


def _load_document(path: Path) -> dict:
    """A result file's JSON document, refused (one line) when it is not one or was edited."""
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise InputError(f"{path}: cannot read: {error.strerror or error}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputError(f"{path}: not a result.json or body.json ({error})") from None
    if not isinstance(document, dict):
        raise InputError(f"{path}: not a result.json or body.json (not a JSON object)")
    if integrity_state(document) == "edited":
        raise InputError(
            f"{path}: edited after it was written (its integrity sha256 is not its content's): "
            "export refuses it; run identify (or combine) again"
        )
    return document


def _source_path(source: Path) -> Path:
    """The result file a SRC names: the file, or the one result file a folder holds."""
    if source.is_dir():
        found = [source / name for name in (BODY_FILE, RESULT_FILE) if (source / name).is_file()]
        if not found:
            raise InputError(f"{source}: holds no {RESULT_FILE} or {BODY_FILE}: identify or "
                             "combine first, or name the file")
        if len(found) > 1:
            raise InputError(f"{source}: holds both {RESULT_FILE} and {BODY_FILE}: name the "
                             "one to export")
        return found[0]
    if not source.is_file():
        raise InputError(f"{source}: not found: name a result.json, a body.json or their folder")
    return source


def _number(value, what: str, bound: str) -> float:
    """A float option checked against ``> 0`` or ``>= 0`` (one-line InputError)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what}: must be a number (kg), got {value!r}") from None
    if not math.isfinite(number) or (number <= 0 if bound == "> 0" else number < 0):
        raise InputError(f"{what}: must be finite and {bound} (kg), got {value!r}")
    return number


def read_source(
    source: str | os.PathLike, mass: float | None = None, mass_std: float | None = None
) -> SourceBody:
    """The mass properties a result.json or body.json states (``export SRC``).

    Parameters
    ----------
    source : str or os.PathLike
        A result.json (its folder's device.toml gives the mass and gravity), a body.json, or
        a folder holding one of them.
    mass : float, optional
        kg, for a source that states no mass (``--mass``); one that does must agree with it
        (its centre of mass was computed with its own).
    mass_std : float, optional
        kg, the mass's std (``--mass-std``); without it the mass is taken as exact, with a note.

    Returns
    -------
    SourceBody

    Raises
    ------
    InputError
        No such file, not a result file, one edited after it was written, no mass (give
        ``--mass``), a ``--mass`` that differs from the source's.
    """
    path = _source_path(Path(source))
    document = _load_document(path)
    notes = []
    if integrity_state(document) == "not sealed":
        notes.append(f"{path}: records no integrity (an older rsp-inertia wrote it): whether "
                     "it was edited cannot be checked")
    given = None if mass is None else _number(mass, "--mass", "> 0")
    std = 0.0 if mass_std is None else _number(mass_std, "--mass-std", ">= 0")
    try:
        entries = np.array([document["tensor"][k] for k in ENTRY_KEYS], dtype=float)
        cov = np.array(document["covariance"], dtype=float)
        if "gravity_torque" in document:
            kind = RESULT_FILE
            torque = document["gravity_torque"]
            gravity = np.array([torque["m_g_xc"], torque["m_g_yc"]], dtype=float)
        else:
            kind = BODY_FILE
            com = np.array([document["com"][k] for k in COM_KEYS], dtype=float)
    except (KeyError, TypeError, ValueError) as missing:
        raise InputError(f"{path}: not a result.json or body.json (no {missing})") from None
    if kind == RESULT_FILE:
        exp = open_experiment(path.parent, protocol=False)
        stated, where = (
            (exp.device.body.mass, f"{exp.device_path} [body] mass")
            if exp.device.body is not None else (None, "")
        )
        axes = "rig axes, about the rig's centre O (result.json)"
    else:
        stated, where = document.get("mass"), f"{path} mass"
        if stated is not None:
            stated = _number(stated, f"{path}: mass", "> 0")
        axes = "body axes, about the body frame's origin (body.json)"
    if stated is None and given is None:
        raise InputError(f"{path}: states no mass (the rig does not measure it): give --mass KG "
                         "(and --mass-std KG)")
    if stated is not None and given is not None and abs(given - stated) > 1e-12 * stated:
        raise InputError(f"--mass {given!r} differs from {where} = {stated!r}, which the centre "
                         "of mass was computed with: correct it there and run again, or leave "
                         "--mass out")
    m = float(stated if stated is not None else given)
    if mass_std is None:
        notes.append("the mass's std is not stated (--mass-std KG): the mass is taken as exact")
    if kind == RESULT_FILE:
        if cov.shape != (8, 8):
            raise InputError(f"{path}: covariance must be 8 x 8, got {cov.shape}")
        g = exp.device.gravity
        # q = m c = (m g c) / g: linear in the gravity terms; z (along the shaft) unmeasured
        moment = np.array([gravity[0] / g, gravity[1] / g, np.nan])
        jac = np.zeros((9, 8))
        jac[:6, :6] = np.eye(6)
        jac[6:8, 6:8] = np.eye(2) / g
    else:
        if cov.shape != (9, 9):
            raise InputError(f"{path}: covariance must be 9 x 9, got {cov.shape}")
        moment = m * com
        jac = np.diag([1.0] * 6 + [m] * 3)
    return SourceBody(
        path=path, kind=kind, axes=axes, entries=entries, moment=moment,
        cov=jac @ cov @ jac.T, mass=m, mass_std=std, notes=tuple(notes),
    )


def _frame_map(theta: np.ndarray, rotation: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """[mass, centre of mass (3), entries about the frame's origin (6), entries about the
    centre of mass (6)] in the frame (``rotation`` F, ``origin`` p in source axes), from
    theta = [entries (6), q = m c (3), m] in the source's axes: place_body with the source's
    origin at -F p, then at -F c (the frame moved to the centre of mass)."""
    entries, m = theta[:6], theta[9]
    com = theta[6:9] / m
    about_origin, com_frame = place_body(entries, com, m, rotation, -rotation @ origin)
    about_com, _ = place_body(entries, com, m, rotation, -rotation @ com)
    return np.concatenate([[m], com_frame, about_origin, about_com])


def frame_properties(
    body: SourceBody, frame: Frame
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body's mass properties in ``frame``, with their covariance (docs/method.md,
    "Exporting in another frame").

    y = [m, c_F (3), J about the frame's origin in its axes (6), J about the centre of mass
    in the frame's axes (6)] = f(theta), theta = [J about the source's origin (6), q = m c
    (3), m], by :func:`rsp_inertia.plant.geometry.place_body`; cov_y = G cov_theta G^T with G
    the Jacobian of f by central differences (exact where f is linear or quadratic in a
    variable, as it is in all but the mass's 1/m: there the step's error is ~1e-8 of the
    derivative).

    Parameters
    ----------
    body : SourceBody
        The source's mass properties and covariance; a NaN in ``moment`` (z of a result.json)
        is a coordinate the source does not determine.
    frame : Frame
        The target frame in the source's axes.

    Returns
    -------
    (values, cov, determined) : numpy.ndarray
        Shapes (16,), (16, 16), (16,): y, its covariance, and whether each entry of y is
        determined by the source (False where it depends on an undetermined coordinate:
        then its value and covariance rows are NaN).
    """
    unknown = ~np.isfinite(body.moment)
    q = np.where(unknown, 0.0, body.moment)
    theta = np.concatenate([body.entries, q, [body.mass]])
    cov = np.zeros((10, 10))
    cov[:9, :9] = body.cov
    cov[9, 9] = body.mass_std**2
    # Steps: central differences are exact for the linear and quadratic dependences up to
    # rounding, whatever the step; about 1e-4 of each variable's scale keeps the rounding
    # ~1e-12 and the 1/m truncation ~1e-8 relative. Powers of two: x +- h is then exact
    # where x has few bits (a mass of 2 kg), and so is the identity's derivative.
    inertia_scale = float(np.max(np.abs(body.entries[:3])))
    length = math.sqrt(inertia_scale / body.mass)
    scale = np.array([inertia_scale] * 6 + [body.mass * length] * 3 + [body.mass])
    step = 2.0 ** np.round(np.log2(1e-4 * scale))
    rotation, origin = np.asarray(frame.rotation), np.asarray(frame.origin)
    values = _frame_map(theta, rotation, origin)
    G = np.empty((values.size, theta.size))
    for i, h in enumerate(step):
        e = np.zeros(theta.size)
        e[i] = h
        G[:, i] = (_frame_map(theta + e, rotation, origin)
                   - _frame_map(theta - e, rotation, origin)) / (2 * h)
    out_scale = np.array([body.mass] + [length] * 3 + [inertia_scale] * 12)
    # An output depends on an undetermined coordinate when moving that coordinate by the
    # body's size moves the output by more than rounding (a finite move, not a derivative:
    # the tensor about the centre of mass depends on z_c quadratically, flat at 0).
    determined = np.ones(values.size, dtype=bool)
    for i in np.flatnonzero(unknown):
        moved = theta.copy()
        moved[6 + i] += body.mass * length
        change = np.abs(_frame_map(moved, rotation, origin) - values)
        determined &= change <= 1e-9 * out_scale
    values = np.where(determined, values, np.nan)
    out_cov = G @ cov @ G.T
    out_cov = (out_cov + out_cov.T) / 2  # symmetric, not only up to the products' rounding
    out_cov[~determined, :] = np.nan
    out_cov[:, ~determined] = np.nan
    return values, out_cov, determined


@dataclass(frozen=True)
class Exported:
    """A body's mass properties in a frame, as ``export`` writes them; :meth:`to_dict` is the
    JSON document, :meth:`to_csv` and :meth:`to_urdf` the other formats' text."""

    source: SourceBody
    """What was read."""
    frame: Frame
    """The frame, in the source's axes."""
    frame_path: Path | None
    """The frame file (None: the source's own axes and origin)."""
    values: np.ndarray
    """(16,) [mass (kg), centre of mass (3, m), the tensor about the frame's origin (6, kg
    m^2), the tensor about the centre of mass (6, kg m^2)], the frame's axes; NaN where the
    source does not determine it; read-only."""
    cov: np.ndarray
    """(16, 16) their covariance; NaN rows where not determined; read-only."""
    notes: tuple[str, ...] = field(default_factory=tuple)
    """What the export assumed (a mass std not stated, a source without integrity)."""

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen

    @property
    def std(self) -> np.ndarray:
        """(16,) standard deviations of :attr:`values`, read-only."""
        return read_only(np.sqrt(np.maximum(np.diag(self.cov), 0.0)))

    def to_dict(self) -> dict:
        """The JSON document (docs/files.md, export): values, stds, the covariance of the
        mass, centre of mass and tensor about the frame's origin, and the tensor about the
        centre of mass."""
        v, s = self.values, self.std

        def plain(x):
            return float(x) if np.isfinite(x) else None

        n = len(OUTPUT_KEYS)
        return {
            "source": str(self.source.path),
            "source_axes": self.source.axes,
            "frame": {
                "file": None if self.frame_path is None else str(self.frame_path),
                "rotation": [[float(c) for c in row] for row in self.frame.rotation],
                "origin": [float(c) for c in self.frame.origin],
            },
            "mass": plain(v[0]),
            "mass_std": plain(s[0]),
            "com": dict(zip(COM_KEYS, map(plain, v[1:4]))),
            "com_std": dict(zip(COM_KEYS, map(plain, s[1:4]))),
            "tensor": dict(zip(ENTRY_KEYS, map(plain, v[4:10]))),
            "tensor_std": dict(zip(ENTRY_KEYS, map(plain, s[4:10]))),
            "covariance_order": list(OUTPUT_KEYS),
            "covariance": [[plain(c) for c in row[:n]] for row in self.cov[:n]],
            "tensor_about_com": dict(zip(ENTRY_KEYS, map(plain, v[10:16]))),
            "tensor_about_com_std": dict(zip(ENTRY_KEYS, map(plain, s[10:16]))),
            "notes": list(self.notes),
        }

    def to_json(self) -> str:
        """The JSON file's text: :meth:`to_dict` indented, with a final newline."""
        return json.dumps(self.to_dict(), indent=2) + "\n"

    def to_csv(self) -> str:
        """The CSV file's text: a header ``quantity,value,std,unit``, one row per quantity
        (empty value and std where the source does not determine it)."""
        names = (
            ["mass", "x_c", "y_c", "z_c", *ENTRY_KEYS, *(f"{k}_com" for k in ENTRY_KEYS)]
        )
        units = ["kg"] + ["m"] * 3 + ["kg m^2"] * 12
        rows = ["quantity,value,std,unit"]
        for name, value, std, unit in zip(names, self.values, self.std, units):
            cells = (repr(float(value)), repr(float(std))) if np.isfinite(value) else ("", "")
            rows.append(f"{name},{cells[0]},{cells[1]},{unit}")
        return "\n".join(rows) + "\n"

    def to_urdf(self) -> str:
        """The URDF file's text: an ``<inertial>`` element (origin xyz: the centre of mass in
        the frame; mass; the tensor about the centre of mass in the frame's axes, URDF's
        ixy = Jxy, the tensor's entry) after an XML comment with the stds.

        Raises
        ------
        InputError
            The source does not determine the centre of mass (a result.json: z_c).
        """
        v, s = self.values, self.std
        if not np.all(np.isfinite(v[:4])) or not np.all(np.isfinite(v[10:])):
            raise InputError(_undetermined(self.source, "URDF's inertial (about the centre of "
                                                        "mass)"))
        inertial = ET.Element("inertial")
        ET.SubElement(inertial, "origin", xyz=" ".join(repr(float(c)) for c in v[1:4]),
                      rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=repr(float(v[0])))
        ET.SubElement(inertial, "inertia", {u: repr(float(x)) for u, x in zip(URDF_KEYS, v[10:])})
        ET.indent(inertial)
        stds = (
            f"mass {s[0]:.3g} kg; xyz " + " ".join(f"{c:.3g}" for c in s[1:4]) + " m; "
            + " ".join(f"{u} {x:.3g}" for u, x in zip(URDF_KEYS, s[10:])) + " kg m^2"
        )
        frame = "the source's axes" if self.frame_path is None else str(self.frame_path)
        comment = (
            f"rsp-inertia export of {self.source.path} in {frame}; standard deviations: "
            f"{stds}"
        ) + "".join(f"; note: {n}" for n in self.notes)
        # "--" may not appear inside an XML comment
        comment = comment.replace("--", "- -")
        return (f"<?xml version='1.0' encoding='utf-8'?>\n<!-- {comment} -->\n"
                + ET.tostring(inertial, encoding="unicode") + "\n")

    def text(self, fmt: str) -> str:
        """The file's text in format ``fmt`` (one of :data:`EXPORT_FORMATS`).

        Parameters
        ----------
        fmt : str
            ``"json"``, ``"csv"`` or ``"urdf"``.

        Returns
        -------
        str
        """
        return {"json": self.to_json, "csv": self.to_csv, "urdf": self.to_urdf}[fmt]()


def _undetermined(body: SourceBody, what: str) -> str:
    """The line refusing an export that needs a coordinate the source does not determine."""
    return (
        f"{body.path}: does not determine the centre of mass along the shaft (z_c: gravity "
        f"does not see it on one mounting), which {what} needs: combine two mountings "
        "(rsp-inertia combine) and export body.json, or export about the rig's centre O "
        "(frame origin [0, 0, 0]) as json or csv"
    )


def export(
    source: str | os.PathLike,
    out: str | os.PathLike,
    format: str = "json",  # named as the command line's --format
    frame: str | os.PathLike | None = None,
    mass: float | None = None,
    mass_std: float | None = None,
) -> Exported:
    """The command behind :func:`rsp_inertia.api.export`, documented there: reads, transforms,
    writes ``out`` atomically (an output that cannot be written is found first)."""
    if format not in EXPORT_FORMATS:
        raise InputError(
            f"--format: must be one of {', '.join(EXPORT_FORMATS)}, got {format!r}"
        )
    target = Path(out)
    check_writable(target)
    frame_path = None if frame is None else Path(frame)
    placed = Frame() if frame_path is None else load_frame(frame_path)
    body = read_source(source, mass, mass_std)
    values, cov, determined = frame_properties(body, placed)
    if not np.all(determined[4:10]):
        raise InputError(_undetermined(body, "the tensor about the frame's origin"))
    exported = Exported(body, placed, frame_path, values, cov, body.notes)
    write_atomic(target, exported.text(format))
    return exported
