"""Where a result comes from: when it was made, by which software, from which input files.

``identify`` records :func:`make_provenance` in result.json (``provenance``); ``report``
checks the recorded inputs against the folder with :func:`input_changes`, so a log changed,
removed or added (a calibration.toml written after identify) after the result was made is
reported, not silently shown with the old numbers.

A result document (result.json, body.json) also carries its own hash, ``integrity``
(:func:`seal`, computed last when it is written): :func:`integrity_state` tells a document
edited since (a changed number, a deleted warning) from one as written, so that ``report``,
``combine`` and ``export`` do not show or use an edited result as if the software had made it.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import os
import platform
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path

from rsp_inertia.infra.files import file_sha256

__all__ = [
    "CHANGES",
    "INTEGRITY_KEY",
    "INTEGRITY_METHOD",
    "PACKAGES",
    "canonical_json",
    "created_now",
    "document_sha256",
    "input_changes",
    "input_status",
    "integrity_state",
    "make_provenance",
    "package_versions",
    "seal",
    "sealed_json",
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


# --- a result document's own hash -------------------------------------------------------------

INTEGRITY_KEY = "integrity"
"""The top-level key of a result document (result.json, body.json) that holds its hash."""

INTEGRITY_METHOD = (
    "sha256 of the UTF-8 canonical JSON of the document without its 'integrity' key: keys "
    "sorted, separators ',' and ':', non-ASCII escaped, numbers as Python's json writes "
    "them (shortest repr of each float)"
)
"""How :func:`document_sha256` hashes, as a document's ``integrity.method`` states it."""


def canonical_json(document: dict) -> bytes:
    """The canonical JSON text of a result document without its :data:`INTEGRITY_KEY`.

    Keys sorted at every level, no whitespace (separators ``,`` and ``:``), non-ASCII as
    ``\\u`` escapes, numbers as Python's ``json`` writes them (a float's shortest repr,
    which reads back to the same float): the same bytes whether the document is the one
    written or the one read back from its indented file.

    Parameters
    ----------
    document : dict
        A parsed (or about to be written) JSON document.

    Returns
    -------
    bytes
        UTF-8.
    """
    body = {key: value for key, value in document.items() if key != INTEGRITY_KEY}
    return json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode()


def document_sha256(document: dict) -> str:
    """The sha256 (hex) of :func:`canonical_json` of ``document``: what its ``integrity``
    records (docs/files.md, result.json ``integrity``).

    Parameters
    ----------
    document : dict
        A parsed JSON document.

    Returns
    -------
    str
        64 hex digits.
    """
    return hashlib.sha256(canonical_json(document)).hexdigest()


def seal(document: dict) -> dict:
    """``document`` with its ``integrity`` (its hash and how it is made), the last key: call it
    on the whole document, last, just before writing it.

    Parameters
    ----------
    document : dict
        The result document, plain JSON types; an ``integrity`` already there is replaced.

    Returns
    -------
    dict
        A new dict: ``document``'s keys and ``integrity``: {"sha256", "method"}.
    """
    body = {key: value for key, value in document.items() if key != INTEGRITY_KEY}
    return {**body, INTEGRITY_KEY: {"sha256": document_sha256(body), "method": INTEGRITY_METHOD}}


def sealed_json(document: dict) -> str:
    """The text of a result file: :func:`seal` of ``document``, indented, with a final newline
    (what ``identify`` writes to result.json and ``combine`` to body.json).

    Parameters
    ----------
    document : dict
        The whole result document (its ``to_dict()``), plain JSON types.

    Returns
    -------
    str
        The JSON text.
    """
    return json.dumps(seal(document), indent=2) + "\n"


def integrity_state(document: dict) -> str:
    """Whether a result document is as it was written.

    Parameters
    ----------
    document : dict
        A parsed result.json or body.json.

    Returns
    -------
    str
        ``"as written"`` (its ``integrity.sha256`` is its content's), ``"edited"`` (it is not:
        a number, a warning or any key changed, added or removed since it was written), or
        ``"not sealed"`` (no ``integrity``: an older rsp-inertia wrote it, or a person or a
        script; whether it was edited cannot be told).
    """
    recorded = document.get(INTEGRITY_KEY)
    if recorded is None:
        return "not sealed"
    if not isinstance(recorded, dict) or recorded.get("sha256") != document_sha256(document):
        return "edited"
    return "as written"
