"""What ``bench runtime`` measured, judged and written down: the targets, the speed-ups
against baselines timed in the same run, and the Markdown report (the paper's Table 1 beside
ours; Wang et al. 2017, Sec. 5.5). Measures nothing: :mod:`benchmark.frames.runtime` times.
"""

from __future__ import annotations

from dataclasses import dataclass

from viewadapt.detect import DETECTOR_KINDS

__all__ = ["RuntimeTarget", "RUNTIME_TARGETS", "RATIOS", "PAPER_RATIOS", "FASTER_ACF_PYRAMID",
           "runtime_quantities", "runtime_ratios", "judge_runtime", "format_table"]


@dataclass(frozen=True)
class RuntimeTarget:
    """A target of ``bench runtime``: a measured quantity, over a baseline's frames per
    second measured in the same run when there is a baseline, held against a bound.

    Attributes
    ----------
    quantity : str
        What is measured (a key of :func:`runtime_quantities`): a method's name for its
        frames per second on one core, or a named measurement (``"nms_ms"``,
        ``"hog_precompute_s"``, ...).
    baseline : str or None
        The method whose frames per second (one core) ``quantity`` is divided by: the
        target is a speed-up; None: ``quantity`` itself is judged.
    bound : float
        The least (or, with ``at_most``, the largest) value that meets the target.
    what : str
        The target in words, as the report and ``info["targets"]`` name it.
    at_most : bool
        True: met when the value is at most ``bound``; False: at least ``bound``.
    """

    quantity: str
    baseline: str | None
    bound: float
    what: str
    at_most: bool = False


#: the targets ``bench runtime`` judges, in the order the report lists them; speed-ups are
#: against baselines timed in the same run on the same machine
RUNTIME_TARGETS = (
    RuntimeTarget("hog_adapted", None, 30.0, "hog_adapted >= 30 fps (1 core)"),
    RuntimeTarget("hog_adapted", "hog_warp", 100.0, "hog_adapted >= 100x hog_warp"),
    RuntimeTarget("hog_adapted", "opencv", 10.0, "hog_adapted >= 10x opencv (4x)"),
    RuntimeTarget("acf_adapted", None, 15.0, "acf_adapted >= 15 fps (1 core)"),
    RuntimeTarget("hog_adapted", None, 100.0, "hog_adapted >= 100 fps (1 core)"),
    RuntimeTarget("acf_adapted", None, 60.0, "acf_adapted >= 60 fps (1 core)"),
    RuntimeTarget("nms_ms", None, 1.0, "NMS <= 1 ms (both detectors)", at_most=True),
    RuntimeTarget("hog_precompute_s", None, 30.0, "precompute <= 30 s (hog)", at_most=True),
    RuntimeTarget("hog_cache_hit_s", None, 1.0, "cache hit <= 1 s (hog)", at_most=True),
    RuntimeTarget("opencv_adapted", "opencv_2x", 1.0, "opencv_adapted >= opencv (2x)"),
    RuntimeTarget("opencv_adapted", None, 25.0, "opencv_adapted >= 25 fps (1 core)"),
)

#: the speed-ups of the report, (method, baseline) -> name; the paper's beside them
RATIOS = {("hog_adapted", "hog_warp"): "hog_adapted / hog_warp",
          ("hog_adapted", "opencv"): "hog_adapted / opencv (4x)",
          ("hog_adapted", "opencv_native"): "hog_adapted / opencv (native)",
          ("hog_adapted", "hog_pyramid"): "hog_adapted / hog_pyramid",
          ("acf_adapted", "acf_warp"): "acf_adapted / acf_warp",
          ("acf_adapted", "acf_pyramid"): "acf_adapted / acf_pyramid",
          ("acf_adapted", "acf_pyramid_fast"): "acf_adapted / acf_pyramid_fast",
          ("opencv_adapted", "opencv_2x"): "opencv_adapted / opencv (2x)",
          ("opencv_adapted", "opencv_warp"): "opencv_adapted / opencv_warp"}
