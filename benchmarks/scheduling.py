"""Running a sweep's cases: local processes or a Dask cluster, one cached JSON file per case.

:func:`run_sweep` runs every case (a :class:`benchmarks.cases.Case` or a
:class:`benchmarks.sensitivity.Perturbation`) whose file is missing or was made by other code
(:func:`benchmarks.cases.code_fingerprint`), writes each row as soon as it arrives, so that an
interrupted sweep resumes, and returns all rows in case order. A case that crashes (a bug, not
bad input) becomes a row flagged ``bug`` that is never cached. The scratch folders of cases
whose process was killed are removed when the next sweep starts (:mod:`benchmarks.scratch`).
"""

from __future__ import annotations

import json
import os
import traceback
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import asdict
from pathlib import Path

import benchmarks
from benchmarks import cases as case_module
from benchmarks import sensitivity
from benchmarks.cases import Case, code_fingerprint
from benchmarks.scratch import remove_stale
from benchmarks.sensitivity import Perturbation
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import write_atomic

__all__ = ["PACKAGES", "run_guarded", "run_sweep"]

PACKAGES = (
    "infra", "plant", "virtual", "ocp", "estimation", "design", "rsp_inertia", "benchmarks"
)  # folder names
"""The project's packages: where a crash's innermost frame of interest lies."""


def run_guarded(case: Case | Perturbation) -> dict:
    """The case's row (:func:`benchmarks.cases.run_case` or
    :func:`benchmarks.sensitivity.run_perturbation`), a crash turned into a row flagged ``bug``.

    One crashing case must not lose a sweep's other results or its report; the row says what
    crashed and where, and is never cached, so the case runs again once the bug is fixed.
    """
    try:
        if isinstance(case, Perturbation):
            return sensitivity.run_perturbation(case)
        return case_module.run_case(case)
    except Exception as error:  # noqa: BLE001 - reported in its row, never cached
        frames = [
            f
            for f in traceback.extract_tb(error.__traceback__)
            if Path(f.filename).parent.name in PACKAGES
        ]
        where = ""
        if frames:
            path = Path(frames[-1].filename)
            where = f" at {path.parent.name}/{path.name}:{frames[-1].lineno} ({frames[-1].name})"
        return {
            "case": case.name,
            **asdict(case),
            "error": f"bug: {type(error).__name__}: {' '.join(str(error).split())}{where}",
            "bug": True,
        }


def run_sweep(
    cases: Iterable[Case | Perturbation],
    out_dir: str | os.PathLike,
    scheduler: str | None = None,
    jobs: int = -1,
    progress: bool = True,
) -> list[dict]:
    """Run every case not yet in ``out_dir/cases/``; return all rows, sorted by case.

    Parameters
    ----------
    cases : iterable of Case or Perturbation
        The grid; duplicates are run once.
    out_dir : path
        Results folder; one JSON file per case goes to ``out_dir/cases/<case.name>.json``,
        written atomically as soon as the case finishes. A case whose file exists, made by
        the same code (:func:`benchmarks.cases.code_fingerprint`), is not run again, so an
        interrupted sweep resumes where it stopped; a change of the code runs it again. A
        case that crashes (a bug, not an InputError) gets a row flagged ``bug`` and no file.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``): the cases run on its workers
        through ``client.map`` (needs dask.distributed, and rsp-inertia and this checkout's
        ``benchmarks`` importable on the scheduler and the workers: checked first, an
        InputError naming the address). By default they run on local processes (joblib,
        loky).
    jobs : int
        Local processes (joblib's n_jobs: -1 = one per core, 1 = in this process).
    progress : bool
        Show a progress bar over the completed cases (on stderr).

    Returns
    -------
    list of dict
        One row per case, in the order of the sorted cases (the sweep's cases first, then the
        perturbations): the same inputs give the same rows (timings aside) whatever the
        scheduler.
    """
    from tqdm import tqdm

    cases = sorted(set(cases), key=lambda c: (isinstance(c, Perturbation), c))
    remove_stale()  # killed cases' scratch folders on this machine (each case cleans its own)
    case_dir = Path(out_dir) / "cases"
    case_dir.mkdir(parents=True, exist_ok=True)
    code = code_fingerprint()
    rows: dict[str, dict] = {}
    todo = []
    for case in cases:
        path = case_dir / f"{case.name}.json"
        cached = json.loads(path.read_text()) if path.is_file() else None
        if cached is not None and cached.get("code") == code:
            rows[case.name] = cached
        else:
            todo.append(case)
    run = _on_cluster(todo, scheduler) if scheduler else _on_processes(todo, jobs)
    with tqdm(
        total=len(cases), initial=len(cases) - len(todo), disable=not progress,
        desc="sweep", unit="case",
    ) as bar:
        for row in run:
            if not row.get("bug"):
                write_atomic(case_dir / f"{row['case']}.json", json.dumps(row, indent=2) + "\n")
            rows[row["case"]] = row
            bar.set_postfix_str(row["case"] + (" (failed)" if row["error"] else ""))
            bar.update()
    return [rows[case.name] for case in cases]


