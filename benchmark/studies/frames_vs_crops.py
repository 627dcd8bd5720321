"""Why do the angle rules order differently on crops and on full frames?

``python -m benchmark.studies.frames_vs_crops --data DIR --out DIR [--model M] [--crossval RES]``

On rendered crops (:mod:`benchmark.crops.crossval`, target pi/4) the source HOG/SVM adapted with
the literal eq. (3) of Wang et al. 2017 misses far fewer persons than with the covariant
rule; on the rendered full frames (``bench frames``) the covariant rule is ahead. The two
measurements differ in more than the setting: the crops are scored at 1e-2 false positives
per *window*, every person exactly at the crop elevation and framed by the window; the
frames are scored by the log-average miss rate over 1e-2..1e0 false positives per *image*
(many thousand windows per image), after non-maximum suppression, with persons at
whatever elevation the camera sees them from.

This study removes those differences one at a time on the frames themselves. For every
frame camera and angle rule it scores every candidate window of the adapted HOG detector
(the operators ``viewadapt detect`` and ``bench frames`` use, on the same source model) and
labels the windows against the ground truth (boxes standardised to the 0.41 aspect, as the
Caltech evaluation):

* a person's score is the best score over the windows whose box overlaps the person's box
  by IoU >= 0.5 -- the score the detector could report for that person at best (``-inf``
  when no window fits; persons the Caltech protocol ignores are left out);
* background windows overlap no ground-truth box (ignored ones included) by IoU >= 0.2;
  those whose box still touches a person's full box (parts of persons, persons at another
  scale: negatives the crops never have) are marked.

Then, per rule and with paired differences from the covariant rule (bootstrap over
persons, :func:`benchmark.crops.summarize.paired_differences`):

1. the frames' LAMR from the same scores after NMS (reproduces ``bench frames``);
2. the window-level miss rate at 1e-2, 1e-3 and 1e-4 false positives per window -- the
   crops' measure at the crops' operating point and at the frames' one;
3. the same split by each person's elevation (the angle below the horizontal of the ray
   from the camera to the person's mid-height, as the crops' elevation is defined), and
   by height in pixels (persons against the background windows of the same height);
4. the persons' mean score and the mean of the top 1 % of background scores (the crops'
   score-shift decomposition), and the share of the background windows above the
   1e-4 FPPW threshold that touch a person;
5. the miss rates again with only the background windows that touch no person.

With ``--crossval RES [RES ...]`` (``bench crossval`` results folders with
``scores.parquet``, e.g. one per ``--target``) the crops' miss rates at the same
false-positive-per-window levels are put beside them, per target elevation.

Outputs (``--out``): ``frames_vs_crops.md``, ``window_miss_rates.csv``,
``window_differences.csv``, ``persons.csv``, ``frames_vs_crops.png``, ``run.json``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.boxes import box_intersections, safe_ratio
from viewadapt.detect import FrameDetector, UPSAMPLE_BELOW, ground_truth_rows
from viewadapt.detect.evaluation import standardize_boxes
from viewadapt.geometry import PERSON_HEIGHT_M
from viewadapt.io import SourceDetectors
from viewadapt.io.files import atomic_output_dir, check_output_dir, run_metadata
from viewadapt.nms import detections_from_scores

from benchmark.data import load_dataset
from benchmark.frames.methods import evaluate_method, load_frames, train_source_detectors
from benchmark.frames.spec import variant_label
from benchmark.recipes import PAPER_RECIPE
from benchmark.crops.summarize import paired_differences, summarize
from benchmark.studies import report_error

__all__ = ["person_elevations", "label_windows", "score_frames", "window_tables",
           "crop_tables", "FPPW_LEVELS", "ELEVATION_EDGES", "HEIGHT_EDGES", "main"]

#: false positives per window at which the miss rates are read (the crops' 1e-2, and the
#: frames' operating region: 1e-2..1e0 FPPI over 2e3-2.4e4 windows per image)
FPPW_LEVELS = (1e-2, 1e-3, 1e-4)
#: person elevation bins, radians (the crops' elevations pi/8 = 0.39 and pi/4 = 0.79)
ELEVATION_EDGES = (0.0, 0.3, 0.45, 0.6, np.pi / 2)
#: person height bins, pixels (the crop window's person is 96 px tall at elevation 0)
HEIGHT_EDGES = (0.0, 48.0, 96.0, np.inf)
POSITIVE_IOU, BACKGROUND_IOU = 0.5, 0.2
RULES = ("covariant", "paper", "none")


def person_elevations(camera, ground, person_height: float = PERSON_HEIGHT_M) -> np.ndarray:
    """(G,) elevation, radians, of each person seen from ``camera``.

    The angle below the horizontal of the ray from the camera centre to the person's
    mid-height point ``(x, y, person_height / 2)``: the crops' elevation
    (:func:`generator.sampling` aims every crop camera at that point).

    Parameters
    ----------
    camera : :class:`viewadapt.geometry.Camera`
    ground : (G, 2) or (G, 3) array_like
        Ground positions ``(x, y[, 0])`` in metres.
    """
    g = np.asarray(ground, float).reshape(len(ground), -1)[:, :2]
    centre = -camera.R.T @ camera.t
    horizontal = np.hypot(g[:, 0] - centre[0], g[:, 1] - centre[1])
    return np.arctan2(centre[2] - person_height / 2.0, horizontal)


def label_windows(window_boxes, gt_rows, full_boxes=None):
    """Which windows fit which person, and which are background.

    Parameters
    ----------
    window_boxes : (N, 4) ndarray
        ``(x, y, w, h)`` person boxes of the candidate windows.
    gt_rows : (G, 5) ndarray
        ``(x, y, w, h, ignore)`` of :func:`viewadapt.detect.ground_truth_rows` (boxes
        already standardised).
    full_boxes : (G, 4) ndarray, optional
        The persons' full boxes (not standardised); default the ``gt_rows`` boxes.

    Returns
    -------
    fits : (G, N) bool ndarray
        IoU >= 0.5 between the standardised window box and the person's box.
    background : (N,) bool ndarray
        IoU < 0.2 with every ground-truth box, ignored ones included.
    touches : (N,) bool ndarray
        The window's box (as given) intersects some person's full box.
    """
    raw = np.asarray(window_boxes, float).reshape(-1, 4)
    wb = standardize_boxes(raw)
    gt = np.asarray(gt_rows, float).reshape(-1, 5)
    if len(gt) == 0:
        return np.zeros((0, len(wb)), bool), np.ones(len(wb), bool), np.zeros(len(wb), bool)
    full = gt[:, :4] if full_boxes is None else np.asarray(full_boxes, float).reshape(-1, 4)
    inter = box_intersections(gt[:, :4], wb)
    area_g = gt[:, 2] * gt[:, 3]
    area_w = wb[:, 2] * wb[:, 3]
    iou = safe_ratio(inter, area_g[:, None] + area_w[None, :] - inter)
    touches = (box_intersections(full, raw) > 0).any(0)
    return iou >= POSITIVE_IOU, (iou < BACKGROUND_IOU).all(0), touches


def _method(rule: str) -> str:
    """The crops' name of the adapted variant with ``rule`` (plane object model), e.g.
    ``"adapted[paper eq.3]"``."""
    return variant_label("adapted", rule)


def score_frames(frames, models, *, rules=RULES, heights=(1.65, 1.85), cache_dir=None,
                 upsample_below: float = UPSAMPLE_BELOW, progress: bool = True):
    """Score every candidate window of every frame with the adapted HOG detector of each
    rule (plane object model), windows of persons shorter than ``96 upsample_below`` px
    reading the frame upsampled 2x as the detector's default (0: never).

    Returns
    -------
    persons : DataFrame
        One row per non-ignored ground-truth person: ``person``, ``frame``, ``scene``,
        ``elevation``, ``height_px`` and one ``score[<rule>]`` column per rule.
    background : dict rule -> (B,) ndarray
        Scores of every background window of every frame.
    touching : (B,) bool ndarray
        Which of those windows touch a person's full box (the same windows for every rule).
    heights : (B,) ndarray
        Those windows' person-box heights, pixels.
    detections : dict method -> list of (D, 5) ndarray
        Per frame, the detector's output (threshold and NMS as ``viewadapt detect``).
    windows : dict scene -> int
        Candidate windows per camera.
    """
    from tqdm import tqdm

    by_scene = {}
    for f in frames:
        by_scene.setdefault(f.scene_id, []).append(f)
    rows, background, touching, bg_heights = [], {r: [] for r in rules}, [], []
    detections = {_method(r): [None] * len(frames) for r in rules}
    order = {id(f): i for i, f in enumerate(frames)}
    n_windows = {}
    bar = tqdm(total=len(frames) * len(rules), desc="frames x rules", disable=not progress,
               unit="frame")
    for scene, group in by_scene.items():
        per_frame = {}
        for rule in rules:
            det = FrameDetector(group[0].camera, models, person_heights=heights,
                                cache_dir=cache_dir, rule=rule, upsample_below=upsample_below)
            op = det.operator("hog")
            boxes = op.boxes()
            n_windows[scene] = len(boxes)
            for f in group:
                img = f.image()
                s = op.scores(op.frame_features(img))
                detections[_method(rule)][order[id(f)]] = detections_from_scores(
                    boxes, s, threshold=det.thresholds["hog"], overlap=op.nms_overlap,
                    nms_threshold=op.nms_threshold)
                if id(f) not in per_frame:
                    gt = ground_truth_rows(f.gt, f.occlusion, f.camera.image_size)
                    per_frame[id(f)] = (gt,) + label_windows(boxes, gt, f.gt)
                gt, fits, bg, touches = per_frame[id(f)]
                if rule == rules[0]:
                    touching.append(touches[bg])
                    bg_heights.append(boxes[bg, 3])
                background[rule].append(s[bg])
                best = np.where(fits, s[None, :], -np.inf).max(1) if len(gt) else np.zeros(0)
                for j in np.flatnonzero(gt[:, 4] == 0):
                    rows.append(dict(person=f"{f.image_id}:{j}", frame=f.image_id,
                                     scene=scene, rule=rule, score=float(best[j]),
                                     elevation=float(person_elevations(
                                         f.camera, f.ground[j:j + 1])[0]),
                                     height_px=float(f.gt[j, 3])))
                bar.update(1)
    bar.close()
    long = pd.DataFrame(rows)
    persons = long.pivot_table(index=["person", "frame", "scene", "elevation", "height_px"],
                               columns="rule", values="score").reset_index()
    persons = persons.rename(columns={r: f"score[{r}]" for r in rules})
    persons.columns.name = None
    return persons, {r: np.concatenate(v) for r, v in background.items()}, \
        np.concatenate(touching), np.concatenate(bg_heights), detections, n_windows


def _scores_frame(persons, background, rules, label) -> pd.DataFrame:
    """The window-level scores in the cross-validation's long form (one row per person's
    best window and per background window), for :func:`benchmark.crops.summarize.summarize`."""
    parts = []
    for rule in rules:
        pos = persons[f"score[{rule}]"].to_numpy()
        neg = background[rule]
        parts.append(pd.DataFrame({
            "detector": "hog", "source_elevation": 0.0, "target_elevation": 0.0,
            "method": _method(rule), "subset": label,
            "score": np.r_[np.where(np.isfinite(pos), pos, NO_WINDOW), neg],
            "label": np.r_[np.ones(len(pos), int), np.zeros(len(neg), int)],
            "fold": np.r_[persons["scene"].to_numpy(), np.full(len(neg), "")],
            "person_id": np.r_[persons["person"].to_numpy(), np.full(len(neg), "")]}))
    return pd.concat(parts, ignore_index=True)


def _subsets(persons, background, touching=None, heights=None):
    """(label, persons, background) of every comparison: all persons; by elevation (all
    background windows); by height, persons and background windows of the same height."""
    yield "all frame persons", persons, background
    if touching is not None:
        yield "all frame persons, background touching no person", persons, \
            {r: v[~touching] for r, v in background.items()}
    for lo, hi in zip(ELEVATION_EDGES[:-1], ELEVATION_EDGES[1:]):
        yield f"elevation {lo:.2f}-{hi:.2f} rad", \
            persons[(persons.elevation >= lo) & (persons.elevation < hi)], background
    for lo, hi in zip(HEIGHT_EDGES[:-1], HEIGHT_EDGES[1:]):
        label = f"height {lo:.0f}-{hi:.0f} px" if np.isfinite(hi) else f"height >= {lo:.0f} px"
        bg = background
        if heights is not None:
            label += ", background windows of that height"
            bg = {r: v[(heights >= lo) & (heights < hi)] for r, v in background.items()}
        yield label, persons[(persons.height_px >= lo) & (persons.height_px < hi)], bg


#: the score a person gets in the long table when no window fits it (a sure miss)
NO_WINDOW = -1e9


def _margins(pos, neg) -> dict:
    pos = pos[pos > NO_WINDOW]
    top = np.sort(neg)[::-1][:max(1, int(np.ceil(0.01 * len(neg))))]
    return {"persons_mean": float(np.mean(pos)) if len(pos) else np.nan,
            "top1pct_background_mean": float(np.mean(top))}


def _top_share(neg, mask, fppw=FPPW_LEVELS[-1]) -> float:
    """Share of the ``max(1, fppw N)`` highest-scoring of the ``N`` background windows (the
    false positives allowed at ``fppw``) for which ``mask`` holds."""
    k = max(1, int(np.floor(fppw * len(neg) + 1e-9)))
    return float(mask[np.argsort(-neg, kind="stable")[:k]].mean())


def _rates_at_levels(scores, label, pairs, rates, diffs, *, n_boot, seed, extra=None):
    """Append to ``rates`` each method's miss rate (95 % interval over persons) and score
    margins at every :data:`FPPW_LEVELS`, and to ``diffs`` the paired differences of
    ``pairs``, of one long score table (:func:`benchmark.crops.summarize.summarize`'s input);
    ``extra``: method -> dict of columns added to its rows."""
    for fppw in FPPW_LEVELS:
        s = summarize(scores, fppw=fppw, n_boot=n_boot, rng=np.random.default_rng(seed))
        for _, row in s.iterrows():
            m = scores[scores.method == row["method"]]
            pos = m.score[m.label == 1].to_numpy()
            rates.append(dict(subset=label, method=row["method"], fppw=fppw,
                              miss_rate=row[f"mr_at_fppw_{fppw:g}"], ci_low=row["ci_low"],
                              ci_high=row["ci_high"], n_persons=int(row["n_pos"]),
                              n_background=int(row["n_neg"]),
                              no_window=int((pos <= NO_WINDOW).sum()),
                              top_touching_share=np.nan, top_small_share=np.nan)
                         | (extra or {}).get(row["method"], {})
                         | _margins(pos, m.score[m.label == 0].to_numpy()))
        d = paired_differences(scores, pairs=pairs, fppw=fppw, n_boot=n_boot,
                               rng=np.random.default_rng(seed))
        for _, row in d.iterrows():
            diffs.append(dict(subset=label, fppw=fppw, method_a=row["method_a"],
                              method_b=row["method_b"], diff=row["diff"],
                              ci_low=row["ci_low"], ci_high=row["ci_high"]))


def window_tables(persons, background, touching=None, heights=None, *, rules=RULES,
                  n_boot: int = 1000, seed: int = 0):
    """Window-level miss rates (per subset of persons, rule and FPPW level, with 95 %
    intervals over persons) and paired differences from the covariant rule; with
    ``touching``, also against only the background windows that touch no person; with
    ``heights`` (the background windows' box heights), each height band of persons
    against the background windows of the same band."""
    rates, diffs = [], []
    pairs = [(_method(r), _method("covariant")) for r in rules if r != "covariant"]
    shares = {}
    for r, v in background.items():
        shares[_method(r)] = dict(
            top_touching_share=_top_share(v, touching) if touching is not None else np.nan,
            top_small_share=_top_share(v, heights < HEIGHT_EDGES[1])
            if heights is not None else np.nan)
    for label, sub, bg in _subsets(persons, background, touching, heights):
        if len(sub) == 0 or min(len(v) for v in bg.values()) == 0:
            continue
        extra = shares if label == "all frame persons" else None
        _rates_at_levels(_scores_frame(sub, bg, rules, label), label, pairs, rates, diffs,
                         n_boot=n_boot, seed=seed, extra=extra)
    return pd.DataFrame(rates), pd.DataFrame(diffs)


def crop_tables(crossval_scores: pd.DataFrame, *, rules=RULES, n_boot: int = 1000,
                seed: int = 0):
    """The crops' HOG miss rates from source elevation 0 of each rule at
    :data:`FPPW_LEVELS`, and paired differences from the covariant rule, for every target
    elevation in a cross-validation's ``scores.parquet``."""
    methods = [_method(r) for r in rules]
    d = crossval_scores[(crossval_scores.detector == "hog")
                        & np.isclose(crossval_scores.source_elevation, 0.0)
                        & crossval_scores.method.isin(methods)]
    if d.empty:
        raise ValueError(f"the cross-validation scores have no HOG rows from elevation 0 "
                         f"for {methods}")
    pairs = [(m, _method("covariant")) for m in methods if m != _method("covariant")]
    rates, diffs = [], []
    for target, dt in d.groupby("target_elevation"):
        _rates_at_levels(dt, f"crops at {target:.2f} rad", pairs, rates, diffs,
                         n_boot=n_boot, seed=seed)
    return pd.DataFrame(rates), pd.DataFrame(diffs)


def _markdown(rates, diffs, lamr, run) -> str:
    lines = ["# Crops against frames: the angle rules on the same frame windows", "",
             f"{run['n_frames']} frames, {run['n_persons']} persons scored (Caltech-ignored "
             f"ones left out), {run['n_background']} background windows per rule "
             f"({run['n_background_touching']} of them touch a person); "
             f"candidate windows per camera {min(run['windows'].values())}-"
             f"{max(run['windows'].values())}. Miss rates with 95 % intervals over persons; "
             "differences paired on the same persons and windows.", "",
             "## Frames, as `bench frames` scores them (LAMR over 1e-2..1e0 FPPI)", "",
             "| method | LAMR |", "|---|---|"]
    lines += [f"| {m} | {v:.3f} |" for m, v in lamr.items()]
    share = rates.dropna(subset=["top_touching_share"]).drop_duplicates("method")
    if len(share):
        lines += ["", "Of the background windows above the 1e-4 FPPW threshold, the share "
                  "that touch a person's box: " + ", ".join(
                      f"{r.method} {r.top_touching_share:.2f}" for r in share.itertuples())
                  + f"; the share shorter than {HEIGHT_EDGES[1]:.0f} px: " + ", ".join(
                      f"{r.method} {r.top_small_share:.2f}" for r in share.itertuples())
                  + "."]
    lines += ["", "## Window-level miss rate (each person's best window)", "",
              "| subset | persons | method | MR @1e-2 FPPW | MR @1e-3 | MR @1e-4 | "
              "persons' mean | top-1 % background |", "|---|---|---|---|---|---|---|---|"]
    for (subset, method), g in rates.groupby(["subset", "method"], sort=False):
        g = g.set_index("fppw")
        cells = [f"{g.loc[f, 'miss_rate']:.3f} ({g.loc[f, 'ci_low']:.2f}-"
                 f"{g.loc[f, 'ci_high']:.2f})" for f in FPPW_LEVELS]
        first = g.iloc[0]
        lines.append(f"| {subset} | {first.n_persons} | {method} | " + " | ".join(cells)
                     + f" | {first.persons_mean:+.3f} | {first.top1pct_background_mean:+.3f} |")
    lines += ["", "## Paired differences from the covariant rule (a - adapted)", "",
              "| subset | a | @1e-2 FPPW | @1e-3 | @1e-4 |", "|---|---|---|---|---|"]
    for (subset, a), g in diffs.groupby(["subset", "method_a"], sort=False):
        g = g.set_index("fppw")
        cells = [f"{g.loc[f, 'diff']:+.3f} ({g.loc[f, 'ci_low']:+.3f}..{g.loc[f, 'ci_high']:+.3f})"
                 for f in FPPW_LEVELS]
        lines.append(f"| {subset} | {a} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _plot(rates, path):
    """Miss rate against FPPW for the crops and the frames, and the frames' miss rate at
    the frames' operating point (1e-4 FPPW) by person elevation and by height."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = {"adapted": "tab:blue", "adapted[paper eq.3]": "tab:red",
              "adapted[S only]": "tab:green"}
    crops = sorted(s for s in rates.subset.unique() if s.startswith("crops"))
    curves = [(s, ls) for s, ls in zip(crops, (":", "--"))] + [("all frame persons", "-")]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for s, ls in curves:
        for m, g in rates[rates.subset == s].groupby("method"):
            axes[0].plot(g.fppw, g.miss_rate, ls, marker="o", color=colors.get(m, "k"),
                         label=f"{m}, {s}")
    axes[0].set(xscale="log", xlabel="false positives per window", ylabel="miss rate",
                title="crops (dotted, dashed) and frames (solid)")
    axes[0].legend(fontsize=6)
    fppw = FPPW_LEVELS[-1]
    for ax, prefix, what in ((axes[1], "elevation", "person elevation, rad"),
                             (axes[2], "height", "person and window height, px")):
        subs = [s for s in rates.subset.unique() if s.startswith(prefix)]
        for k, (m, g) in enumerate(rates[rates.subset.isin(subs) & (rates.fppw == fppw)]
                                   .groupby("method")):
            g = g.set_index("subset")
            g = g.loc[[s for s in subs if s in g.index]]
            x = np.arange(len(g)) + 0.08 * (k - 1)
            ax.errorbar(x, g.miss_rate, yerr=[g.miss_rate - g.ci_low, g.ci_high - g.miss_rate],
                        marker="o", capsize=3, color=colors.get(m, "k"), label=m)
            ax.set_xticks(range(len(g)), [f"{i.split(',')[0].split(' ', 1)[1]}\n"
                                          f"({n})" for i, n in zip(g.index, g.n_persons)],
                          fontsize=8)
        ax.set(xlabel=f"{what} (persons)", ylabel=f"miss rate at {fppw:g} FPPW",
               title=f"frames by {prefix}")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.frames_vs_crops",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="dataset directory with frames")
    ap.add_argument("--out", type=Path, required=True, help="output directory")
    ap.add_argument("--model", type=Path, default=None,
                    help="source detectors (models/source_detectors.npz of `bench frames`); "
                         "default: train them as `bench frames` does")
    ap.add_argument("--frame-view", default="both", choices=("hog", "acf", "both", "none"),
                    help="training with frame-view copies, when no --model (default both)")
    ap.add_argument("--crossval", type=Path, nargs="+", default=None, metavar="RESULTS",
                    help="`bench crossval` results folders (their scores.parquet, e.g. one "
                         "per --target): the crops' miss rates at the same FPPW levels "
                         "beside the frames'")
    ap.add_argument("--cache", type=Path, default=None,
                    help="operator cache directory (default OUT/cache)")
    ap.add_argument("--upsample-below", type=float, default=UPSAMPLE_BELOW,
                    help="windows of persons shorter than 96 x this many px read the frame "
                         f"upsampled 2x (default {UPSAMPLE_BELOW:g}, as the detector; 0 = never)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--overwrite", action="store_true",
                    help="write into a non-empty --out that viewadapt did not write")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    args = ap.parse_args(argv)
    try:
        check_output_dir(args.out, overwrite=args.overwrite)
        frames = load_frames(args.data)
        crossval = None
        if args.crossval is not None:
            for folder in args.crossval:
                if not (folder / "scores.parquet").is_file():
                    raise FileNotFoundError(f"{folder} has no scores.parquet (the output "
                                            "of `viewadapt bench crossval`)")
            crossval = pd.concat([pd.read_parquet(f / "scores.parquet")
                                  for f in args.crossval], ignore_index=True)
        if any(f.ground is None for f in frames):
            raise ValueError(f"{args.data}/frames_coco.json has no ground_position per "
                             "person (render the frames again with this version)")
        t0 = time.perf_counter()
        models = (SourceDetectors.load(args.model) if args.model else
                  train_source_detectors(load_dataset(args.data), seed=args.seed,
                                         frame_view=args.frame_view, recipe=PAPER_RECIPE))
        persons, background, touching, heights, detections, windows = score_frames(
            frames, models, cache_dir=args.cache or (args.out / "cache"),
            upsample_below=args.upsample_below, progress=not args.quiet)
    except (ValueError, FileNotFoundError) as exc:
        return report_error(ap, exc)
    lamr = {m: evaluate_method(d, frames)["lamr"] for m, d in detections.items()}
    rates, diffs = window_tables(persons, background, touching, heights, seed=args.seed)
    if crossval is not None:
        r, d = crop_tables(crossval, seed=args.seed)
        rates, diffs = pd.concat([r, rates]), pd.concat([d, diffs])
    run = run_metadata(args.seed, data=str(args.data), model=str(args.model),
                       upsample_below=args.upsample_below,
                       training=models.training, n_frames=len(frames),
                       n_persons=int(len(persons)),
                       n_background=int(len(touching)),
                       n_background_touching=int(touching.sum()),
                       windows=windows, lamr=lamr, seconds=round(time.perf_counter() - t0, 1))
    with atomic_output_dir(args.out) as tmp:
        rates.to_csv(tmp / "window_miss_rates.csv", index=False, float_format="%.5f")
        diffs.to_csv(tmp / "window_differences.csv", index=False, float_format="%.5f")
        persons.to_csv(tmp / "persons.csv", index=False, float_format="%.5f")
        (tmp / "frames_vs_crops.md").write_text(_markdown(rates, diffs, lamr, run))
        (tmp / "run.json").write_text(json.dumps(run, indent=2))
        _plot(rates, tmp / "frames_vs_crops.png")
    print(_markdown(rates, diffs, lamr, run))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
