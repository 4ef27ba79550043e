"""docs/real-rig.md and docs/api.md run as written, in an empty folder, and print what they show.

How a page is read (``steps``), block by block in the page's order:

- a ```toml (or ```csv) block whose first line is ``# PATH`` is a file the page tells the
  reader to write: it is written to PATH, the block as given (its first line included);
- a ```toml block whose first line is ``# PATH, ...`` (words after a comma) shows what PATH
  holds at that point: the block's other lines are consecutive lines of the file, exactly;
- a plain block of ``$ `` lines holds commands, each followed by what it prints: every
  command runs in the folder, in order (``rsp-inertia ...`` through the command line's own
  ``main`` in this process, anything else in ``sh``); it must end with exit status 0, or 1
  for ``check`` (not ready, which its printed last line says);
- a plain block without commands lists files (its lines' first words): each exists once the
  page has run.

docs/api.md: its ```python blocks run in order as one script (one session: a later block uses
what an earlier one made), and the block after each (its "It prints") is its output.

What is printed is compared with what the page shows (``placed``) line by line and exactly,
the numbers included. Two things a reader sees on the page are not compared: a line ``...``
stands for any number of lines, and a line ending in `` ...`` for any line that starts with
what precedes it. Nor is a wall time (program's ``; 0.53 s ->``), which no two runs share.

The numbers are exact in one numerical environment (``PINNED``), in which the pages run in
a process of their own: OpenBLAS's SkylakeX kernels on one thread. The virtual device's runs
are seeded, so the same code prints the same digits there, on any processor that has those
kernels' instructions (AVX-512). Another processor's own kernels round differently: the
torque programs then differ in their last bits, the closed-loop reverse passes they drive
cross the encoder's counts at other samples, and from there the printed numbers differ in
their last digits (the forward-only Jz of real-rig.md by 1.6e-5 of itself, its node formula
by 0.04 std; measured with OPENBLAS_CORETYPE=Prescott). The thread count and numpy's own
SIMD kernels change no digit. On a processor without AVX-512 the pages' text is compared
and their numbers are not (``text_only``).

When the code changes what the pages print, ``python -m tests.test_docs_run`` runs both
pages in that environment and rewrites every printed line that changed in its values only
(the same text with other numbers); a changed text it reports, for a person to edit.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from rsp_inertia.cli import main

ROOT = Path(__file__).resolve().parents[1]
REAL_RIG = ROOT / "docs" / "real-rig.md"
API = ROOT / "docs" / "api.md"
RIG_DEFAULTS = ROOT / "plant" / "defaults" / "rig"

FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
WALL_TIME = re.compile(r"; \d+\.\d\d s -> ")
"""A measured wall time in program's line, which differs between two runs."""
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?")
ELLIPSIS = "..."

PINNED = {
    "OPENBLAS_CORETYPE": "SkylakeX",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "SOURCE_DATE_EPOCH": "1795000000",
}
"""The numerical environment the pages' numbers are printed in (module docstring)."""


def pinnable() -> bool:
    """Whether this processor runs OpenBLAS's SkylakeX kernels (x86-64 with AVX-512)."""
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:
        return False
    return re.search(r"^flags\s*:.*\bavx512f\b", flags, re.MULTILINE) is not None


@dataclass(frozen=True)
class Step:
    """One thing the page tells the reader to do, or shows."""

    kind: str
    """``write`` a file, ``holds`` (a file's lines), ``run`` a command, ``files`` listed."""
    line: int
    """The page's line number of the block's first line (for messages)."""
    path: str = ""
    """``write``, ``holds``: the file, relative to the working folder."""
    text: str = ""
    """``write``: the file's text; ``holds``: its lines; ``run``: the command line."""
    shown: tuple[str, ...] = ()
    """``run``: the printed lines the page shows; ``files``: the paths listed."""


def _blocks(text: str) -> Iterator[tuple[str, str, int, int]]:
    """(info string, body, line of the body's first line, line after the block's end)."""
    for match in FENCE.finditer(text):
        first = text.count("\n", 0, match.start(2)) + 1
        yield match.group(1).strip(), match.group(2), first, text.count("\n", 0, match.end()) + 1


def steps(page: Path) -> list[Step]:
    """What ``page`` (Markdown) tells the reader to do, in order (module docstring)."""
    out = []
    for info, body, line, _ in _blocks(page.read_text(encoding="utf-8")):
        lines = body.splitlines()
        if info in ("toml", "csv"):
            head = re.fullmatch(r"#\s*(\S+?)(,.*)?", lines[0].strip())
            assert head, f"{page.name}:{line}: a {info} block starts with '# PATH', not {lines[0]!r}"
            if head.group(2):
                out.append(Step("holds", line, head.group(1), "\n".join(lines[1:])))
            else:
                out.append(Step("write", line, head.group(1), body))
        elif info == "" and any(x.startswith("$ ") for x in lines):
            assert lines[0].startswith("$ "), f"{page.name}:{line}: output before a command"
            for k, x in enumerate(lines):
                if x.startswith("$ "):
                    shown = []
                    for after in lines[k + 1 :]:
                        if after.startswith("$ "):
                            break
                        shown.append(after)
                    out.append(Step("run", line + k, text=x[2:], shown=tuple(shown)))
        elif info == "":
            paths = tuple(x.split()[0] for x in lines if x.strip())
            out.append(Step("files", line, shown=paths))
    return out


