"""The experiment folder of INTERFACES.md: where each file of an experiment lives.

One folder is one experiment::

    EXP/device.toml          the gimbal (required)
    EXP/virtual.toml         only for a virtual device
    EXP/stageN/braking.csv   encoder log of the braking pass of stage N (1-based)
    EXP/stageN/program.csv   torque program of the reverse pass
    EXP/stageN/reverse.csv   log of the reverse pass
    EXP/stageN/pendulum_kK.csv  torsion-pendulum baseline run at node K (optional)
    EXP/result.json          written by ``identify``
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from plant.config import Device, Virtual, load_device, load_virtual
from plant.errors import InputError

__all__ = ["Experiment", "open_experiment"]


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

    def stage_dir(self, stage: int) -> Path:
        """Folder of stage ``stage`` (1-based)."""
        self.check_stage(stage)
        return self.root / f"stage{stage}"

    def braking_path(self, stage: int) -> Path:
        """``stageN/braking.csv``."""
        return self.stage_dir(stage) / "braking.csv"

    def program_path(self, stage: int) -> Path:
        """``stageN/program.csv``."""
        return self.stage_dir(stage) / "program.csv"

    def reverse_path(self, stage: int) -> Path:
        """``stageN/reverse.csv``."""
        return self.stage_dir(stage) / "reverse.csv"

    def pendulum_path(self, stage: int, node: int) -> Path:
        """``stageN/pendulum_kK.csv``: torsion-pendulum run at node K (1-based) of stage N."""
        return self.stage_dir(stage) / f"pendulum_k{node}.csv"

    @property
    def result_path(self) -> Path:
        """``result.json``."""
        return self.root / "result.json"

    @property
    def virtual_path(self) -> Path:
        """``virtual.toml`` (virtual device only)."""
        return self.root / "virtual.toml"

    def load_virtual(self) -> Virtual:
        """The virtual device's truth; an error if this is not a virtual experiment."""
        if not self.virtual_path.is_file():
            raise InputError(
                f"{self.virtual_path}: not found: only a virtual device (with virtual.toml) "
                "can be simulated"
            )
        return load_virtual(self.virtual_path)

    def check_stage(self, stage: int) -> None:
        """Raise InputError unless 1 <= stage <= n_stages."""
        if not 1 <= stage <= self.n_stages:
            raise InputError(
                f"{self.root / 'device.toml'}: no stage {stage}: the device has "
                f"{self.n_stages} stage(s), numbered from 1"
            )

    def stages(self, stage: int | None = None) -> list[int]:
        """[stage] if given (checked), else every stage number."""
        if stage is not None:
            self.check_stage(stage)
            return [stage]
        return list(range(1, self.n_stages + 1))


def open_experiment(path: str | os.PathLike) -> Experiment:
    """Open the experiment folder ``path`` and validate its device.toml."""
    root = Path(path)
    if not root.is_dir():
        raise InputError(f"{root}: not an experiment folder (no such directory)")
    return Experiment(root=root, device=load_device(root / "device.toml"))
