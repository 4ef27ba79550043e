"""The experiment folder of docs/files.md: where each file of an experiment lives.

One folder is one experiment::

    EXP/device.toml          the gimbal (required)
    EXP/virtual.toml         only for a virtual device
    EXP/stageN/braking.csv   encoder log of the (forward) braking pass of stage N (1-based)
    EXP/stageN/program.csv   torque program of the reverse pass
    EXP/stageN/reverse.csv   log of the reverse pass
    EXP/stageN/braking_backward.csv, program_backward.csv, reverse_backward.csv
                             the same for the backward run, when the stage's ``directions``
                             include "backward" (phi decreases while braking)
    EXP/stageN/pendulum_kK.csv  torsion-pendulum baseline run at node K (optional)
    EXP/stageN/pilot.csv     pilot run for planning: spin-up at a known torque, then a free
                             coast (optional; the log format of braking.csv, forward only)

The logs' extension is device.toml ``[log] format``'s (``.csv``, ``.tdms``, ``.parquet``);
program.csv is always CSV.
    EXP/result.json          written by ``identify``
    EXP/calibration.toml     written by ``calibrate``, applied by ``identify`` (optional)
    EXP/reference.toml       a reference body's certified data (a calibration's reference
                             folder only)
    EXP/record.toml          the lab's record: operator, part, serial, environment (optional)
    EXP/spec.toml            the part's specification and decision rule (optional)
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device, load_device, require_protocol
from rsp_inertia.plant.direction import Direction

__all__ = [
    "BODY_FILE",
    "CALIBRATION_FILE",
    "DEVICE_FILE",
    "ENCODER_FIGURE",
    "PLAN_FIGURE",
    "RECORD_FILE",
    "REFERENCE_FILE",
    "REPORT_FILE",
    "RESULT_FILE",
    "SPEC_FILE",
    "VIRTUAL_FILE",
    "Experiment",
    "open_experiment",
]

# The names of an experiment's files: the one place they are spelled (docs/files.md).
DEVICE_FILE = "device.toml"
"""The gimbal, the protocol and the mounting (required)."""
VIRTUAL_FILE = "virtual.toml"
"""The virtual device's truth (a virtual device only)."""
REFERENCE_FILE = "reference.toml"
"""A reference body's certified data (a calibration's reference folder)."""
CALIBRATION_FILE = "calibration.toml"
"""Written by ``calibrate``, applied by ``identify``."""
RECORD_FILE = "record.toml"
"""The lab's record of the measurement (optional; identify copies it into result.json)."""
SPEC_FILE = "spec.toml"
"""The part's specification and decision rule (optional; identify decides against it)."""
RESULT_FILE = "result.json"
"""Written by ``identify``."""
REPORT_FILE = "report.html"
"""Written by ``report``."""
BODY_FILE = "body.json"
"""Written by ``combine`` into its --out folder."""
PLAN_FIGURE = "plan.png"
"""Written by ``plan``."""
ENCODER_FIGURE = "encoder_error.png"
"""Written by ``calibrate`` when it estimates the encoder's error."""


