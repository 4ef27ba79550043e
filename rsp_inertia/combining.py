"""``rsp-inertia combine``: several identified mountings of one body in, ``OUT/body.json`` out.

The tensor and the whole centre of mass in body axes, by one generalised least squares over
the mountings' results (rsp_inertia.estimation.combine.combine_mountings); its result object
is :class:`rsp_inertia.results.CombineResult`.
"""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path

from rsp_inertia.estimation.combine import Combination, combine_mountings, read_mounting
from rsp_inertia.estimation.coverage import DEFAULT_COVERAGE_FACTOR, check_coverage_factor
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable, file_sha256, write_atomic
from rsp_inertia.plant.experiment import BODY_FILE, open_experiment
from rsp_inertia.provenance import (
    input_changes,
    input_status,
    integrity_state,
    make_provenance,
    sealed_json,
)

__all__ = ["body_provenance", "combine"]


def combine(
    paths: list[str | Path], out: str | Path, coverage_factor: float = DEFAULT_COVERAGE_FACTOR
) -> tuple[Combination, Path]:
    """The command behind :func:`rsp_inertia.api.combine`, documented there; returns the
    library's record (rsp_inertia.estimation.combine.Combination) and the body.json written,
    which the API holds in its CombineResult. A mounting whose inputs changed since
    identify (its result.json's provenance against the folder) gives a warning, one whose
    result.json was edited after identify wrote it (rsp_inertia.provenance.integrity_state)
    is refused; an output that cannot be written is found before anything is read."""
    coverage_factor = check_coverage_factor(coverage_factor)
    if not paths:
        raise InputError("combine: no experiment folder given: name every mounting's folder")
    exps = [open_experiment(root, protocol=False) for root in paths]
    seen: dict[Path, Path] = {}
    for exp in exps:
        same = seen.setdefault(exp.root.resolve(), exp.root)
        if same is not exp.root:
            raise InputError(f"{exp.root}: given twice (as {same}): each mounting once")
    first = exps[0]
    for exp in exps[1:]:
        if exp.device.name != first.device.name:
            raise InputError(
                f"{exp.device_path}: device.name = {exp.device.name!r} differs from "
                f"{first.device_path}'s {first.device.name!r}: the mountings must be "
                "measured on one device"
            )
    folder = Path(out)
    target = folder / BODY_FILE
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{folder}: --out: is a file, not a folder; nothing was computed")
    check_writable(target if folder.is_dir() else folder)
    mountings = [read_mounting(exp) for exp in exps]
    for exp, mounting in zip(exps[1:], mountings[1:]):
        if mounting.mass != mountings[0].mass:
            raise InputError(
                f"{exp.device_path}: body.mass = {mounting.mass!r} differs from "
                f"{first.device_path}'s {mountings[0].mass!r}: the mountings must be "
                "of one body"
            )
    warnings = []
    for exp in exps:
        document = json.loads(exp.result_path.read_text())
        state = integrity_state(document)
        if state == "edited":
            raise InputError(
                f"{exp.result_path}: edited after identify wrote it (its integrity sha256 is "
                f"not its content's): run rsp-inertia identify {exp.root} again; nothing "
                "was written"
            )
        if state == "not sealed":
            warnings.append(f"{exp.result_path}: records no integrity (an older rsp-inertia "
                            "wrote it): whether it was edited cannot be checked")
        recorded = (document.get("provenance") or {}).get("inputs")
        if recorded is None:
            warnings.append(f"{exp.result_path}: records no inputs: whether it still "
                            "describes the folder's logs cannot be checked")
            continue
        changes = input_changes(input_status(exp.root, recorded, exp.identify_inputs()))
        if changes:
            warnings.append(f"{exp.root}: identify again: {'; '.join(changes)}")
    combination = combine_mountings(mountings)
    combination = replace(combination, warnings=warnings + list(combination.warnings),
                          provenance=body_provenance(folder, [exp.result_path for exp in exps]),
                          coverage_factor=coverage_factor)
    folder.mkdir(parents=True, exist_ok=True)
    # sealed last, over the whole document (docs/files.md, body.json integrity)
    write_atomic(target, sealed_json(combination.to_dict()))
    return combination, target


def body_provenance(out: Path, results: list[Path]) -> dict:
    """body.json's ``provenance``: the command, when it ran, the software, and each mounting's
    result.json with its sha256, named relative to ``out`` (the folders may move together;
    ``report OUT`` checks them).

    Parameters
    ----------
    out : pathlib.Path
        The folder body.json is written to.
    results : list of pathlib.Path
        The mountings' result.json files, in the order given.

    Returns
    -------
    dict
        ``{"command": "combine", "created", "software", "inputs": {name: sha256}}``.
    """
    provenance = make_provenance("combine", out, [])
    provenance["inputs"] = {
        Path(os.path.relpath(path.resolve(), out.resolve())).as_posix(): file_sha256(path)
        for path in results
    }
    return provenance
