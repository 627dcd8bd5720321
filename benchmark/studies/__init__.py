"""One-off studies behind docs/findings.md and docs/training.md, each ``python -m
benchmark.studies.NAME``."""

from __future__ import annotations

import sys

__all__ = ["report_error"]


def report_error(parser, exc) -> int:
    """A study command's answer to a user's mistake: ``PROG: error: MESSAGE``, one line on
    stderr, and the exit status 2 to return."""
    print(f"{parser.prog}: error: {exc}", file=sys.stderr)
    return 2