# --- comparing what is printed with what the page shows --------------------------------------


Shape = Callable[[str], str]
"""What of a line is compared, when not all of it."""


def text_only(line: str) -> str:
    """A line's text, its numbers left out."""
    return NUMBER.sub("#", line)


def _same(shown: str, printed: str, shape: Shape | None = None) -> bool:
    """Whether a printed line is the one shown (with ``shape``: what it leaves of them)."""
    if shape:
        shown, printed = shape(shown), shape(printed)
    if shown.endswith(" " + ELLIPSIS) and shown.strip() != ELLIPSIS:
        return printed.startswith(shown[: -len(ELLIPSIS)])
    return WALL_TIME.sub("; <wall> s -> ", shown) == WALL_TIME.sub("; <wall> s -> ", printed)


def _segments(shown: list[str]) -> list[list[str]]:
    """The runs of lines between the page's ``...`` lines (empty runs at either end kept)."""
    out: list[list[str]] = [[]]
    for line in shown:
        if line.strip() == ELLIPSIS:
            out.append([])
        else:
            out[-1].append(line)
    return out


def placed(
    shown: list[str], printed: list[str], shape: Shape | None = None
) -> list[int] | None:
    """For each line the page shows (``...`` lines left out), the index of the printed line
    it is; None when the printed lines are not the ones shown.

    The first run of shown lines starts at the first printed line, the last ends at the last
    (unless the page puts ``...`` before or after them); each run is consecutive printed lines;
    ``...`` is any number of lines."""
    segments = _segments(shown)
    where: list[int] = []
    position = 0
    for k, segment in enumerate(segments):
        last = k == len(segments) - 1
        if k == 0:
            starts = [0]
        elif last:
            starts = [len(printed) - len(segment)]
        else:
            starts = range(position, len(printed) - len(segment) + 1)
        for start in starts:
            if start < position or start + len(segment) > len(printed):
                continue
            if last and start + len(segment) != len(printed):
                continue
            if all(_same(s, printed[start + j], shape) for j, s in enumerate(segment)):
                where += range(start, start + len(segment))
                position = start + len(segment)
                break
        else:
            return None
        if len(segments) == 1 and position != len(printed):
            return None
    return where


def differences(shown: list[str], printed: list[str]) -> str:
    """A message: what the page shows against what was printed."""
    return (
        "the page shows:\n" + "\n".join(shown) + "\n--- printed:\n" + "\n".join(printed)
    )


# --- running a page --------------------------------------------------------------------------


@contextlib.contextmanager
def _inside(folder: Path) -> Iterator[None]:
    """The working folder set to ``folder`` for the block."""
    before = Path.cwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(before)


def run_command(command: str, folder: Path) -> tuple[int, list[str]]:
    """(exit status, printed lines) of one of the page's commands, run in ``folder``."""
    words = shlex.split(command)
    if words[0] != "rsp-inertia":
        done = subprocess.run(
            command, shell=True, cwd=folder, capture_output=True, text=True, check=False
        )
        return done.returncode, (done.stdout + done.stderr).splitlines()
    printed = io.StringIO()
    with _inside(folder), contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
        status = main(words[1:])
    return status, printed.getvalue().splitlines()


@dataclass
class Outcome:
    """What a page's run found: the faults, and per command the printed lines."""

    faults: list[str]
    printed: dict[int, list[str]]
    """Page line of the command -> what it printed."""


def run_page(page: Path, folder: Path, shape: Shape | None = None) -> Outcome:
    """Do what ``page`` says in ``folder``, comparing what it shows (with ``shape``: what it
    leaves of each line); stops at a command that fails (what follows it would fail for that
    reason)."""
    outcome = Outcome([], {})
    listed: list[Step] = []
    for step in steps(page):
        where = f"{page.name}:{step.line}"
        if step.kind == "write":
            target = folder / step.path
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(step.text, encoding="utf-8")
        elif step.kind == "holds":
            target = folder / step.path
            held = target.read_text(encoding="utf-8") if target.is_file() else ""
            text = step.text
            if shape:
                held, text = shape(held), shape(text)
            if text not in held:
                outcome.faults.append(f"{where}: {step.path} does not hold\n{step.text}")
        elif step.kind == "files":
            listed.append(step)
        else:
            status, printed = run_command(step.text, folder)
            outcome.printed[step.line] = printed
            allowed = (0, 1) if shlex.split(step.text)[:2] == ["rsp-inertia", "check"] else (0,)
            if status not in allowed:
                outcome.faults.append(
                    f"{where}: $ {step.text}: exit status {status}\n" + "\n".join(printed)
                )
                return outcome
            shown = list(step.shown)
            if placed(shown, printed, shape) is None:
                outcome.faults.append(f"{where}: $ {step.text}\n" + differences(shown, printed))
    for step in listed:
        absent = [p for p in step.shown if not (folder / p).exists()]
        if absent:
            outcome.faults.append(f"{page.name}:{step.line}: listed, never made: {absent}")
    return outcome


