"""Every default a subcommand's ``--help`` states is the default it really parses."""

from __future__ import annotations

import argparse
import math
import re

import pytest

from viewadapt.cli import build_parser

#: "... (default 1.75)", "default: both", "default hog: HOG/SVM", "default 1; -1 = all cores"
_STATED = re.compile(r"default:? ([^\s;:)]+)")
#: "hog (default), ..." and "covariant (default, J^-T)": the choice named before it
_NAMED = re.compile(r"(\S+) \(default[,)]")


def _subcommands(parser, path=()):
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _subcommands(sub, path + (name,))


def _stated_defaults():
    for path, parser in _subcommands(build_parser()):
        for action in parser._actions:
            text = " ".join((action.help or "").split())
            m = _STATED.search(text) or _NAMED.search(text)
            if m and action.dest != "help":
                yield " ".join(path), action.dest, m.group(1).rstrip(",."), \
                    parser.get_default(action.dest)


def _number(token):
    if not re.fullmatch(r"[0-9.e+\-*/]*(pi)?[0-9.e+\-*/]*", token):
        return None
    try:
        return float(eval(token, {"__builtins__": {}}, {"pi": math.pi}))  # digits and pi only
    except (SyntaxError, ZeroDivisionError, NameError, TypeError):
        return None


def _agrees(token, value) -> bool:
    if isinstance(value, bool):
        return True                                   # flags state no literal default
    if isinstance(value, (tuple, list)):
        return token.split(",") == [f"{v:g}" if isinstance(v, float) else str(v)
                                    for v in value]
    if isinstance(value, (int, float)):
        if value == -1 and token in ("all", "every"):
            return True                               # -1 = all cores
        x = _number(token)
        return x is not None and math.isclose(x, value, rel_tol=1e-9, abs_tol=1e-12)
    return token == str(value)


CASES = [c for c in _stated_defaults() if c[3] is not None]


def test_the_walk_finds_the_options_it_should():
    seen = {(cmd, dest) for cmd, dest, _, _ in CASES}
    for want in [("detect", "jobs"), ("detect", "heights"), ("detect", "rule"),
                 ("bench frames", "jobs"), ("bench frames", "heights"),
                 ("bench runtime", "jobs"), ("bench runtime", "heights"),
                 ("bench sweep", "step"), ("bench sweep", "detector"), ("demo", "jobs")]:
        assert want in seen, want


def test_every_help_that_names_a_default_is_read():
    """A help text that mentions its default in a form the walk cannot read would drop out
    of the check below unseen (as ``detect --lens`` once did)."""
    unread = [(" ".join(path), a.dest) for path, parser in _subcommands(build_parser())
              for a in parser._actions
              if a.dest != "help" and "default" in " ".join((a.help or "").split())
              and not (_STATED.search(" ".join(a.help.split()))
                       or _NAMED.search(" ".join(a.help.split())))]
    assert not unread, f"help texts whose default the walk cannot read: {unread}"
    assert _NAMED.search("or auto (default): windows") and not _STATED.search(
        "or auto (the default): windows") and not _NAMED.search("or auto (the default): x")


@pytest.mark.parametrize("command, dest, stated, value", CASES,
                         ids=[f"{c}:{d}" for c, d, _, _ in CASES])
def test_help_states_the_parsed_default(command, dest, stated, value):
    assert _agrees(stated, value), \
        f"viewadapt {command} --{dest.replace('_', '-')}: help says default {stated!r}, " \
        f"parses {value!r}"


def test_the_comparison_can_fail():
    assert not _agrees("1.75", (1.65, 1.85)) and not _agrees("1", -1)
    assert not _agrees("pi/72", 0.05) and not _agrees("hog", "acf")
    assert _agrees("pi/72", math.pi / 72) and _agrees("1.65,1.85", (1.65, 1.85))
