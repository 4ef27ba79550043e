"""Where a result comes from: when it was made, by which software, from which input files.

``identify`` records :func:`make_provenance` in result.json (``provenance``); ``report``
checks the recorded inputs against the folder with :func:`input_changes`, so a log changed,
removed or added (a calibration.toml written after identify) after the result was made is
reported, not silently shown with the old numbers.
"""

from __future__ import annotations

import datetime
import os
import platform
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path

from rsp_inertia.infra.files import file_sha256

__all__ = [
    "CHANGES",
    "PACKAGES",
    "created_now",
    "input_changes",
    "input_status",
    "make_provenance",
    "package_versions",
]

PACKAGES = ("rsp-inertia", "numpy", "scipy", "casadi", "control", "matplotlib")
"""Whose installed versions a result records."""


def package_versions() -> dict[str, str]:
    """Python's and :data:`PACKAGES`' installed versions ("not installed" for a missing one)."""
    versions = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def created_now() -> str:
    """The present time in UTC, ISO 8601 to the second (``2026-11-26T13:05:00Z``).

    The environment variable ``SOURCE_DATE_EPOCH`` (seconds since 1970, the reproducible-builds
    convention) replaces the clock: with it, the same inputs give byte-identical files.
    """
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch is not None and epoch.strip().isdigit():
        moment = datetime.datetime.fromtimestamp(int(epoch), datetime.UTC)
    else:
        moment = datetime.datetime.now(datetime.UTC)
    return moment.strftime("%Y-%m-%dT%H:%M:%SZ")


def _name(root: Path, path: Path) -> str:
    """``path`` relative to the experiment folder, with forward slashes (the folder may move)."""
    try:
        return path.relative_to(root).as_posix()
    except ValueError:
        return path.as_posix()


def make_provenance(command: str, root: str | os.PathLike, inputs: Iterable[Path]) -> dict:
    """result.json's ``provenance``: the command, when it ran, the software's versions and
    the sha256 of every input file.

    Parameters
    ----------
    command : str
        The command that made the result ("identify").
    root : str or os.PathLike
        The experiment folder: the inputs are named relative to it (the folder may move).
    inputs : iterable of pathlib.Path
        The files the command read.

    Returns
    -------
    dict
        ``{"command", "created" (:func:`created_now`), "software"
        (:func:`package_versions`), "inputs": {name: sha256}}``.
    """
    root = Path(root)
    return {
        "command": command,
        "created": created_now(),
        "software": package_versions(),
        "inputs": {_name(root, Path(p)): file_sha256(p) for p in inputs},
    }


CHANGES = {
    "changed": "changed since the result was made",
    "removed": "removed since the result was made",
    "new": "not read when the result was made (written after it?)",
}
"""What :func:`input_changes` says of an input in each state but ``"as read"``."""


def input_status(
    root: str | os.PathLike, recorded: dict[str, str], inputs: Iterable[Path]
) -> dict[str, str]:
    """Each input's state against what a result recorded. Every file is hashed once.

    Parameters
    ----------
    root : str or os.PathLike
        The experiment folder the names are relative to.
    recorded : dict of str to str
        The result's inputs, name -> sha256 (result.json's ``provenance.inputs``).
    inputs : iterable of pathlib.Path
        The files the command would read today.

    Returns
    -------
    dict of str to str
        Name -> ``"as read"``, ``"changed"``, ``"removed"``, or ``"new"`` (read today, not
        when the result was made); the recorded names first, in their order.
    """
    root = Path(root)
    now = {_name(root, Path(p)): Path(p) for p in inputs}
    status = {}
    for name, digest in recorded.items():
        path = now.get(name, root / name)
        if not path.is_file():
            status[name] = "removed"
        else:
            status[name] = "as read" if file_sha256(path) == digest else "changed"
    status.update({name: "new" for name in now if name not in recorded})
    return status


def input_changes(status: dict[str, str]) -> list[str]:
    """One line per input of :func:`input_status` that is not as read. Empty: the same
    files."""
    return [f"{name}: {CHANGES[state]}" for name, state in status.items() if state != "as read"]
