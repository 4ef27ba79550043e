"""Command line of rsp-inertia: parse arguments, call one library function, print."""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rsp-inertia`` console script."""
    print("rsp-inertia: under construction", file=sys.stderr)
    return 1