#: the faster of the two ACF pyramids: the baseline the ACF speed-up is claimed against
FASTER_ACF_PYRAMID = "acf_adapted / faster ACF pyramid"
PAPER_RATIOS = {"paper: hog_adapted / hog_warp": 11.8 / 0.0666,
                "paper: acf_adapted / acf_warp": 10.7 / 0.0419,
                "paper: hog_adapted / hog_pyramid": 11.8 / 0.439,
                "paper: acf_adapted / acf_pyramid": 10.7 / 3.54,
                "paper: acf_adapted / acf_pyramid_fast": 10.7 / 3.54,
                "paper: acf_adapted / faster ACF pyramid": 10.7 / 3.54}


def runtime_quantities(rows, info) -> dict:
    """The quantities targets are judged on, taken from measurements alone.

    Each method's frames per second on one core (keyed by the method's name; rows without
    ``fps_1core`` are left out), ``nms_ms`` (the slowest NMS stage among the rows with
    ``stages``, milliseconds; absent without any) and every number in ``info`` whose key
    ends in ``_s`` (seconds: ``hog_precompute_s``, ``hog_cache_hit_s``, ...).
    """
    q = {r["method"]: r["fps_1core"] for r in rows if r.get("fps_1core") is not None}
    nms = [st["ms"] for r in rows for st in r.get("stages") or () if st["stage"] == "nms"]
    if nms:
        q["nms_ms"] = max(nms)
    q.update({k: v for k, v in info.items()
              if k.endswith("_s") and isinstance(v, (int, float)) and not isinstance(v, bool)})
    return q


def runtime_ratios(rows) -> dict:
    """The report's speed-ups from the rows' frames per second (one core), the paper's
    beside them (``"paper: "`` and the same name).

    One entry per pair of :data:`RATIOS` both measured, then ``"acf_adapted / faster ACF
    pyramid"`` (against the faster of ``acf_pyramid`` and ``acf_pyramid_fast``) where all
    three are, then the paper's ratios.
    """
    fps = runtime_quantities(rows, {})
    out = {name: fps[m] / fps[b] for (m, b), name in RATIOS.items() if m in fps and b in fps}
    if {"acf_adapted", "acf_pyramid", "acf_pyramid_fast"} <= fps.keys():
        out[FASTER_ACF_PYRAMID] = fps["acf_adapted"] / max(fps["acf_pyramid"],
                                                           fps["acf_pyramid_fast"])
    return {**out, **PAPER_RATIOS}


def judge_runtime(rows, info, targets=RUNTIME_TARGETS) -> list:
    """Each target held against the measurements (:func:`runtime_quantities` of ``rows``
    and ``info``); measures nothing.

    Returns
    -------
    list of dict
        Per target, in order: ``target`` (its ``what``), ``value`` (the quantity, or the
        quantity over the baseline's frames per second; None when not judged), ``bound``,
        ``met`` (bool; None when not judged) and ``missing`` (the quantity or baseline not
        measured, or not positive for a baseline; None when judged).
    """
    q = runtime_quantities(rows, info)
    out = []
    for t in targets:
        value, missing = q.get(t.quantity), None
        if value is None:
            missing = t.quantity
        elif t.baseline is not None:
            base = q.get(t.baseline)
            value, missing = (value / base, None) if base else (None, t.baseline)
        met = None if value is None else bool(value <= t.bound if t.at_most
                                              else value >= t.bound)
        out.append(dict(target=t.what, value=value, bound=t.bound, met=met, missing=missing))
    return out