@dataclass(frozen=True)
class ApiBlock:
    """One ```python block of docs/api.md and the output the page shows after it."""

    code: str
    line: int
    """The block's first line in the page."""
    shown: list[str]
    shown_line: int
    """The first line of the output block."""


def api_examples(page: Path) -> list[ApiBlock]:
    """docs/api.md's ```python blocks, in order, each with the output the page shows after it."""
    blocks = list(_blocks(page.read_text(encoding="utf-8")))
    code = [k for k, block in enumerate(blocks) if block[0] == "python"]
    assert code, f"{page.name}: no python block"
    examples = []
    for k in code:
        source, shown = blocks[k], blocks[k + 1]
        assert shown[0] == "", f"{page.name}:{source[2]}: the python block is not followed by its output"
        examples.append(ApiBlock(source[1], source[2], shown[1].splitlines(), shown[2]))
    return examples


def run_api_examples(page: Path, folder: Path) -> list[list[str]]:
    """The printed lines of each of docs/api.md's python blocks, run in order in one namespace
    in ``folder``."""
    namespace = {"__name__": "__main__"}
    printed = []
    for block in api_examples(page):
        out = io.StringIO()
        compiled = compile("\n" * (block.line - 1) + block.code, str(page), "exec")
        with _inside(folder), contextlib.redirect_stdout(out):
            exec(compiled, namespace)  # noqa: S102 (the examples of our own docs)
        printed.append(out.getvalue().splitlines())
    return printed


# --- the tests -------------------------------------------------------------------------------


def test_what_the_page_shows_is_compared_exactly_but_for_its_ellipses_and_wall_times():
    printed = [
        "stage 1: program: 10489 rows, OCP 8 iterations; 0.41 s -> bench-A/stage1/program.csv",
        "warning: the balances do not close (chi2 = 6.99e+03 for 14 terms); likely causes: a, b",
        "result -> bench-A/result.json",
    ]
    shown = [
        "stage 1: program: 10489 rows, OCP 8 iterations; 0.53 s -> bench-A/stage1/program.csv",
        "warning: the balances do not close (chi2 = 6.99e+03 for 14 terms); ...",
        "result -> bench-A/result.json",
    ]
    assert placed(shown, printed) == [0, 1, 2]
    assert placed([shown[0], ELLIPSIS], printed) == [0]
    assert placed([ELLIPSIS, shown[2]], printed) == [2]
    assert placed([shown[0], shown[2]], printed) is None  # a line left out needs its "..."
    assert placed(shown[:2], printed) is None
    drifted = [shown[0], shown[1].replace("6.99e+03", "7.03e+03"), shown[2]]
    assert placed(drifted, printed) is None
    assert placed(drifted, printed, text_only) == [0, 1, 2]


