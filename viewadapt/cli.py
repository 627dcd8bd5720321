"""The ``viewadapt`` command line.

The library's own commands (``detect``, ``calibrate``: :mod:`viewadapt.commands`) are built
in; every other command is found through the ``viewadapt.commands`` entry points of the
installed distributions (this project's ``pyproject.toml`` registers the benchmark's, the
generator's and the end-to-end pipelines'), each a ``register(subparsers, common)``
function. So the library never imports the benchmark or the generator, and another package
can add its own commands. Subcommands import their (heavier) modules lazily, so
``viewadapt --help`` is quick and never imports Blender or torch.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from importlib.metadata import entry_points
from pathlib import Path

from .commands.calibrate import register as register_calibrate
from .commands.detect import register as register_detect
from .io.files import (
    FailedRunCleanup, RunError, UserError, check_apart, check_output_dir, claim_output_dir,
    clean_stale_partials, running_command,
)
from .io.locks import hold_output_dir
from .version import __version__

__all__ = ["main", "common_parser", "build_parser", "command_entry_points", "ENTRY_POINT_GROUP"]

#: the entry-point group of ``viewadapt`` subcommands: ``name = "module:register"``
ENTRY_POINT_GROUP = "viewadapt.commands"


def common_parser(*, jobs: int = 1) -> argparse.ArgumentParser:
    """Options every subcommand shares: ``--seed``, ``--out``, ``--jobs`` (default ``jobs``).

    Each call makes new argument objects: a parent parser's arguments are shared by every
    subcommand built from it, so a subcommand with another ``--jobs`` default takes its own
    ``common_parser(jobs=...)`` (``set_defaults`` on one subcommand would change them all).
    """
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--seed", type=int, default=0,
                   help="master random seed; written into every output's metadata (default 0)")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--jobs", type=int, default=jobs,
                   help=f"parallel worker processes (default {'all cores' if jobs == -1 else jobs}"
                        "; -1 = all cores)")
    p.add_argument("--overwrite", action="store_true",
                   help="write into a non-empty --out that viewadapt did not write (files of "
                        "the same names are replaced; no other file is deleted)")
    return p


def command_entry_points() -> list:
    """The installed ``viewadapt.commands`` entry points, in name order (the order of
    ``viewadapt --help``)."""
    return sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="viewadapt",
        description="Viewpoint adaptation for person detectors (Wang et al. 2017): remap "
                    "features with G = S (x) A instead of warping every window.")
    parser.add_argument("--version", action="version", version=f"viewadapt {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    common = common_parser()

    register_detect(sub, common)
    register_calibrate(sub, common)
    for entry in command_entry_points():
        entry.load()(sub, common)
    return parser


def command_name(args) -> str:
    """``"bench crossval"``, ``"dataset verify"``, ``"generate"``: the command of ``args``."""
    return " ".join(str(v) for v in (args.command, getattr(args, "bench_command", None),
                                     getattr(args, "dataset_command", None)) if v)


#: the options of a command whose folders it writes, and those of the inputs it reads (an
#: output may neither be, nor lie inside, nor hold an input)
OUTPUT_OPTIONS = {"out": "--out", "cache": "--cache"}
INPUT_OPTIONS = {"data": "--data", "inputs": "INPUT"}


def check_folders_apart(args) -> None:
    """Refuse (:class:`UserError`) a command whose ``--out`` or ``--cache`` overlaps its
    ``--data`` or its ``INPUT`` files and folders."""
    check_apart({opt: getattr(args, dest) for dest, opt in OUTPUT_OPTIONS.items()
                 if getattr(args, dest, None) is not None},
                {opt: getattr(args, dest) for dest, opt in INPUT_OPTIONS.items()
                 if getattr(args, dest, None) is not None})


def _close_progress_bars() -> None:
    """Close live progress bars, so an error line starts on a line of its own."""
    tq = sys.modules.get("tqdm.std")
    if tq is None:
        return
    for bar in list(getattr(tq.tqdm, "_instances", ())):
        try:
            bar.close()
        except Exception:  # noqa: BLE001 - a bar that cannot close must not hide the error
            pass
    sys.stdout.flush()


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    name = command_name(args)
    # the commands writing an --out directory (generate checks, locks and marks its own)
    out = getattr(args, "out", None) if hasattr(args, "overwrite") else None
    cleanup = kept = None

    def finish_failed(exc_type, exc, tb):
        """After a failure, while the lock is still held: what the run kept."""
        nonlocal kept
        if exc_type is not None and cleanup is not None:
            _close_progress_bars()
            kept = cleanup.finish()
        return False

    def fail(what: str, exc, rc: int) -> int:
        _close_progress_bars()
        msg = str(exc) or exc.__class__.__name__
        if kept and kept.startswith("kept"):
            msg += f" ({kept})"
        print(f"viewadapt {name}: {what}: {msg}", file=sys.stderr)
        return rc

    try:
        with running_command(name), contextlib.ExitStack() as held:
            if out is not None:
                check_folders_apart(args)
            if out is not None and args.command != "generate":
                clean_stale_partials(out)
                check_output_dir(out, overwrite=args.overwrite)
                pending = FailedRunCleanup(out, name)
                # one writer at a time; a pipeline's stages run in this process and write
                # folders of their own inside it
                held.enter_context(hold_output_dir(out, name))
                held.push(finish_failed)
                cleanup = pending
                # marked from the start: a run killed before its outputs (caches written
                # meanwhile) leaves a directory its rerun accepts
                claim_output_dir(out, overwrite=args.overwrite, command=name)
            return int(args.func(args) or 0)
    except (UserError, ValueError, FileNotFoundError, PermissionError) as exc:
        return fail("error", exc, 2)
    except (RunError, OSError) as exc:
        return fail("error", exc, 1)
    except KeyboardInterrupt as exc:
        _close_progress_bars()
        msg = str(exc) or kept or "nothing was written"
        print(f"viewadapt {name}: interrupted; {msg}", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
