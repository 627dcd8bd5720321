"""The evaluation and report of ``viewadapt bench footage``.

Every method is evaluated as ``viewadapt detect --boxes`` evaluates (Caltech protocol,
LAMR over 1e-2..1e0 FPPI, miss rates at 0.1 and 1 FPPI, 95 % intervals from a circular
block bootstrap over consecutive frames:
:func:`viewadapt.detect.evaluation.evaluation_summary`), each method matched once.
Comparisons are paired: the LAMR difference of two methods on the same resampled blocks
(:func:`viewadapt.detect.evaluation.paired_matches_bootstrap`), against the best unadapted
baseline (the lowest-LAMR pyramid, ground-filtered or not) and, per detector, adapted
against image warping of the same model.
"""

from __future__ import annotations

import numpy as np

from benchmark.frames.report import WARP_MARGIN
from benchmark.frames.spec import FrameMethod
from viewadapt.detect import PRETRAINED_KINDS
from viewadapt.detect.evaluation import (
    evaluation_matches, matches_summary, paired_matches_bootstrap,
)

__all__ = ["evaluate_run", "paired_differences", "comparison_pairs", "best_unadapted",
           "footage_targets", "target_items", "summary_lines", "summary_rows",
           "format_interval"]


def evaluate_run(run, image_size, *, regions=None, block: int = 10,
                 seed: int = 0) -> tuple[dict, dict]:
    """``(evaluations, matches)`` of every method of a :class:`FootageRun`: {method:
    (evaluation, curve)} and {method: per-frame matches}, each method matched once
    (:func:`~viewadapt.detect.evaluation.evaluation_matches`)."""
    evaluations, matches = {}, {}
    for m, d in run.detections.items():
        matches[m], gts = evaluation_matches(d, run.truth, image_size, regions=regions)
        evaluations[m] = matches_summary(matches[m], gts, block=block, seed=seed)
    return evaluations, matches


def best_unadapted(evaluations):
    """The unadapted baseline (a pyramid, with or without the ground-plane filter) of
    lowest LAMR, or None."""
    base = [m for m in evaluations if m.how.startswith("pyramid")]
    return min(base, key=lambda m: evaluations[m][0]["lamr"]) if base else None


def paired_differences(run, evaluations, matches, *, block: int = 10, seed: int = 0) -> list:
    """``(method, reference, result)`` of
    :func:`~viewadapt.detect.evaluation.paired_matches_bootstrap` for every pair of
    :func:`comparison_pairs` among the run's methods. ``evaluations, matches``:
    :func:`evaluate_run`'s."""
    return [(m, r, paired_matches_bootstrap(matches[m], matches[r], block=block, seed=seed))
            for m, r in comparison_pairs(list(run.detections), evaluations)]


def comparison_pairs(methods, evaluations) -> list:
    """``(method, reference)`` pairs: each of ``methods`` against the best unadapted
    baseline of ``evaluations`` (:func:`best_unadapted`), each adapted detector against the
    best unadapted pyramid of the same detector (when that is another one) and against
    image warping of the same model (when that is among ``methods``)."""
    pairs = []
    ref = best_unadapted(evaluations)
    if ref is not None:
        pairs += [(m, ref) for m in methods if m != ref]
    for m in methods:
        if m.how != "adapted":
            continue
        own = best_unadapted({k: v for k, v in evaluations.items() if k.kind == m.kind})
        if own is not None and own != ref:
            pairs.append((m, own))
        warp = FrameMethod(m.kind, "warp")
        if warp in methods:
            pairs.append((m, warp))
    return pairs


def _fps(run, m) -> float:
    return run.n_frames / run.seconds[m] if run.seconds[m] > 0 else float("inf")


def footage_targets(run, evaluations, differences) -> list:
    """Markdown lines judging the real-footage targets on this run: adapted OpenCV (and
    adapted Daimler) below the same detector's best ``detectMultiScale`` with the
    ground-plane filter at no fewer frames per second than it at 2x; each adapted detector
    within :data:`WARP_MARGIN` of image warping, its interval's upper end included."""
    out = target_items(evaluations, differences, run=run)
    return ["", "## Targets", "", *out] if out else []