def in_pinned_process(page: str, folder: Path) -> dict:
    """Run ``page`` (``real-rig`` or ``api``) in ``folder`` in a process of its own in the
    ``PINNED`` environment (``python -m tests.test_docs_run PAGE FOLDER``); what it found."""
    done = subprocess.run(
        [sys.executable, "-m", "tests.test_docs_run", page, str(folder)],
        cwd=ROOT, env=os.environ | PINNED, capture_output=True, text=True, check=False,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


def _numbers_or_text() -> Shape | None:
    """Exact where the numbers are reproducible, else the text (module docstring)."""
    return None if pinnable() else text_only


def test_api_example_prints_what_the_page_shows(tmp_path):
    """docs/api.md's examples as one script in an empty folder (15 s on 2 cores)."""
    printed = in_pinned_process("api", tmp_path)["printed"]
    shape = _numbers_or_text()
    blocks = api_examples(API)
    assert len(printed) == len(blocks)
    for block, lines in zip(blocks, printed, strict=True):
        assert placed(block.shown, lines, shape) is not None, (
            f"api.md:{block.shown_line}\n" + differences(block.shown, lines)
        )
    root = tmp_path / "virtual-bench"
    figures = sorted(p.name for p in (root / "figures").iterdir())
    assert figures == sorted(
        ["design.png", "errors.png"]
        + [f"{kind}_stage{k}.png" for kind in ("motion", "tracking") for k in (1, 2)]
    )


def test_real_rig_virtual_tomls_are_the_demos():
    """The page's virtual.toml files are the demo's rig (plant/defaults/rig/), as it says,
    but for their first line (the page's: the path)."""
    written = {s.path: s.text for s in steps(REAL_RIG) if s.kind == "write"}
    for folder, source in (
        ("bench-A", RIG_DEFAULTS),
        ("bench-A/calibration/empty", RIG_DEFAULTS / "empty"),
        ("bench-A/calibration/reference", RIG_DEFAULTS / "reference"),
    ):
        page = written[f"{folder}/virtual.toml"].split("\n", 1)[1]
        demo = (source / "virtual.toml").read_text(encoding="utf-8").split("\n", 1)[1]
        assert page == demo, folder


@pytest.mark.slow  # 86 s, the default suite's longest: run by -m slow and `python -m tests.test_docs_run`
def test_real_rig_session_prints_what_the_page_shows(tmp_path):
    """docs/real-rig.md from its first file to its last command, every printed line compared
    (78 s on 2 cores at a load average of 1, 135 s at 3: in the default suite all the same,
    so that the page cannot drift from the code unnoticed)."""
    if pinnable():
        faults = in_pinned_process("real-rig", tmp_path)["faults"]
    else:
        faults = run_page(REAL_RIG, tmp_path, shape=text_only).faults
    assert not faults, "\n\n".join(faults)


# --- rewriting the pages' values --------------------------------------------------------------


def _prefix(shown: str, printed: str) -> str:
    """The start of ``printed`` that a shown ``text ...`` line stands for, with the printed
    line's numbers."""
    parts = NUMBER.split(shown[: -len(ELLIPSIS)])
    pattern = NUMBER.pattern.join(re.escape(part) for part in parts)
    return re.match(pattern, printed).group(0)


def _update(lines: list[str], first: int, shown: list[str], printed: list[str]) -> bool:
    """Put the printed values into the page's ``lines`` (the shown block's first line at index
    ``first``) where the two differ only in their numbers; False where the text differs."""
    if placed(shown, printed) is not None:
        return True
    where = placed(shown, printed, text_only)
    if where is None:
        return False
    kept = [k for k, line in enumerate(shown) if line.strip() != ELLIPSIS]
    for k, index in zip(kept, where):
        new = printed[index]
        if shown[k].endswith(" " + ELLIPSIS):
            new = _prefix(shown[k], new) + ELLIPSIS
        lines[first + k] = new + "\n"
    return True


def _rewrite() -> int:
    """Run both pages in the ``PINNED`` environment and put the printed values into them
    (module docstring)."""
    if not pinnable():
        print("this processor does not run OpenBLAS's SkylakeX kernels: its numbers would differ")
        return 1
    left = []
    with tempfile.TemporaryDirectory() as scratch:
        found = in_pinned_process("real-rig", Path(scratch))
    printed = {int(line): lines for line, lines in found["printed"].items()}
    left += [fault for fault in found["faults"] if "exit status" in fault]
    lines = REAL_RIG.read_text(encoding="utf-8").splitlines(keepends=True)
    for step in steps(REAL_RIG):
        shown = list(step.shown)
        if step.line in printed and not _update(lines, step.line, shown, printed[step.line]):
            left.append(
                f"real-rig.md:{step.line}: $ {step.text}\n"
                + differences(shown, printed[step.line])
            )
    REAL_RIG.write_text("".join(lines), encoding="utf-8")
    with tempfile.TemporaryDirectory() as scratch:
        api = in_pinned_process("api", Path(scratch))["printed"]
    lines = API.read_text(encoding="utf-8").splitlines(keepends=True)
    for block, printed_block in zip(api_examples(API), api, strict=True):
        if not _update(lines, block.shown_line - 1, block.shown, printed_block):
            left.append(f"api.md:{block.shown_line}\n" + differences(block.shown, printed_block))
    API.write_text("".join(lines), encoding="utf-8")
    print("\n\n".join(left) or "both pages print what they show")
    return 1 if left else 0


def _run(page: str, folder: Path) -> None:
    """One page run in this process, what it found printed as one line of JSON (the pinned
    process of ``in_pinned_process``)."""
    folder.mkdir(parents=True, exist_ok=True)
    if page == "api":
        found = {"printed": run_api_examples(API, folder)}
    else:
        outcome = run_page(REAL_RIG, folder)
        found = {"faults": outcome.faults, "printed": outcome.printed}
    print(json.dumps(found))


if __name__ == "__main__":
    if len(sys.argv) == 3:
        _run(sys.argv[1], Path(sys.argv[2]))
    else:
        sys.exit(_rewrite())