@dataclass(frozen=True)
class Experiment:
    """An experiment folder with its device description loaded."""

    root: Path
    """The folder."""
    device: Device
    """device.toml, validated."""

    @property
    def n_stages(self) -> int:
        """Number of [[stage]] tables in device.toml."""
        return len(self.device.stages)

    @property
    def device_path(self) -> Path:
        """``device.toml``."""
        return self.root / DEVICE_FILE

    def stage_dir(self, stage: int) -> Path:
        """Folder of stage ``stage`` (1-based)."""
        self.check_stage(stage)
        return self.root / f"stage{stage}"

    @property
    def log_extension(self) -> str:
        """The logs' extension by device.toml ``[log] format``: ``.csv``, ``.tdms`` or
        ``.parquet`` (program.csv is always ``.csv``)."""
        return self.device.log.extension

    def _pass_path(self, stage: int, name: str, direction: Direction, extension: str) -> Path:
        """``stageN/name.ext`` for a forward run, ``stageN/name_backward.ext`` backward."""
        suffix = "" if direction is Direction.FORWARD else f"_{direction}"
        return self.stage_dir(stage) / f"{name}{suffix}{extension}"

    def braking_path(self, stage: int, direction: Direction = Direction.FORWARD) -> Path:
        """``stageN/braking.csv``, or ``stageN/braking_backward.csv`` backward (the
        extension by ``[log] format``)."""
        return self._pass_path(stage, "braking", direction, self.log_extension)

    def program_path(self, stage: int, direction: Direction = Direction.FORWARD) -> Path:
        """``stageN/program.csv``, or ``stageN/program_backward.csv`` backward (always CSV:
        our own output, read by the drive)."""
        return self._pass_path(stage, "program", direction, ".csv")

    def reverse_path(self, stage: int, direction: Direction = Direction.FORWARD) -> Path:
        """``stageN/reverse.csv``, or ``stageN/reverse_backward.csv`` backward (the
        extension by ``[log] format``)."""
        return self._pass_path(stage, "reverse", direction, self.log_extension)

    def pilot_path(self, stage: int) -> Path:
        """``stageN/pilot.csv``: the pilot run of stage N (spin-up, then coast; forward only;
        the extension by ``[log] format``)."""
        return self.stage_dir(stage) / f"pilot{self.log_extension}"

    def pendulum_path(self, stage: int, node: int) -> Path:
        """``stageN/pendulum_kK.csv``: torsion-pendulum run at node K (1-based) of stage N
        (the extension by ``[log] format``)."""
        return self.stage_dir(stage) / f"pendulum_k{node}{self.log_extension}"

    @property
    def result_path(self) -> Path:
        """``result.json``."""
        return self.root / RESULT_FILE

    @property
    def calibration_path(self) -> Path:
        """``calibration.toml`` (written by calibrate, applied by identify)."""
        return self.root / CALIBRATION_FILE

    @property
    def reference_path(self) -> Path:
        """``reference.toml`` (a reference body's data, in a calibration's reference folder)."""
        return self.root / REFERENCE_FILE

    @property
    def record_path(self) -> Path:
        """``record.toml`` (the lab's record; optional)."""
        return self.root / RECORD_FILE

    @property
    def spec_path(self) -> Path:
        """``spec.toml`` (the part's specification and decision rule; optional)."""
        return self.root / SPEC_FILE

    def identify_inputs(self) -> list[Path]:
        """The files ``identify`` reads that exist, in a fixed order: device.toml,
        calibration.toml, record.toml, spec.toml, every run's braking and reverse logs (stage by stage, each
        direction of ``stage.directions``) and the pendulum logs. result.json records their
        sha256 (rsp_inertia.provenance); ``report`` and ``combine`` check them against the
        folder (a missing log is identify's to refuse)."""
        files = [self.device_path, self.calibration_path, self.record_path, self.spec_path]
        for stage, st in enumerate(self.device.stages, 1):
            for direction in st.directions:
                files += [self.braking_path(stage, direction), self.reverse_path(stage, direction)]
        files += [
            self.pendulum_path(stage, k)
            for stage, st in enumerate(self.device.stages, 1)
            for k in range(1, len(st.nodes) + 1)
        ]
        return [path for path in files if path.is_file()]

    @property
    def report_path(self) -> Path:
        """``report.html``."""
        return self.root / REPORT_FILE

    @property
    def plan_figure_path(self) -> Path:
        """``plan.png``."""
        return self.root / PLAN_FIGURE

    @property
    def virtual_path(self) -> Path:
        """``virtual.toml`` (virtual device only)."""
        return self.root / VIRTUAL_FILE

    def check_stage(self, stage: int) -> None:
        """Raise InputError unless 1 <= stage <= n_stages."""
        if not 1 <= stage <= self.n_stages:
            raise InputError(
                f"{self.device_path}: no stage {stage}: the device has "
                f"{self.n_stages} stage(s), numbered from 1"
            )

    def stages(self, stage: int | None = None) -> list[int]:
        """[stage] if given (checked), else every stage number."""
        if stage is not None:
            self.check_stage(stage)
            return [stage]
        return list(range(1, self.n_stages + 1))


def open_experiment(path: str | os.PathLike, protocol: bool = True) -> Experiment:
    """Open the experiment folder ``path`` and validate its device.toml.

    ``protocol``: refuse a stage without its ``launch_speed`` or ``braking_torque``
    (rsp_inertia.plant.config.require_protocol); ``plan``, which chooses them, and the runs
    that do not use them (a pilot, a pendulum run) pass False.
    """
    root = Path(path)
    if not root.is_dir():
        raise InputError(f"{root}: not an experiment folder (no such directory)")
    device = load_device(root / DEVICE_FILE)
    if protocol:
        require_protocol(device, root / DEVICE_FILE)
    return Experiment(root=root, device=device)
