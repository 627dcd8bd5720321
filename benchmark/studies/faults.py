"""Fault injection: kill ``generate`` and ``bench crossval`` at random points, rerun, compare.

``python -m benchmark.studies.faults --preset tiny`` (not part of the test suite; ~30-60 min on two
cores with Cycles):

1. renders the preset once, uninterrupted (the reference), and runs ``bench crossval
   --quick`` on it once;
2. ``--generate-kills`` times (default 10): starts ``generate`` into a fresh directory,
   kills it and all its workers with SIGKILL at a random moment of the reference's
   duration, reruns it to completion, and compares every file's sha256 with the
   reference's (hidden files included: ``.parts/``, the marker; nothing is excluded);
3. ``--crossval-kills`` times (default 5): the same for ``bench crossval --quick``, into a
   fresh results directory (``run.json`` is left out of the comparison: it records the
   time and the seconds taken; ``SOURCE_DATE_EPOCH`` fixes the PDFs' creation dates);
4. concurrent writers: ``generate`` and ``bench crossval`` each started twice into one
   fresh folder, the second run ``--concurrent-delay`` s (default 1) after the first; the
   second must be refused in one line naming the first (exit 2), the first must finish
   with the reference's bytes;
5. overlapping folders: ``bench crossval`` with ``--out`` the dataset, inside it, or
   holding it, ``dataset preview`` into the dataset, and ``generate`` into a folder
   ``bench crossval`` wrote; each must be refused in one line (exit 2) and leave every
   folder as it was, and the dataset must still pass ``dataset verify --hash``;
6. malformed inputs: ``detect`` given a calibration with a misspelled key, a YAML alias
   bomb (a few hundred bytes that expand to billions of strings), an OpenCV FileStorage
   file nested 100,000 levels deep (``cv2.FileStorage`` crashes on it) or one over 1 MB,
   and ``detect`` and ``calibrate`` given a broken symbolic link as ``--out``; each must be
   refused in one line (exit 2) within :data:`MALFORMED_SECONDS`, writing nothing;
7. measures the peak memory of a ``--large`` image render against a ``--small`` one
   (the largest resident set of the ``generate`` process and its workers, ru_maxrss of
   the children, and the peak of their summed RSS sampled every 0.2 s), with
   ``--memory-renderer`` (pyrender by default: 2,000 Cycles images take ~25 min here).

It prints how many reruns ended byte-identical to the reference (target: all), how many
left stray files -- files the reference does not have, or anything but the output
folder beside it, such as a ``.partial-*`` folder (target: none) --, how many concurrent,
overlapping and malformed-input cases were refused as they should be (target: all), and
the two peaks (target: within 10 %).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from viewadapt.geometry import camera_from_pose
from viewadapt.io.files import LOCK

__all__ = ["main", "tree_hashes", "render_size", "compare", "concurrent_writers",
           "overlapping_folders", "malformed_inputs", "refused_in_one_line"]

REPO = Path(__file__).resolve().parent.parent
#: results files whose bytes record the time they were made (left out of the comparison)
TIMED_RESULTS = ("run.json",)
#: the cross-validation the faults run (small enough to be killed and rerun five times)
CROSSVAL_ARGS = ["--quick", "--detectors", "hog", "acf", "--sources", "0",
                 "--object-models", "plane", "--no-upper-bound"]
#: the longest a malformed input may take to be refused (seconds, the process start included)
MALFORMED_SECONDS = 30.0


def tree_hashes(root: Path, exclude=()) -> dict:
    """sha256 of every file under ``root`` (hidden ones included) by relative path."""
    out = {}
    for p in sorted(Path(root).rglob("*")):
        rel = p.relative_to(root).as_posix()
        if p.is_file() and rel not in exclude:
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def compare(ref: dict, got: dict, parent: Path, name: str) -> tuple[bool, list]:
    """(identical, stray): stray = files the reference lacks and entries beside the
    output folder in its (otherwise empty) parent."""
    stray = sorted(set(got) - set(ref))
    stray += [f"../{p.name}" for p in parent.iterdir() if p.name != name]
    same = set(ref) == set(got) and all(ref[k] == got[k] for k in ref)
    return same, stray


def _env() -> dict:
    return dict(os.environ, SOURCE_DATE_EPOCH="0", PYTHONHASHSEED="0")


def _cli(args) -> list:
    return [sys.executable, "-m", "viewadapt.cli", *args]


def _run(args, log: Path) -> float:
    t0 = time.perf_counter()
    with open(log, "ab") as fh:
        rc = subprocess.run(_cli(args), cwd=REPO, env=_env(), stdout=fh, stderr=fh).returncode
    if rc != 0:
        raise SystemExit(f"faults: `viewadapt {' '.join(args)}` failed (rc {rc}); see {log}")
    return time.perf_counter() - t0


def _run_killed(args, delay: float, log: Path) -> str:
    """Start the command, SIGKILL its whole process group after ``delay`` seconds."""
    with open(log, "ab") as fh:
        p = subprocess.Popen(_cli(args), cwd=REPO, env=_env(), stdout=fh, stderr=fh,
                             start_new_session=True)
        try:
            p.wait(timeout=delay)
            return f"finished before the kill (rc {p.returncode})"
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
            return f"killed at {delay:.1f} s"


def refused_in_one_line(rc: int, err: str, want: str) -> bool:
    """A command refused as it should be: exit 2, one line of stderr (no traceback) that
    starts ``viewadapt`` and says ``want``."""
    lines = [ln for ln in err.splitlines() if ln.strip() and "Warp CUDA warning" not in ln]
    return (rc == 2 and len(lines) == 1 and lines[0].startswith("viewadapt ")
            and want in lines[0] and "Traceback" not in err)


def concurrent_writers(args: list, out: Path, ref_tree: dict, log: Path, delay: float,
                       exclude=()) -> dict:
    """Start ``viewadapt ARGS --out OUT`` twice, the second ``delay`` s after the first has
    taken the folder's lock: the second must be refused naming the first (``is in use
    by``, its pid), the first must finish and leave ``ref_tree``'s bytes (``exclude``
    aside)."""
    argv = args + ["--out", str(out)]
    name = " ".join(args[:2]) if args[0] in ("bench", "dataset") else args[0]
    with open(log, "ab") as fh:
        first = subprocess.Popen(_cli(argv), cwd=REPO, env=_env(), stdout=fh, stderr=fh)
        deadline = time.time() + 120
        while first.poll() is None and not (out / LOCK).is_file() and time.time() < deadline:
            time.sleep(0.02)
        time.sleep(delay)
        running = first.poll() is None
        second = subprocess.run(_cli(argv), cwd=REPO, env=_env(), capture_output=True,
                                text=True)
        rc_first = first.wait()
    refused = refused_in_one_line(second.returncode, second.stderr,
                                  f"is in use by viewadapt {name}")
    named = f"(pid {first.pid}," in second.stderr
    got = tree_hashes(out, exclude) if out.is_dir() else {}
    diff = sorted(f for f in set(ref_tree) | set(got) if ref_tree.get(f) != got.get(f))
    ok = running and refused and named and rc_first == 0 and not diff
    return {"command": name, "first_running": running,
            "second_rc": second.returncode, "second_stderr": second.stderr.strip()[-400:],
            "first_rc": rc_first, "differ": diff, "ok": ok}


def overlapping_folders(data: Path, work: Path, gen: list, log: Path) -> list:
    """Commands whose output folder overlaps an input, or was written by another command:
    each must be refused in one line (exit 2) and change nothing (``data`` and every other
    folder involved keep their files)."""
    outer = work / "outer"
    shutil.copytree(data, outer / "data")
    results = work / "crossval_folder"
    _run(["bench", "crossval", "--data", str(data), "--out", str(results)] + CROSSVAL_ARGS,
         log)
    cv = ["bench", "crossval"] + CROSSVAL_ARGS
    cases = [
        ("crossval --out = --data", cv + ["--data", str(data), "--out", str(data)],
         "is the --data folder"),
        ("crossval --out inside --data", cv + ["--data", str(data), "--out",
                                               str(data / "results")], "lies inside --data"),
        ("crossval --data inside --out", cv + ["--data", str(outer / "data"), "--out",
                                               str(outer)], "lies inside --out"),
        ("crossval --cache inside --data", cv + ["--data", str(data), "--out",
                                                 str(work / "never"), "--cache",
                                                 str(data / "cache")], "lies inside --data"),
        ("preview into the dataset", ["dataset", "preview", str(data), "--out",
                                      str(data / "sheet.png")], "lies inside DIRECTORY"),
        ("generate into a crossval folder", gen + ["--out", str(results)],
         "written by viewadapt bench crossval"),
    ]
    watched = (data, outer, results)
    rows = []
    for name, argv, want in cases:
        before = [tree_hashes(d) for d in watched]
        with open(log, "ab") as fh:
            fh.write(f"\n$ viewadapt {' '.join(argv)}\n".encode())
        p = subprocess.run(_cli(argv), cwd=REPO, env=_env(), capture_output=True, text=True)
        unchanged = [tree_hashes(d) for d in watched] == before
        refused = refused_in_one_line(p.returncode, p.stderr, want)
        rows.append({"case": name, "rc": p.returncode, "stderr": p.stderr.strip()[-400:],
                     "unchanged": unchanged and not (work / "never").exists(),
                     "ok": refused and unchanged and not (work / "never").exists()})
    v = subprocess.run(_cli(["dataset", "verify", str(data), "--hash"]), cwd=REPO, env=_env(),
                       capture_output=True, text=True)
    rows.append({"case": "dataset verify --hash afterwards", "rc": v.returncode,
                 "stderr": v.stdout.strip()[-400:], "unchanged": True, "ok": v.returncode == 0})
    return rows


def _malformed_files(d: Path) -> dict:
    """The inputs of :func:`malformed_inputs`, written into ``d``."""
    import cv2

    pose = "image_size: [384, 288]\nfocal: 350\nheight: 4.5\ntilt: 35\n"
    bomb = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    bomb += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, 9)]
    head = ("%YAML:1.0\n---\nimage_width: 384\nimage_height: 288\ncamera_matrix: "
            "!!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 350., 0., 191.5, "
            "0., 350., 143.5, 0., 0., 1. ]\nrvec: [1.9, 0.0, 0.0]\ntvec: [0.0, 2.6, 3.7]\n")
    texts = {"misspelled.yaml": pose + "rol: 2\n",
             "bomb.yaml": "\n".join(bomb) + "\n" + pose.replace("[384, 288]", "*a8"),
             "deep.yml": head + "deep: " + "[" * 100_000 + "]" * 100_000 + "\n",
             "large.yml": head + "# " + "x" * 2 ** 21 + "\n"}
    for name, text in texts.items():
        (d / name).write_text(text)
    cv2.imwrite(str(d / "frame.png"), np.zeros((288, 384, 3), np.uint8))
    cam = camera_from_pose(focal=350.0, principal_point=(191.5, 143.5), height=4.5,
                           tilt=np.radians(35), image_size=(384, 288))
    uv = np.array([(u, v) for v in (120.0, 270.0) for u in (40.0, 190.0, 340.0)])
    rays = (np.c_[uv, np.ones(len(uv))] @ np.linalg.inv(cam.K).T) @ cam.R
    XY = (cam.center + (-cam.center[2] / rays[:, 2])[:, None] * rays)[:, :2]
    (d / "points.csv").write_text("u,v,X,Y\n" + "".join(
        f"{a!r},{b!r},{x!r},{y!r}\n" for (a, b), (x, y) in zip(uv, XY)))
    for link in ("out_link", "cam_link.yaml"):
        os.symlink(d / f"missing_{link}", d / link)
    return {n: d / n for n in (*texts, "frame.png", "points.csv", "out_link", "cam_link.yaml")}


def malformed_inputs(work: Path, log: Path) -> list:
    """Inputs a user can get wrong: each must be refused in one line (exit 2) within
    :data:`MALFORMED_SECONDS`, leave no output (a broken ``--out`` link stays a link to
    nothing)."""
    work.mkdir(parents=True, exist_ok=True)
    f = _malformed_files(work)
    never = work / "never"

    def detect(calibration, out=never):
        return ["detect", "--calibration", str(calibration), "--out", str(out),
                str(f["frame.png"])]

    cases = [
        ("calibration with a misspelled key", detect(f["misspelled.yaml"]),
         "unknown key 'rol' (did you mean 'roll'?)"),
        ("calibration: a YAML alias bomb", detect(f["bomb.yaml"]), "YAML anchors and aliases"),
        ("OpenCV FileStorage nested 100,000 levels", detect(f["deep.yml"]),
         "nested more than the 16 levels"),
        ("OpenCV FileStorage over 1 MB", detect(f["large.yml"]), "is over the 1 MB"),
        ("detect --out a broken symbolic link", detect(f["misspelled.yaml"], f["out_link"]),
         "is a broken symbolic link"),
        ("calibrate --out a broken symbolic link",
         ["calibrate", str(f["points.csv"]), "--image-size", "384,288", "--out",
          str(f["cam_link.yaml"])], "is a broken symbolic link"),
    ]
    rows = []
    for name, argv, want in cases:
        with open(log, "ab") as fh:
            fh.write(f"\n$ viewadapt {' '.join(argv)}\n".encode())
        t0 = time.perf_counter()
        p = subprocess.run(_cli(argv), cwd=REPO, env=_env(), capture_output=True, text=True,
                           timeout=600)
        seconds = time.perf_counter() - t0
        untouched = (not never.exists() and all(
            f[k].is_symlink() and not f[k].exists() for k in ("out_link", "cam_link.yaml")))
        refused = refused_in_one_line(p.returncode, p.stderr, want)
        rows.append({"case": name, "rc": p.returncode, "stderr": p.stderr.strip()[-400:],
                     "seconds": round(seconds, 2), "unchanged": untouched,
                     "ok": refused and untouched and seconds <= MALFORMED_SECONDS})
    return rows


def render_size(persons: int, scenes: int, instances: int = 1, elevations: int = 3,
                backgrounds: int = 1, frames: int = 1) -> int:
    """Images a ``generate --persons --scenes --instances`` run of the tiny preset plans."""
    return scenes * (persons * instances * elevations + backgrounds * elevations) + frames


def _tree_rss_kb(pid: int) -> int:
    """Summed RSS (kB) of ``pid`` and its descendants (Linux /proc)."""
    total, todo = 0, [pid]
    while todo:
        q = todo.pop()
        try:
            for line in Path(f"/proc/{q}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
            for t in Path(f"/proc/{q}/task").iterdir():
                todo += [int(c) for c in (t / "children").read_text().split()]
        except (OSError, ValueError):
            continue
    return total


_MAXRSS = ("import resource, subprocess, sys; "
           "rc = subprocess.run(sys.argv[1:], stdout=sys.stderr).returncode; "
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, rc)")


def measure_memory(args, log: Path) -> dict:
    """Peak memory of one ``generate`` run: the largest process (ru_maxrss of the
    children, via a fresh intermediate process) and the sampled peak of the tree's sum."""
    t0 = time.perf_counter()
    with open(log, "ab") as fh:
        p = subprocess.Popen([sys.executable, "-c", _MAXRSS, *_cli(args)], cwd=REPO,
                             env=_env(), stdout=subprocess.PIPE, stderr=fh, text=True)
        peak = 0
        while p.poll() is None:
            peak = max(peak, _tree_rss_kb(p.pid))
            time.sleep(0.2)
        out = p.stdout.read().split()[-2:]
    maxrss, rc = int(out[0]), int(out[1])
    if rc != 0:
        raise SystemExit(f"faults: `viewadapt {' '.join(args)}` failed (rc {rc}); see {log}")
    return {"max_process_mb": maxrss / 1024, "tree_peak_mb": peak / 1024,
            "seconds": time.perf_counter() - t0}


