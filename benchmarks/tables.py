"""The Markdown table both benchmark scripts write (benchmarks/results/*.md)."""

from __future__ import annotations

from collections.abc import Callable, Sequence


def markdown_table(rows: Sequence[dict], keys: Sequence[str], spec: Callable[[str], str]) -> list[str]:
    """Header, separator and one line per row; ``spec(key)`` is the format spec of a column."""
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(format(r[k], spec(k)) for k in keys) + " |")
    return lines
