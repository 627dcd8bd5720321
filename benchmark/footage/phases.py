"""``bench footage --phases N``: every method at N x N phases of its window grid.

Where the grid of windows falls is arbitrary, yet a clip's LAMR moves with it: a window a
fraction of a stride to the side can be the one a person's strongest score lands on. The
methods that score the candidate windows (adapted detectors and image warping,
:attr:`~benchmark.frames.spec.FrameMethod.on_window_grid`) run with their ground grid at the
``N x N`` phases of :func:`benchmark.frames.phases.grid_phases`; the pyramids, which slide
their own windows over the frame, run on the frame moved by the ``N x N`` whole-pixel shifts
of :func:`benchmark.frames.phases.frame_shifts` -- the default grid and the unshifted frame
first. Each method's LAMR is reported as the mean over its phases, and the paired
differences average over the phases with every phase of both sides on the same resampled
blocks of frames (:func:`viewadapt.detect.evaluation.paired_groups_bootstrap`).
"""

from __future__ import annotations

import numpy as np

from benchmark.footage.report import (
    best_unadapted, comparison_pairs, format_interval, target_items,
)
from benchmark.footage.run import run_footage
from benchmark.frames.phases import phase_columns
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap

__all__ = ["run_phases", "PhaseSummary", "phase_summary", "phase_lines"]


def run_phases(clip, methods, models, phases, shifts, *, progress=None, **kw) -> dict:
    """Detections of every method at each phase after the first (the default grid's and
    the unshifted frame's run is the caller's): the window-grid methods at ``phases[k]``,
    the pyramids on the frame moved by ``shifts[k]``.

    Parameters
    ----------
    clip : benchmark.footage.run.Clip
    methods : sequence of FrameMethod
    models : SourceDetectors or None
    phases : sequence of (float, float)
        :func:`benchmark.frames.phases.grid_phases`' output.
    shifts : sequence of (int, int)
        :func:`benchmark.frames.phases.frame_shifts`' output, as long as ``phases``.
    progress : callable or None
        Called once per frame of each phase's run.
    **kw
        :func:`~benchmark.footage.run.run_footage`'s other keywords (heights, cache, ...).

    Returns
    -------
    dict FrameMethod -> list (one per phase after the first) of per-frame (D, 5) arrays
    """
    if len(shifts) != len(phases):
        raise ValueError(f"{len(phases)} grid phases but {len(shifts)} frame shifts")
    out = {m: [] for m in methods}
    for ph, sh in list(zip(phases, shifts))[1:]:
        run = run_footage(clip, methods, models, grid_phase=ph, frame_shift=sh,
                          progress=progress, **kw)
        for m in methods:
            out[m].append(run.detections[m])
    return out


class PhaseSummary:
    """What :func:`phase_summary` found.

    Attributes
    ----------
    lamr : dict FrameMethod -> list of float
        Each method's LAMR at every phase, the default grid (unshifted frame) first.
    differences : list of (FrameMethod, FrameMethod, dict)
        ``(method, reference, result)`` of
        :func:`~viewadapt.detect.evaluation.paired_groups_bootstrap`: the mean over the
        phases of the method minus that of the reference.
    phases : list of (float, float)
        The window-grid methods' grid phases.
    shifts : list of (int, int)
        The pyramids' frame shifts, px.
    """

    def __init__(self, lamr, differences, phases, shifts):
        self.lamr, self.differences = lamr, differences
        self.phases, self.shifts = list(phases), list(shifts)

    def mean(self, m) -> float:
        return float(np.mean(self.lamr[m]))

    def rows(self) -> list:
        """One dict per method and phase (``phases.csv``): a window-grid method's grid phase
        (``phase_forward``, ``phase_left``, fractions of the stride) or a pyramid's frame
        shift (``shift_x``, ``shift_y``, px)."""
        return [dict(method=m.name, **phase_columns(m, ph, sh), lamr=v)
                for m, vs in self.lamr.items()
                for ph, sh, v in zip(self.phases, self.shifts, vs)]

    def json(self) -> dict:
        """``phases.json``: the phases and shifts, each method's LAMR at each, and the
        differences."""
        return dict(grid_phases=[list(p) for p in self.phases],
                    frame_shifts=[list(p) for p in self.shifts],
                    lamr={m.name: vs for m, vs in self.lamr.items()},
                    differences=[dict(method=m.name, reference=r.name, **d)
                                 for m, r, d in self.differences])


