"""Experiment planning: each stage's launch speed and braking torque (docs/method.md §4).

The braking torque and the launch speed are protocol choices. This module tries a grid of
them per stage on a nominal model of the stage (a pilot run's fit, or the rough guesses of
``device.toml [plan]``), keeps the protocols that every limit admits, predicts for
each the standard deviations that ``identify`` will report (rsp_inertia.estimation.predict: the same
balances, the same noise model) and picks, over all stages together, the protocols with the
smallest predicted std of the worst J_k whose total duration fits the user's budget.

The candidates of each stage and the limits that admit them: rsp_inertia.design.candidates.

Objective: the smallest predicted worst std over the axes. The runs' noises are independent,
so each candidate's information matrix is computed once (rsp_inertia.estimation.predict.run_information)
and combinations of one candidate per stage are summed and inverted exhaustively. These
stds are an ideal reverse's, right for ranking protocols; what the chosen plan promises in
closed loop comes from its rehearsal (rsp_inertia.design.rehearsal).
"""

from __future__ import annotations

import itertools
import math
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from rsp_inertia.design.candidates import (
    RELEASE_BEFORE_NODE_DEG,
    TORQUE_MARGIN,
    Candidate,
    StageModel,
    evaluate,
    planned_release,
    stage_candidates,
)
from rsp_inertia.estimation.predict import axis_stds, combine_information
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.frozen import freeze_arrays
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.geometry import device_design

# RELEASE_BEFORE_NODE_DEG, TORQUE_MARGIN, StageModel and planned_release live in
# rsp_inertia.design.candidates; they are re-exported here, where rsp_inertia.planning,
# rsp_inertia.api and plant.device_config's message name them.
__all__ = [
    "MAX_COMBINATIONS",
    "RELEASE_BEFORE_NODE_DEG",
    "TORQUE_MARGIN",
    "Plan",
    "StageModel",
    "make_plan",
    "map_stages",
    "planned_release",
]

MAX_COMBINATIONS = 500_000
"""Combinations of one candidate per stage evaluated exhaustively (beyond: refused)."""


@dataclass(frozen=True)
class Plan:
    """The chosen protocols and what they promise."""

    chosen: tuple[Candidate, ...]
    """One per stage."""
    axis_std: np.ndarray
    """kg m^2, predicted std of J_k at every node (device_design order)."""
    axis_stage: np.ndarray
    """Stage of each axis."""
    duration: float
    """s, the whole experiment's motion time."""
    max_duration: float
    """s, the budget it was chosen within."""
    candidates: tuple[tuple[Candidate, ...], ...]
    """Per stage, every candidate tried."""
    front: np.ndarray
    """(k, 2) [duration s, worst std kg m^2]: the best worst std within each duration."""
    current: tuple[Candidate, ...] | None = None
    """The protocols device.toml held before, evaluated the same way (None if infeasible, or
    if a stage stated none)."""
    current_std: float | None = None
    """kg m^2, their predicted worst std."""
    tradeoff: tuple[tuple[int, float, Candidate | None, float, float], ...] = ()
    """Per stage and launch speed tried: (stage, speed, its best feasible candidate within
    the budget with the other stages as chosen or None, the predicted worst std over the
    stage's own axes, and over all axes), stds in kg m^2."""

    def __post_init__(self) -> None:
        freeze_arrays(self)  # its arrays read-only, as the record is frozen

    @property
    def worst(self) -> float:
        return float(self.axis_std.max())


def map_stages(fn, jobs: list[tuple]) -> list:
    """[fn(*job) for job in jobs], the jobs in parallel processes (forked, one per job up to
    the machine's cores) when there are several: the stages are independent, and each job is
    deterministic, so the result does not depend on the scheduling."""
    workers = min(len(jobs), os.cpu_count() or 1)
    if workers <= 1:
        return [fn(*job) for job in jobs]
    context = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(workers, mp_context=context) as pool:
        return list(pool.map(fn, *zip(*jobs)))


