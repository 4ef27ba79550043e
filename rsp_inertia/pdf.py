"""``report --pdf``: the report printed to PDF, as a browser prints it.

The renderer is a headless Chromium (its ``--print-to-pdf``: the report's print layout as a
reader's browser prints it, page numbers from the CSS ``@page`` margin boxes, which Chromium
prints from version 131), found on the PATH under :data:`BROWSERS`. Without one: one line
naming what to install (InputError, exit 2), found before anything is written.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from rsp_inertia.infra.errors import InputError

__all__ = ["BROWSERS", "BROWSER_FLAGS", "PAPERS", "find_renderer", "print_pdf"]

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
"""The headless browsers tried, in order, on the PATH."""

BROWSER_FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--no-pdf-header-footer",
)
"""Chromium's flags: no window, no network of its own (the report fetches nothing), no
header or footer of its own (the report's ``@page`` rule prints its number and page x of y)."""

PAPERS = {"a4": "A4", "letter": "letter"}
"""``--paper`` -> the CSS page size."""

TIMEOUT = 120.0
"""s, the longest a print may take (the demo's report prints in about 2 s)."""

INSTALL = (
    "report --pdf: no PDF renderer: install Chromium (apt-get install chromium, or put a "
    f"browser named {' or '.join(BROWSERS)} on the PATH)"
)
"""The one line of a machine with neither."""


def find_renderer() -> str:
    """The browser ``print_pdf`` will use: the first of :data:`BROWSERS` on the PATH.

    Raises
    ------
    InputError
        None is installed (the line names what to install).
    """
    for name in BROWSERS:
        found = shutil.which(name)
        if found:
            return found
    raise InputError(INSTALL)


def print_pdf(html_path: str | os.PathLike, pdf_path: str | os.PathLike,
              paper: str = "a4", browser: str | None = None) -> Path:
    """Print the HTML file ``html_path`` to ``pdf_path`` (atomically) on ``paper``.

    Parameters
    ----------
    html_path : str or os.PathLike
        A self-contained HTML file (the report).
    pdf_path : str or os.PathLike
        The PDF to write.
    paper : str, optional
        ``"a4"`` (default) or ``"letter"`` (:data:`PAPERS`).
    browser : str, optional
        The browser's executable (:func:`find_renderer`'s, found again when None).

    Returns
    -------
    pathlib.Path
        ``pdf_path``.

    Raises
    ------
    InputError
        An unknown paper, no browser, or a browser that printed nothing (its message).
    """
    if paper not in PAPERS:
        raise InputError(f"--paper {paper}: not one of {', '.join(PAPERS)}")
    html_path, pdf_path = Path(html_path), Path(pdf_path)
    executable = browser or find_renderer()
    size = f"<style>@page{{size:{PAPERS[paper]}}}</style></head>"
    text = html_path.read_text(encoding="utf-8").replace("</head>", size, 1)
    with tempfile.TemporaryDirectory(prefix="rsp-pdf-", dir=pdf_path.parent) as scratch:
        page, printed = Path(scratch) / "page.html", Path(scratch) / "page.pdf"
        page.write_text(text, encoding="utf-8")
        _chromium(executable, page, printed, Path(scratch) / "profile")
        os.replace(printed, pdf_path)
    return pdf_path


def _chromium(executable: str, page: Path, printed: Path, profile: Path) -> None:
    """Chromium's print of ``page`` to ``printed`` (a fresh profile, removed with it)."""
    command = [executable, *BROWSER_FLAGS, f"--user-data-dir={profile}",
               f"--print-to-pdf={printed}", page.resolve().as_uri()]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT,
                              check=False)
    except subprocess.TimeoutExpired:
        raise InputError(f"report --pdf: {executable} did not print within {TIMEOUT:g} s")
    if not printed.is_file() or printed.stat().st_size == 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise InputError(f"report --pdf: {executable} printed nothing (exit {done.returncode}:"
                         f" {last})")

