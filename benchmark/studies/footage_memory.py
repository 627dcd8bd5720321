"""Memory of ``viewadapt detect`` over a long clip: does it stay flat?

    python -m benchmark.studies.footage_memory --data DIR [--minutes 10] [--out DIR]

The bar: a 10-minute 384x288 clip runs in flat memory (frames streamed, never all
held). This writes a clip of ``--minutes`` at 25 frames per second from the dataset's
frames (resized to 384x288 and repeated in order, as :mod:`benchmark.studies.footage_speed`), runs
``viewadapt detect`` on it in a child process with the shipped HOG model and an annotated
video, and samples the child's resident memory (``VmRSS`` of ``/proc/PID/status``) every
half second. The report gives the resident memory at each tenth of the run and the growth
from the first tenth to the end; nothing here asserts a size.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmark.studies.footage_speed import (
    SIZE, clip_frames, write_calibration, write_clip, write_study,
)
from benchmark.studies import report_error

__all__ = ["FPS", "rss_mb", "run_memory_benchmark", "format_memory", "main"]

#: frame rate of the written clip
FPS = 25.0


def rss_mb(pid: int) -> float | None:
    """Resident memory of process ``pid`` in MB (``VmRSS``), or None once it has ended."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except (FileNotFoundError, ProcessLookupError):
        return None
    return None


def run_memory_benchmark(data, *, minutes: float = 10.0, workdir=None,
                         interval: float = 0.5) -> dict:
    """Write the clip, run ``viewadapt detect`` on it and sample its memory.

    Returns a dict with the clip's frame count, the samples ``(seconds, MB)``, the command's
    metadata (frames, frames per second) and its exit code.
    """
    from benchmark.frames.runtime import timing_camera

    n_frames = max(2, int(round(minutes * 60 * FPS)))
    work = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix="viewadapt-memory-"))
    work.mkdir(parents=True, exist_ok=True)
    clip = write_clip(work / "clip.mp4", clip_frames(data, n_frames), fps=FPS)
    cal = write_calibration(work / "clip.json", timing_camera(SIZE))
    out = work / "out"
    cmd = [sys.executable, "-c", "import sys; from viewadapt.cli import main; "
           "sys.exit(main(sys.argv[1:]))", "detect", "--calibration", str(cal),
           "--cache", str(work / "cache"), "--annotate", "video", "--quiet",
           "--out", str(out), str(clip)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    samples = []
    while proc.poll() is None:
        mb = rss_mb(proc.pid)
        if mb is not None:
            samples.append((time.perf_counter() - t0, mb))
        time.sleep(interval)
    stdout, stderr = proc.communicate()
    meta = json.loads((out / "metadata.json").read_text()) if proc.returncode == 0 else {}
    return {"frames": n_frames, "minutes": n_frames / FPS / 60, "frame_size": list(SIZE),
            "returncode": proc.returncode, "samples": samples,
            "detect_frames": meta.get("frames"), "frames_per_second":
            meta.get("frames_per_second"), "seconds": round(time.perf_counter() - t0, 1),
            "stderr_tail": stderr.decode(errors="replace")[-500:] if proc.returncode else ""}


def format_memory(result) -> str:
    """``memory.md``: resident memory at each tenth of the run and its growth."""
    s = np.array(result["samples"], float).reshape(-1, 2)
    lines = [f"`viewadapt detect` on a {result['minutes']:.1f}-minute {result['frame_size'][0]}x"
             f"{result['frame_size'][1]} clip ({result['frames']} frames at {FPS:g} fps; "
             f"annotated video written), resident memory of the process sampled every "
             f"0.5 s; {result['seconds']} s in all, detection at "
             f"{result['frames_per_second']} frames/s.", ""]
    if result["returncode"] != 0 or len(s) < 2:
        return "\n".join(lines + [f"The command failed (exit {result['returncode']}) or ran "
                                  "too briefly to sample."]) + "\n"
    lines += ["| share of the run | MB |", "|---|---|"]
    T = s[-1, 0]
    for q in np.arange(1, 11) / 10:
        k = min(int(np.searchsorted(s[:, 0], q * T)), len(s) - 1)
        lines.append(f"| {q:.0%} | {s[k, 1]:.0f} |")
    tenth = s[s[:, 0] <= 0.1 * T, 1].max()
    rest = s[s[:, 0] >= 0.1 * T, 1]
    lines += ["", f"Peak {s[:, 1].max():.0f} MB. From the first tenth of the run (peak "
              f"{tenth:.0f} MB) to the end: peak {rest.max():.0f} MB, last sample "
              f"{rest[-1]:.0f} MB (growth {rest.max() - tenth:+.0f} MB)."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    from viewadapt.io.files import check_output_dir

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.footage_memory",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="dataset directory with frames")
    ap.add_argument("--minutes", type=float, default=10.0,
                    help="length of the clip, minutes at 25 fps (default 10)")
    ap.add_argument("--out", type=Path, default=None,
                    help="write memory.md and memory.json here (default: print only)")
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args(argv)
    try:
        if not np.isfinite(args.minutes) or args.minutes <= 0:
            raise ValueError(f"--minutes must be positive, got {args.minutes}")
        if args.out is not None:
            check_output_dir(args.out, overwrite=args.overwrite)
        result = run_memory_benchmark(args.data, minutes=args.minutes)
    except (ValueError, FileNotFoundError) as exc:
        return report_error(ap, exc)
    write_study(args.out, "memory", format_memory(result), args.data, result)
    return 0 if result["returncode"] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
