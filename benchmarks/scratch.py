"""Scratch folders of a sweep's cases that a killed process does not leave behind.

Each case of a sweep (:func:`benchmarks.cases.run_case`,
:func:`benchmarks.sensitivity.run_perturbation`) writes a whole experiment into a
temporary folder of the machine it runs on, some megabytes of logs. ``tempfile``'s own
folders are removed when the case ends, but not when its process is killed (a worker lost
to the memory limit or to ``kill -9``, a sweep stopped twice with Ctrl-C): every such
folder would stay in the temporary directory for good.

So :func:`scratch_folder` makes ``<tmp>/rsp-sweep-XXXXXXXX/`` and holds an exclusive lock
(``flock``) on its file ``.owner`` while it is in use; the system releases the lock when
the process ends, however it ends. :func:`remove_stale` removes every such folder whose lock
nobody holds; every new scratch folder calls it first (on a Dask worker's machine too), and
so does :func:`benchmarks.scheduling.run_sweep` when it starts (on the machine it runs on).
Where ``fcntl`` is missing (Windows), folders are plain temporary ones, never collected.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows: no flock
    fcntl = None

__all__ = ["OWNER_FILE", "PREFIX", "UNLOCKED_AGE", "remove_stale", "scratch_folder"]

PREFIX = "rsp-sweep-"
"""Name of every scratch folder up to the random part ``tempfile.mkdtemp`` adds."""

OWNER_FILE = ".owner"
"""The file in a scratch folder that its process keeps locked."""

UNLOCKED_AGE = 3600.0
"""s: a folder without its owner file (its process killed between making the folder and
the file) is removed once this old; a younger one may be a folder being made."""


@contextmanager
def scratch_folder() -> Iterator[Path]:
    """A new empty folder in the temporary directory, removed on exit; stale ones first.

    Yields
    ------
    Path
        ``<tmp>/rsp-sweep-XXXXXXXX``, locked by this process until the ``with`` block ends
        (then removed), and left to :func:`remove_stale` if the process is killed first.

    Examples
    --------
    >>> with scratch_folder() as tmp:
    ...     _ = (tmp / "device.toml").write_text("")
    >>> tmp.exists()
    False
    """
    root = Path(tempfile.gettempdir())
    remove_stale(root)
    while True:
        folder = Path(tempfile.mkdtemp(prefix=PREFIX, dir=root))
        owner = os.open(folder / OWNER_FILE, os.O_RDWR | os.O_CREAT, 0o600)
        if fcntl is None:
            break
        fcntl.flock(owner, fcntl.LOCK_EX)
        # Another process's remove_stale may have taken the lock between the open and the
        # flock and removed the folder: then make another one.
        try:
            if os.stat(folder / OWNER_FILE).st_ino == os.fstat(owner).st_ino:
                break
        except FileNotFoundError:
            pass
        os.close(owner)
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)
        os.close(owner)


def remove_stale(root: str | os.PathLike | None = None) -> list[Path]:
    """Remove the scratch folders in ``root`` (default: the temporary directory) whose
    process has ended; return them.

    A folder is stale when nobody holds the lock on its owner file (its process ended
    without removing it), or when it has no owner file and is older than
    :data:`UNLOCKED_AGE`. Folders of running processes, on this machine or another one
    sharing the directory's locks, are left alone.
    """
    if fcntl is None:
        return []
    removed = []
    for folder in Path(root or tempfile.gettempdir()).glob(PREFIX + "*"):
        try:
            owner = os.open(folder / OWNER_FILE, os.O_RDWR)
        except FileNotFoundError:
            try:
                old = time.time() - folder.stat().st_mtime > UNLOCKED_AGE
            except OSError:
                continue
            if old and folder.is_dir():
                shutil.rmtree(folder, ignore_errors=True)
                removed.append(folder)
            continue
        except OSError:  # not a folder, or another user's
            continue
        try:
            fcntl.flock(owner, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # held: its process is running
            continue
        else:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
        finally:
            os.close(owner)
    return removed
