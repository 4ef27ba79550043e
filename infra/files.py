"""Files written whole or not at all, checked for writability before the work, and hashed.

Every output of the package goes through :func:`write_atomic`, so a reader never sees half a
file; every command calls :func:`check_writable` on its outputs before it computes anything,
and ``identify`` records :func:`file_sha256` of each input for the report's provenance.
"""

from __future__ import annotations

import glob
import hashlib
import os
import secrets
from collections.abc import Iterable
from pathlib import Path

from rsp_inertia.infra.errors import InputError

__all__ = ["check_writable", "file_sha256", "write_atomic"]


def write_atomic(path: str | os.PathLike, text: str | bytes | Iterable[str]) -> None:
    """Replace ``path`` by a file holding ``text`` (UTF-8, newlines as given; bytes as they
    are; pieces of text one after the other, so that a long log is never whole in memory),
    all or nothing.

    The text goes to a temporary file in the same folder, is flushed to disk and renamed over
    ``path`` with ``os.replace``; a reader sees the old file or the new one, never a part. If
    anything fails, the temporary file is removed and ``path`` is left as it was.

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist.
    text : str, bytes or iterable of str
        The whole content: text (a TOML, CSV or JSON file), bytes (a PNG), or its text in
        pieces (a long CSV log, made as it is written).
    """
    target = Path(path)
    _remove_stale_temporaries(target)
    temp = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(6)}.tmp")
    # os.open with mode 0o666 lets the umask decide the permissions, as for a plain open().
    fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        if isinstance(text, bytes):
            file = os.fdopen(fd, "wb")
        else:
            file = os.fdopen(fd, "w", encoding="utf-8", newline="")
        with file:
            if isinstance(text, (str, bytes)):
                file.write(text)
            else:
                for piece in text:
                    file.write(piece)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temp, target)
    except BaseException:
        temp.unlink(missing_ok=True)
        raise


def file_sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of a file's bytes, hexadecimal (read in pieces: a log may be hundreds of
    MB). Recorded for every input by ``calibrate`` and ``identify``, checked by ``report``."""
    with open(path, "rb") as file:
        return hashlib.file_digest(file, "sha256").hexdigest()


def check_writable(path: str | os.PathLike) -> None:
    """Refuse, before any computation, an output that :func:`write_atomic` could not write:
    it needs to create a file in the target's folder (and to replace the target there).

    Raises
    ------
    InputError
        Naming the file and why (a read-only folder, a missing one, a target that is a folder).
    """
    target = Path(path)
    if target.is_dir():
        raise InputError(f"{target}: cannot be written: it is a folder; nothing was computed")
    probe = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(6)}.tmp")
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    except OSError as error:
        raise InputError(
            f"{target}: cannot be written ({error.strerror or error}); nothing was computed"
        ) from None
    probe.unlink(missing_ok=True)


def _remove_stale_temporaries(target: Path) -> None:
    """Remove the temporary files that a writer of ``target`` killed before it could clean up
    left behind (:func:`write_atomic` names them after its process id): those of processes
    that no longer run. A live writer's is left alone."""
    for temp in target.parent.glob(f".{glob.escape(target.name)}.*.tmp"):
        pid = temp.name[len(target.name) + 2 :].split(".")[0]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            temp.unlink(missing_ok=True)
        except (PermissionError, OSError):
            continue  # another user's live process, or we cannot tell: keep it