def phase_summary(run, phase_detections, evaluations, matches, image_size, phases, shifts, *,
                  regions=None, block: int = 10, seed: int = 0) -> PhaseSummary:
    """Every method's LAMR at every phase and the paired differences averaged over the
    phases: against the best unadapted baseline, each adapted detector against the best
    pyramid of the same detector (when that is another one) and against image warping of
    the same model.

    ``run``, ``evaluations``, ``matches``: the default grid's
    (:func:`~benchmark.footage.run.run_footage`,
    :func:`~benchmark.footage.report.evaluate_run`); ``phase_detections``:
    :func:`run_phases`' output.
    """
    per_phase = {}
    for m, dets in phase_detections.items():
        per_phase[m] = [matches[m]] + [
            evaluation_matches(d, run.truth, image_size, regions=regions)[0] for d in dets]
    lamr = {m: [matches_lamr(x) for x in ms] for m, ms in per_phase.items()}

    def group(m):
        return per_phase.get(m, [matches[m]])

    pairs = comparison_pairs(list(per_phase), evaluations)
    differences = [(m, r, paired_groups_bootstrap(group(m), group(r), block=block, seed=seed))
                   for m, r in pairs]
    return PhaseSummary(lamr, differences, phases, shifts)


def phase_lines(summary: PhaseSummary, evaluations, block_frames: int) -> list:
    """The report's markdown section on the grid phases, with the targets judged on the
    phase means (see :func:`~benchmark.footage.report.footage_targets`)."""
    n = len(summary.phases)
    ref = best_unadapted(evaluations)
    to_ref = {m: d for m, r, d in summary.differences if r == ref}
    shifts = sorted({s for xy in summary.shifts for s in xy})
    lines = ["", f"## Over {n} grid phases", "",
             "Every method with its window grid at "
             f"{n} phases, the default first: the methods that score the candidate windows "
             "with their ground grid at fractions of its stride, the pyramids on the frame "
             f"moved by {shifts[0]}-{shifts[-1]} whole pixels each way (a LAMR moves with "
             "where the grid falls). Mean over the phases; paired differences "
             "average over the phases, every phase of both sides on the same resampled "
             f"{block_frames}-frame blocks.", "",
             f"| method | LAMR, mean over {n} phases | sd | range | default grid | "
             f"- {ref.name if ref else 'best unadapted'} (paired 95%) |",
             "|---|---|---|---|---|---|"]
    for m, vs in summary.lamr.items():
        d = to_ref.get(m)
        diff = f"{d['difference']:+.3f} ({format_interval(d['ci'])})" if d else "-"
        sd = f"{np.std(vs, ddof=1):.3f}" if len(vs) > 1 else "-"
        lines.append(f"| {m.name} | {np.mean(vs):.3f} | {sd} | {min(vs):.3f}-{max(vs):.3f} | "
                     f"{vs[0]:.3f} | {diff} |")
    other = [(m, r, d) for m, r, d in summary.differences if r != ref]
    if other:
        lines += ["", "Adapted against its own detector's best pyramid and against image "
                      "warping of the same model, means over the phases:", ""]
        lines += [f"- {m.name} - {r.name}: {d['difference']:+.3f} "
                  f"(95% {format_interval(d['ci'])})" for m, r, d in other]
    means = {m: summary.mean(m) for m in summary.lamr}
    targets = target_items(evaluations, summary.differences, lamr=means, note=" (phase mean)")
    return lines + (["", "Targets on the phase means:", "", *targets] if targets else [])
