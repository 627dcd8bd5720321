"""The report of a ``bench frames`` run: the summary table, the accuracy targets, the
adapted - warping gap over grid phases (``--phases``), and the tables and figure of a
study over training seeds (``--seeds``).

Results are keyed by :class:`benchmark.frames.spec.FrameMethod`; the tables and figures
write each method's name."""

from __future__ import annotations

import numpy as np

from viewadapt.detect import DETECTOR_KINDS
from viewadapt.io import FAMILY_COLORS

from benchmark.frames.phases import phase_columns
from benchmark.frames.spec import FrameMethod

#: the accuracy target's margin: adapted LAMR at most this above image warping's
WARP_MARGIN = 0.03

__all__ = ["WARP_MARGIN", "TARGETS", "summary_table", "phase_table", "phase_gap_lines",
           "accuracy_targets", "seed_summary", "seed_gaps", "plot_seed_figure"]


def summary_table(results, methods, *, seed_note: str = "", n_phases: int = 1) -> list:
    """Markdown lines: each method's LAMR and seconds per frame. With ``n_phases`` > 1 the
    LAMR is the mean over the phases (every method's ``lamr_phases``), beside its standard
    deviation over them and the default grid's."""
    if n_phases == 1:
        lines = [f"| method | LAMR{seed_note} (1e-2..1e0 fppi) | s / frame |", "|---|---|---|"]
        return lines + [f"| {m.name} | {results[m]['lamr']:.3f} | "
                        f"{results[m]['seconds_per_frame']:.3f} |" for m in methods]
    lines = [f"| method | LAMR{seed_note}, mean over {n_phases} grid phases | sd over the "
             "phases | default grid | s / frame |", "|---|---|---|---|---|"]
    for m in methods:
        r = results[m]
        sd, default = np.std(r["lamr_phases"], ddof=1), r["lamr_phases"][0]
        lines.append(f"| {m.name} | {r['lamr']:.3f} | {sd:.3f} | {default:.3f} | "
                     f"{r['seconds_per_frame']:.3f} |")
    return lines


def phase_table(results, phases, shifts) -> str:
    """CSV text: ``method, phase_forward, phase_left, shift_x, shift_y, lamr`` for every method
    run at each phase: a method on the candidate windows at ``phases`` (fractions of the
    ground grid's stride, as ``grid_phase``), a pyramid on the frames moved by ``shifts``
    (whole pixels); the other pair of columns empty."""
    rows = ["method,phase_forward,phase_left,shift_x,shift_y,lamr\n"]
    for m, r in results.items():
        for ph, sh, v in zip(phases, shifts, r.get("lamr_phases", ())):
            where = ",".join("" if c is None else f"{c:g}"
                             for c in phase_columns(m, ph, sh).values())
            rows.append(f"{m.name},{where},{v:.5f}\n")
    return "".join(rows)


def phase_gap_lines(phase_detections, frames, *, n_boot: int = 1000, seed: int = 0) -> list:
    """Markdown lines: each detector's adapted - image warping LAMR, both the mean over the
    grid phases, with its 95 % paired bootstrap interval over frames
    (:func:`benchmark.frames.phases.phase_mean_difference`) against :data:`WARP_MARGIN`: met
    when the whole interval lies at or below it, not met when it lies above, else not
    resolved."""
    from benchmark.frames.phases import phase_mean_difference

    out = []
    for kind in DETECTOR_KINDS:
        ad, wp = FrameMethod(kind, "adapted"), FrameMethod(kind, "warp")
        if ad not in phase_detections or wp not in phase_detections:
            continue
        diff, lo, hi = phase_mean_difference(
            phase_detections[ad], phase_detections[wp], frames, n_boot=n_boot,
            rng=np.random.default_rng(seed))
        verdict = ("met" if hi <= WARP_MARGIN else "NOT met" if lo > WARP_MARGIN else
                   f"not resolved (the mean {'meets' if diff <= WARP_MARGIN else 'misses'} it)")
        out.append(f"- {ad.name} - {wp.name}: {diff:+.3f} [{lo:+.3f}, {hi:+.3f}] over "
                   f"{len(phase_detections[ad])} grid phases; at most +{WARP_MARGIN:g} with "
                   f"the whole interval: {verdict}")
    if not out:
        return []
    return ["", "Adapted minus image warping, mean over the grid phases, 95 % paired "
            f"bootstrap interval over the {len(frames)} frames ({n_boot} replicates):", "",
            *out]


#: the accuracy targets: (how the baseline detects, test on (adapted, baseline) LAMR, wording)
TARGETS = (("warp", lambda a, b: a <= b + WARP_MARGIN,
            f"within {WARP_MARGIN:g} of (or below) image warping"),
            ("pyramid", lambda a, b: a < b, "below the unadapted pyramid"))