def make_plan(
    device: Device,
    models: list[StageModel],
    max_duration: float,
    two_level: bool = False,
) -> Plan:
    """Choose every stage's protocol (module docstring).

    Parameters
    ----------
    device : Device
        The gimbal, with the protocols it states now (evaluated for comparison).
    models : list of StageModel
        What the planner knows of each stage.
    max_duration : float
        s, the budget: the whole experiment's motion time. The stages' candidates are
        evaluated in parallel processes (:func:`map_stages`).
    two_level : bool, optional
        Two-level brakings only, whose balances measure each run's pass gain
        (rsp_inertia.design.candidates.stage_candidates).

    Returns
    -------
    Plan
        The chosen protocols, what they promise and what else was tried.

    Raises
    ------
    InputError
        A stage has no feasible protocol (the message names the limit and by how much), or
        no combination fits ``max_duration``.
    """
    per_stage = []
    found = map_stages(
        stage_candidates, [(device, sm, max_duration, two_level) for sm in models]
    )
    for sm, cands in zip(models, found):
        feasible = [c for c in cands if c.feasible]
        if not feasible:
            raise InputError(f"stage {sm.stage}: no feasible protocol: {_closest(cands)}")
        per_stage.append((cands, feasible))
    lists = [f for _, f in per_stage]
    count = math.prod(len(f) for f in lists)
    if count > MAX_COMBINATIONS:
        raise InputError(
            f"device.toml: {count} combinations of the stages' protocols, at most "
            f"{MAX_COMBINATIONS} are searched: plan fewer stages at once"
        )
    combos = list(itertools.product(*[range(len(f)) for f in lists]))
    durations = np.array([sum(lists[s][i].run_time for s, i in enumerate(c)) for c in combos])
    infos = np.array([sum(lists[s][i].information for s, i in enumerate(c)) for c in combos])
    worst = axis_stds(device, infos).max(axis=1)
    within = durations <= max_duration
    if not np.any(within):
        shortest = float(durations.min())
        raise InputError(
            f"--max-duration: the shortest feasible experiment takes {shortest:.1f} s, "
            f"{shortest - max_duration:.1f} s over the {max_duration:g} s allowed"
        )
    best = int(np.flatnonzero(within)[np.argmin(worst[within])])
    chosen = tuple(lists[s][i] for s, i in enumerate(combos[best]))
    order = np.argsort(durations, kind="stable")
    running = np.minimum.accumulate(worst[order])
    keep = np.concatenate([[True], running[1:] < running[:-1]])
    front = np.column_stack([durations[order][keep], running[keep]])
    design = device_design(device)
    axis_std = combine_information(device, [c.information for c in chosen])
    current, current_std = None, None
    if all(st.launch_speed is not None and st.braking_torque is not None for st in device.stages):
        current = tuple(
            evaluate(
                device, sm, st.launch_speed, st.braking_torque,
                braking_torque_2=st.braking_torque_2, switch_turns=st.braking_switch_turns,
            )
            for sm, st in zip(models, device.stages)
        )
        if all(c.feasible for c in current):
            infos = [c.information for c in current]
            current_std = float(combine_information(device, infos).max())
        else:
            current = None
    design = device_design(device)
    rows = []
    for k, cands in enumerate(per_stage):
        others = [c for j, c in enumerate(chosen) if j != k]
        rest_time = sum(c.run_time for c in others)
        for speed in sorted({c.launch_speed for c in cands[0]}):
            options = [
                c for c in cands[1]
                if c.launch_speed == speed and rest_time + c.run_time <= max_duration
            ]
            if not options:
                rows.append((k + 1, speed, None, math.nan, math.nan))
                continue
            stack = np.array([sum(o.information for o in others) + c.information for c in options])
            stds = axis_stds(device, stack)
            own = stds[:, np.asarray(design.stages) == k + 1].max(axis=1)
            j = int(np.argmin(own))
            rows.append((k + 1, speed, options[j], float(own[j]), float(stds[j].max())))
    return Plan(
        tradeoff=tuple(rows),
        chosen=chosen,
        axis_std=axis_std,
        axis_stage=np.asarray(design.stages),
        duration=float(durations[best]),
        max_duration=max_duration,
        candidates=tuple(tuple(c) for c, _ in per_stage),
        front=front,
        current=current,
        current_std=current_std,
    )


def _closest(cands: list[Candidate]) -> str:
    """The limit that binds: the violation of the candidate that breaks the fewest limits."""
    best = min(
        cands,
        key=lambda c: (len(c.violations) or 99, -(c.turns if math.isfinite(c.turns) else 0.0)),
    )
    if not best.violations:
        return "the balances cannot be formed"
    what = "; ".join(best.violations)
    return f"at launch {best.launch_speed:.3g} rad/s, braking {best.braking_torque:.3g} N m: {what}"