def _sizes(n: int, scenes: int) -> int:
    """Persons giving about ``n`` images over ``scenes`` scenes (tiny preset layout)."""
    return max(1, round((n - 1) / scenes / 3 - 1))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.faults", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="tiny", choices=("tiny", "demo", "small"))
    ap.add_argument("--renderer", default="cycles", choices=("cycles", "pyrender"))
    ap.add_argument("--work", type=Path, default=Path("faults-work"),
                    help="scratch directory (removed first; default ./faults-work)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the kill moments")
    ap.add_argument("--generate-kills", type=int, default=10)
    ap.add_argument("--crossval-kills", type=int, default=5)
    ap.add_argument("--small", type=int, default=200, help="images of the small render")
    ap.add_argument("--large", type=int, default=2000, help="images of the large render")
    ap.add_argument("--memory-scenes", type=int, default=10)
    ap.add_argument("--memory-renderer", default="pyrender", choices=("cycles", "pyrender"))
    ap.add_argument("--concurrent-delay", type=float, default=1.0,
                    help="seconds between the two concurrent writers (default 1)")
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument("--only-memory", action="store_true",
                    help="skip the kills: only the memory measurement")
    a = ap.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    work = a.work.resolve()
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    log = work / "faults.log"
    gen = ["generate", "--preset", a.preset, "--renderer", a.renderer, "--quiet"]
    report = {"preset": a.preset, "renderer": a.renderer}

    g = c = None
    if not a.only_memory:
        ref = work / "ref" / "ds"
        ref.parent.mkdir()
        t_gen = _run(gen + ["--out", str(ref)], log)
        ref_hashes = tree_hashes(ref)
        print(f"reference render: {len(ref_hashes)} files in {t_gen:.0f} s", flush=True)

        def trials(kind, n, duration, make_args, ref_tree, exclude=()):
            same_n, stray_n, results_n, rows = 0, 0, 0, []
            for k in range(n):
                parent = work / f"{kind}{k}"
                parent.mkdir()
                out = parent / "res"
                delay = float(rng.uniform(0.05, 0.9) * duration)
                what = _run_killed(make_args(out), delay, log)
                _run(make_args(out), log)
                got = tree_hashes(out, exclude)
                same, stray = compare(ref_tree, got, parent, out.name)
                diff = sorted(f for f in set(ref_tree) | set(got) if ref_tree.get(f) != got.get(f))
                # results alone: every file outside the feature cache
                same_results = not [f for f in diff if not f.startswith("cache/")]
                same_n += same
                results_n += same_results
                stray_n += bool(stray)
                rows.append({"trial": k, "kill": what, "identical": same,
                             "results_identical": same_results, "stray": stray, "differ": diff})
                print(f"  {kind} {k}: {what}; rerun {'byte-identical' if same else 'DIFFERS'}"
                      + ("" if same or not same_results else " (in cache/ only)")
                      + (f"; stray: {stray[:5]}" if stray else ""), flush=True)
                if not same:
                    print(f"    differing files ({len(diff)}): {diff[:8]}", flush=True)
            return same_n, stray_n, rows, results_n

        print(f"generate: {a.generate_kills} runs killed (SIGKILL) at random moments, rerun",
              flush=True)
        g = trials("generate", a.generate_kills, t_gen,
                   lambda out: gen + ["--out", str(out)], ref_hashes)
        report["generate"] = dict(zip(("identical", "with_stray_files", "trials"), g))
        print(f"== generate: {g[0]}/{a.generate_kills} reruns byte-identical to the "
              f"uninterrupted render; {g[1]} left stray files", flush=True)

        res_ref = work / "ref" / "res"
        cv = lambda out, data=ref: ["bench", "crossval", "--data", str(data),  # noqa: E731
                                    "--out", str(out)] + CROSSVAL_ARGS
        t_cv = _run(cv(res_ref), log)
        cv_hashes = tree_hashes(res_ref, TIMED_RESULTS)
        print(f"reference crossval: {len(cv_hashes)} files in {t_cv:.0f} s", flush=True)
        print(f"bench crossval: {a.crossval_kills} runs killed at random moments, rerun "
              f"(excluded from the comparison: {', '.join(TIMED_RESULTS)})", flush=True)
        c = trials("crossval", a.crossval_kills, t_cv, cv, cv_hashes, TIMED_RESULTS)
        report["crossval"] = dict(zip(("identical", "with_stray_files", "trials",
                                       "results_identical"), c))
        print(f"\n== generate: {g[0]}/{a.generate_kills} reruns byte-identical to the "
              f"uninterrupted render; {g[1]} left stray files", flush=True)
        print(f"== bench crossval: {c[0]}/{a.crossval_kills} reruns byte-identical (all files but "
              f"{', '.join(TIMED_RESULTS)}), {c[3]}/{a.crossval_kills} with identical results "
              f"(the feature cache aside); {c[1]} left stray files", flush=True)
        (work / "faults.json").write_text(json.dumps(report, indent=1, default=str))

        print(f"concurrent writers: each command started twice into one folder, "
              f"{a.concurrent_delay:g} s apart", flush=True)
        conc = [concurrent_writers(gen, work / "concurrent_generate" / "ds", ref_hashes, log,
                                   a.concurrent_delay),
                concurrent_writers(["bench", "crossval", "--data", str(ref)] + CROSSVAL_ARGS,
                                   work / "concurrent_crossval" / "res", cv_hashes, log,
                                   a.concurrent_delay, TIMED_RESULTS)]
        for r in conc:
            state = "still running" if r["first_running"] else "ALREADY DONE"
            verdict = "ok" if r["ok"] else "NOT OK"
            same = "byte-identical" if not r["differ"] else f"DIFFERS: {r['differ'][:5]}"
            print(f"  {r['command']}: {verdict}; the first run was {state} when the second "
                  f"started; second rc {r['second_rc']}, first rc {r['first_rc']}, {same}",
                  flush=True)
        report["concurrent"] = conc
        over = overlapping_folders(ref, work / "overlap", gen, log)
        for r in over:
            print(f"  {r['case']}: {'ok' if r['ok'] else 'NOT OK'} (rc {r['rc']}"
                  f"{'' if r['unchanged'] else ', FOLDERS CHANGED'})", flush=True)
        report["overlapping"] = over
        bad = malformed_inputs(work / "malformed", log)
        for r in bad:
            print(f"  {r['case']}: {'ok' if r['ok'] else 'NOT OK'} (rc {r['rc']}, "
                  f"{r['seconds']:.1f} s{'' if r['unchanged'] else ', FILES CHANGED'})",
                  flush=True)
        report["malformed"] = bad
        safe = sum(r["ok"] for r in conc + over + bad)
        print(f"== concurrent writers, overlapping folders and malformed inputs: {safe}/"
              f"{len(conc) + len(over) + len(bad)} cases refused in one line with nothing "
              "changed", flush=True)
        (work / "faults.json").write_text(json.dumps(report, indent=1, default=str))
    if not a.skip_memory:
        s = a.memory_scenes
        mem = {}
        for label, n in (("small", a.small), ("large", a.large)):
            p = _sizes(n, s)
            images = render_size(p, s)
            out = work / f"memory_{label}"
            m = measure_memory(["generate", "--preset", "tiny", "--renderer",
                                a.memory_renderer, "--persons", str(p), "--scenes", str(s),
                                "--quiet", "--out", str(out)], log)
            mem[label] = dict(m, images=images, persons=p, scenes=s)
            print(f"== memory, {images} images ({p} persons x {s} scenes, "
                  f"{a.memory_renderer}): largest process {m['max_process_mb']:.0f} MB, "
                  f"peak of the process tree {m['tree_peak_mb']:.0f} MB "
                  f"({m['seconds']:.0f} s)", flush=True)
            shutil.rmtree(out, ignore_errors=True)
        for key in ("max_process_mb", "tree_peak_mb"):
            r = mem["large"][key] / mem["small"][key]
            within = "within" if abs(r - 1) <= 0.10 else "NOT within"
            print(f"   {key}: large / small = {r:.3f} ({within} 10 %)", flush=True)
        report["memory"] = mem
    (work / "faults.json").write_text(json.dumps(report, indent=1, default=str))
    ok = g is None or (g[0] == a.generate_kills and c[0] == a.crossval_kills
                       and not g[1] and not c[1]
                       and all(r["ok"] for key in ("concurrent", "overlapping", "malformed")
                               for r in report[key]))
    return 0 if ok else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