def _on_processes(cases: Sequence[Case | Perturbation], jobs: int) -> Iterator[dict]:
    """Rows of ``cases`` as they complete, on local processes (checked before any runs)."""
    from joblib import Parallel, delayed

    if jobs == 0:
        raise InputError("--jobs: must not be 0 (-1 = one process per core)")
    if not cases:
        return iter(())
    parallel = Parallel(n_jobs=jobs, return_as="generator_unordered")
    return parallel(delayed(run_guarded)(case) for case in cases)


def _on_cluster(cases: Sequence[Case | Perturbation], address: str) -> Iterator[dict]:
    """Rows of ``cases`` as they complete, on the Dask cluster at ``address``.

    Importing dask, connecting and checking that the scheduler and the workers import
    ``benchmarks`` (:func:`_check_imports`) happen here, before any case runs, so that a
    missing package, a wrong address or a cluster started elsewhere is one line of error.
    """
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise InputError(
            "--scheduler: dask.distributed is not installed: pip install 'rsp-inertia[cluster]'"
        ) from None
    if not cases:
        return iter(())
    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as error:
        reason = " ".join(str(error).split()) or type(error).__name__
        raise InputError(f"--scheduler {address}: cannot connect: {reason}") from None
    try:
        _check_imports(client, address)
    except InputError:
        client.close()
        raise

    def rows() -> Iterator[dict]:
        with client:
            futures = client.map(run_guarded, cases, key=[f"rsp-bench-{c.name}" for c in cases])
            for future in as_completed(futures):
                yield future.result()

    return rows()


IMPORT_PROBE = "import benchmarks.scheduling"
"""What a cluster must run to take the sweep's cases: the scheduler unpickles the task graph
(:func:`run_guarded` and the cases) and the workers run it, so both import this module (and
with it rsp_inertia and the case modules)."""


def _check_imports(client, address: str) -> None:
    """Refuse a scheduler, or a worker already connected, that cannot import ``benchmarks``.

    Without the check the sweep fails late and badly: a scheduler that cannot unpickle the
    task graph answers every case with a RuntimeError ("Error during deserialization of the
    task graph", caused by a ModuleNotFoundError), and a worker that cannot unpickle a case
    drops its connection to the scheduler and leaves the sweep waiting for ever. The probe is
    ``exec`` of :data:`IMPORT_PROBE`, which any Python unpickles. Workers that join later are
    not checked.
    """
    checkout = Path(benchmarks.__file__).resolve().parent.parent
    try:
        client.run_on_scheduler(exec, IMPORT_PROBE, {})
    except Exception as error:  # noqa: BLE001 - whatever stops the import, named below
        faults = {"the scheduler": error}
    else:
        workers = client.run(exec, IMPORT_PROBE, {}, on_error="return")
        faults = {
            f"its worker {worker}": error
            for worker, error in sorted(workers.items())
            if isinstance(error, Exception)
        }
    if not faults:
        return
    where, error = next(iter(faults.items()))
    reason = f"{type(error).__name__}: {' '.join(str(error).split())}"
    if isinstance(error, ModuleNotFoundError) and error.name == "benchmarks":
        fix = f"start it from the checkout's folder {checkout} or with PYTHONPATH={checkout}"
    else:
        fix = f"install rsp-inertia there with its extra 'cluster' (pip install '{checkout}[cluster]')"
    more = f" (and {len(faults) - 1} other worker(s))" if len(faults) > 1 else ""
    raise InputError(
        f"--scheduler {address}: {where}{more} cannot import this checkout's benchmarks "
        f"({reason}): {fix}; see docs/commands.md"
    )