def target_items(evaluations, differences, *, run=None, lamr=None, note: str = "") -> list:
    """The bullets of :func:`footage_targets`; ``lamr``: {method: LAMR} replacing the
    evaluations' for those methods, the baselines' too (e.g. means over grid phases,
    ``note`` saying so);
    ``run``: with it, the frames-per-second targets too."""
    lamr = lamr or {}

    def value(m):
        return lamr.get(m, evaluations[m][0]["lamr"])

    out = []
    for kind in PRETRAINED_KINDS:          # OpenCV's INRIA detector, then its Daimler one
        ad = FrameMethod(kind, "adapted")
        grounded = [m for m in evaluations if m.kind == kind and m.how == "pyramid"
                    and m.ground]
        if ad not in evaluations or not grounded:
            continue
        best = min(grounded, key=value)
        a, b = value(ad), value(best)
        out.append(f"- {ad.name} LAMR {a:.3f}{note} below {best.name}'s {b:.3f}: "
                   f"{'met' if a < b else 'NOT met'}")
        two = FrameMethod(kind, "pyramid", upsample=2)
        if run is not None and two in run.seconds:
            fa, fb = _fps(run, ad), _fps(run, two)
            out.append(f"- {ad.name} at {fa:.1f} frames/s, no fewer than {two.name}'s "
                       f"{fb:.1f}: {'met' if fa >= fb else 'NOT met'}")
    for m, r, d in differences:
        if r.how == "warp" and m.how == "adapted":
            hi = d["ci"][1]
            ok = hi is not None and hi <= WARP_MARGIN
            out.append(f"- {m.name} - {r.name} = {d['difference']:+.3f} LAMR{note} (95% "
                       f"{format_interval(d['ci'])}), upper end within +{WARP_MARGIN:g}: "
                       f"{'met' if ok else 'NOT met'}")
    return out


def format_interval(ci) -> str:
    """A paired interval as ``-0.012..+0.034`` (``-`` without one)."""
    lo, hi = ci
    return "-" if lo is None else f"{lo:+.3f}..{hi:+.3f}"


def summary_rows(run, evaluations, differences) -> list:
    """One dict per method: the table's numbers (for the csv)."""
    best = best_unadapted(evaluations)
    ref = {m: d for m, r, d in differences if r == best}
    refname = best.name if ref else ""
    out = []
    for m, (ev, _) in evaluations.items():
        d = ref.get(m)
        out.append(dict(method=m.name, lamr=ev["lamr"], lamr_ci_low=ev["lamr_ci95"][0],
                        lamr_ci_high=ev["lamr_ci95"][1],
                        miss_rate_at_0_1_fppi=ev["miss_rate_at_0.1_fppi"],
                        miss_rate_at_1_fppi=ev["miss_rate_at_1_fppi"],
                        reference=refname if d else "",
                        difference=d["difference"] if d else np.nan,
                        difference_ci_low=d["ci"][0] if d else np.nan,
                        difference_ci_high=d["ci"][1] if d else np.nan,
                        frames_per_second=_fps(run, m),
                        prepare_seconds=run.prepare_seconds[m], n_frames=run.n_frames,
                        n_gt=ev["n_gt"], n_gt_ignored=ev["n_gt_ignored"]))
    return out


def summary_lines(run, evaluations, differences) -> list:
    """The markdown report: the table, the adapted-vs-warping lines and the targets."""
    rows = summary_rows(run, evaluations, differences)
    ref = next((r["reference"] for r in rows if r["reference"]), None)
    lines = [f"| method | LAMR (95% interval) | MR @ 0.1 FPPI | MR @ 1 FPPI | "
             f"- {ref or 'best unadapted'} (paired 95%) | frames/s |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lo, hi = r["lamr_ci_low"], r["lamr_ci_high"]
        ci = "" if lo is None else f" ({lo:.3f}..{hi:.3f})"
        dci = (r["difference_ci_low"], r["difference_ci_high"])
        diff = f"{r['difference']:+.3f} ({format_interval(dci)})" if r["reference"] else "-"
        lines.append(f"| {r['method']} | {r['lamr']:.3f}{ci} | "
                     f"{r['miss_rate_at_0_1_fppi']:.3f} | {r['miss_rate_at_1_fppi']:.3f} | "
                     f"{diff} | {r['frames_per_second']:.2f} |")
    best = best_unadapted(evaluations)
    own = [(m, r, d) for m, r, d in differences
           if m.how == "adapted" and r.how.startswith("pyramid") and r != best]
    if own:
        lines += ["", "Adapted against the best unadapted pyramid of the same detector "
                      "(paired block bootstrap):", ""]
        lines += [f"- {m.name} - {r.name}: {d['difference']:+.3f} "
                  f"(95% {format_interval(d['ci'])})" for m, r, d in own]
    warp = [(m, r, d) for m, r, d in differences if r.how == "warp"]
    if warp:
        lines += ["", "Adapted against image warping of the same model (paired block "
                      "bootstrap):", ""]
        lines += [f"- {m.name} - {r.name}: {d['difference']:+.3f} "
                  f"(95% {format_interval(d['ci'])})" for m, r, d in warp]
    return lines + footage_targets(run, evaluations, differences)