def format_table(rows, info) -> str:
    """Markdown: ratios first (the headline), then Table 1 with the paper beside ours."""
    out = ["# Runtime (Table 1 of Wang et al. 2017, this implementation)", "",
           f"{info['candidate_windows']} candidate windows on a "
           f"{'x'.join(str(v) for v in info.get('size', (384, 288)))} frame (paper: "
           f"{info['paper_windows']} on CAVIAR); HOG: {info['hog_scored_positions']} "
           f"distinct scored positions, {info['hog_weights_per_window']:.0f} adapted weights "
           f"each, {info['hog_templates']} shared templates, cell sizes "
           f"{', '.join(f'{c:g}' for c in info['hog_cell_sizes'])} frame px (under 2 px: "
           "cells of the 2x-upsampled frame).", "", "## Speed-ups measured in the same run", "",
           "| ratio | ours | paper |", "|---|---|---|"]
    r = info["ratios"]
    for k in ("hog_adapted / hog_warp", "acf_adapted / acf_warp", "hog_adapted / hog_pyramid",
              "acf_adapted / acf_pyramid", "acf_adapted / acf_pyramid_fast"):
        out.append(f"| {k} | {r[k]:.0f}x | {r['paper: ' + k]:.0f}x |")
    k = "acf_adapted / faster ACF pyramid"
    out.append(f"| **{k}** ({info['faster_acf_pyramid']}: the baseline the ACF speed-up is "
               f"claimed against; the paper's 3.54 fps is the toolbox's fast pyramid) | "
               f"{r[k]:.0f}x | {r['paper: ' + k]:.0f}x |")
    for k in ("hog_adapted / opencv (4x)", "hog_adapted / opencv (native)",
              "opencv_adapted / opencv (2x)", "opencv_adapted / opencv_warp"):
        if k in r:
            out.append(f"| {k} | {r[k]:.1f}x | - |")
    out += ["", "## Frames per second", "",
            "| method | fps, 1 core | fps, all cores | paper fps (1 i7 core) | windows | "
            "feature pixels | how |", "|---|---|---|---|---|---|---|"]
    for row in rows:
        allc = f"{row['fps_all_cores']:.2f}" if row["fps_all_cores"] else "-"
        paper = f"{row['paper_fps']}" if row["paper_fps"] else "-"
        win = f"{row['windows']}" if row["windows"] else "-"
        out.append(f"| {row['method']} | {row['fps_1core']:.3g} | {allc} | {paper} | {win} | "
                   f"{row['feature_pixels']:.3g} | {row['how']}; {row['detail']} |")
    out += ["", "## Stages against a memory-bandwidth floor (one core, one frame)", "",
            "Floor: a plain copy (np.copyto, preallocated) of as many bytes as the stage "
            "reads and writes at least once, timed in this run -- features: the frame in, the "
            "cell maps out; scoring: the cell maps and the adapted weights in, the scores out; "
            "NMS: the scores in, candidates and detections. Fraction = floor / stage (1 = at "
            "the floor).", "",
            "| method | stage | ms | MB read + written | floor ms | fraction of floor |",
            "|---|---|---|---|---|---|"]
    for row in rows:
        for st in row.get("stages", ()):
            out.append(f"| {row['method']} | {st['stage']} | {st['ms']:.2f} | "
                       f"{st['bytes'] / 1e6:.3g} | {st['floor_ms']:.3f} | "
                       f"{st['floor_ms'] / st['ms']:.3f} |")
    out += ["", "## Scoring, forms of the same operator (one core, same scores; HOG: the "
            "folded operator, without its normalisation stage)", "",
            "| detector | form | ms per frame |", "|---|---|---|"]
    for kind in DETECTOR_KINDS:
        for k, v in info.get(f"{kind}_scoring_forms_ms", {}).items():
            out.append(f"| {kind.upper()} | {k} | {v} |")
    out += ["", f"Precompute (one camera, one model): HOG {info['hog_precompute_s']} s, ACF "
            f"{info['acf_precompute_s']} s; cache hit HOG {info['hog_cache_hit_s']} s, ACF "
            f"{info['acf_cache_hit_s']} s; window selection {info['window_selection_s']} s.",
            (f"All cores = {info['cores']} processes, each detecting on its own frames"
             if info["cores"] > 1 else "All cores not measured (--jobs 1)")
            + "; load average at the end "
            + ("n/a" if info["load_average"] is None else f"{info['load_average']:.2f}") + ".",
            "Detectors trained with " + ", ".join(
                f"{k}={v['name'] if k == 'recipe' else v}"
                for k, v in info.get("training", {}).items()) + ".",
            "", "## Targets", ""]
    for t in RUNTIME_TARGETS:
        met = info["targets"].get(t.what)
        out.append(f"- {t.what}: "
                   + ("not judged (not measured)" if met is None else "met" if met else "NOT met"))
    return "\n".join(out) + "\n"