def accuracy_targets(results, per_seed=None) -> list:
    """The accuracy targets (:data:`TARGETS`), read off this run's log-average miss rates; with
    ``per_seed`` ({seed: {method: LAMR}}, two seeds or more) judged on the seed means,
    with how many seeds meet each on their own."""
    many = per_seed is not None and len(per_seed) > 1
    lamr = ({m: float(np.mean([r[m] for r in per_seed.values() if m in r]))
             for m in results} if many else {m: r["lamr"] for m, r in results.items()})
    out = []
    for kind in DETECTOR_KINDS:
        ad = FrameMethod(kind, "adapted")
        if ad not in lamr:
            continue
        for base, test, text in TARGETS:
            other = FrameMethod(kind, base)
            if other not in lamr:
                continue
            ok = test(lamr[ad], lamr[other])
            line = (f"- {ad.name} {'mean ' if many else ''}LAMR {lamr[ad]:.3f} {text} "
                    f"({lamr[other]:.3f}): {'met' if ok else 'NOT met'}")
            if many:
                n = sum(test(r[ad], r[other]) for r in per_seed.values())
                line += f" (met at {n} of {len(per_seed)} seeds on their own)"
            out.append(line)
    if not out:
        return []
    head = ["", "## Targets", ""]
    if many:
        head += [f"Judged on the mean over the {len(per_seed)} training seeds "
                 f"{', '.join(map(str, per_seed))} (seeds.md).", ""]
    return head + out


def seed_summary(per_seed) -> list:
    """Markdown lines: each method's LAMR per training seed with mean, standard deviation
    and range, and each detector's adapted - warping gap per seed. ``per_seed`` is
    {seed: {method: LAMR}}; a method missing from a seed (one run only) is left out of
    that seed's column."""
    seeds = list(per_seed)
    methods = list(dict.fromkeys(m for r in per_seed.values() for m in r))

    def header(first):
        return [f"| {first} | " + " | ".join(f"seed {s}" for s in seeds)
                + " | mean | sd | min - max |", "|---|" + "---|" * (len(seeds) + 3)]

    lines = [f"## Log-average miss rate over {len(seeds)} training seeds", "",
             *header("method")]

    def stats(vals, sign=""):
        v = np.asarray(vals, float)
        sd = f"{v.std(ddof=1):.3f}" if v.size > 1 else "-"
        return (f"{v.mean():{sign}.3f} | {sd} | {v.min():{sign}.3f} - "
                f"{v.max():{sign}.3f}")

    for m in methods:
        vals = [per_seed[s].get(m) for s in seeds]
        cells = " | ".join("-" if v is None else f"{v:.3f}" for v in vals)
        lines.append(f"| {m.name} | {cells} | {stats([v for v in vals if v is not None])} |")
    gaps = seed_gaps(per_seed)
    if gaps:
        lines += ["", "Adapted minus image warping (negative: adapted misses less; the "
                  f"target is at most +{WARP_MARGIN:g}):", "", *header("detector")]
        for kind, g in gaps.items():
            lines.append(f"| {kind} | " + " | ".join(f"{v:+.3f}" for v in g)
                         + f" | {stats(g, '+')} |")
    return lines


def seed_gaps(per_seed) -> dict:
    """{detector: [adapted - warping LAMR per seed]} for the detectors with both."""
    out = {}
    for kind in DETECTOR_KINDS:
        ad, wp = FrameMethod(kind, "adapted"), FrameMethod(kind, "warp")
        if all(ad in r and wp in r for r in per_seed.values()):
            out[kind] = [r[ad] - r[wp] for r in per_seed.values()]
    return out


def plot_seed_figure(per_seed, path_stem, *, what: str = "training seeds"):
    """Left: each method's LAMR at every seed (dots) and their mean (bar); right: the
    adapted - warping gap per seed against the 0.03 target. ``per_seed`` is {seed:
    {method: LAMR}}; ``what`` names its keys in the title (e.g. "grid phases")."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    seeds = list(per_seed)
    methods = list(dict.fromkeys(m for r in per_seed.values() for m in r))
    gaps = seed_gaps(per_seed)
    fig, axes = plt.subplots(1, 2 if gaps else 1, figsize=(9 if gaps else 5.5, 3.8),
                             squeeze=False, gridspec_kw={"width_ratios": [2, 1]} if gaps
                             else None)
    ax = axes[0, 0]
    for i, m in enumerate(methods):
        vals = np.array([per_seed[s][m] for s in seeds if m in per_seed[s]])
        color = FAMILY_COLORS.get(m.kind, "tab:gray")
        ax.bar(i, vals.mean(), color=color, alpha=0.3, width=0.7)
        ax.plot(np.full(vals.size, i) + np.linspace(-0.2, 0.2, vals.size), vals, "o",
                color=color, ms=4)
    ax.set_xticks(range(len(methods)), [m.name for m in methods], rotation=30, ha="right",
                  fontsize=8)
    ax.set_ylabel("log-average miss rate")
    ax.set_ylim(0, 1)
    ax.set_title(f"{len(seeds)} {what}: dots, mean: bar", fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)
    if gaps:
        ax = axes[0, 1]
        for i, (kind, g) in enumerate(gaps.items()):
            color = FAMILY_COLORS[kind]
            ax.plot(np.full(len(g), i) + np.linspace(-0.15, 0.15, len(g)), g, "o",
                    color=color, ms=4)
            ax.plot([i - 0.3, i + 0.3], [np.mean(g)] * 2, color=color, lw=2)
        ax.axhline(WARP_MARGIN, color="k", ls="--", lw=1, label=f"target: +{WARP_MARGIN:g}")
        ax.axhline(0.0, color="gray", lw=0.8)
        ax.set_xticks(range(len(gaps)), [f"{k} adapted\n- warping" for k in gaps], fontsize=8)
        ax.set_xlim(-0.6, len(gaps) - 0.4)
        ax.set_ylabel("LAMR difference")
        ax.legend(fontsize=8)
        ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(f"{path_stem}.png", dpi=150)
    plt.close(fig)
