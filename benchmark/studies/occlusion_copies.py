"""Positives partly hidden, added to the training: ``python -m benchmark.studies.occlusion_copies``.

The hypothesis under test: a detector trained on renders misses real people in groups and
behind street furniture (``benchmark.studies.footage_errors``) because every rendered
crop shows one fully visible person. Each source-view crop gets one copy, drawn per crop
(seeded), in which

* a *neighbour* -- another person's crop, cut out by its depth map's silhouette, scaled by
  0.9-1.1 about the feet and moved sideways by 0.24-0.48 of the window's width (up to 6 px
  up or down) -- stands in front of the person, or
* the same neighbour stands behind the person (the person's own silhouette stays on top),
  or
* a *pole* -- a vertical bar 2-7 px wide, of a random grey level with a shading across it
  and a slight colour cast -- stands in front of the person at a random column;

``--modes`` keeps the neighbour copies, the pole copies or both. The copies join the crops
as positives (the crops themselves stay); the rest of the training is ``bench frames``'
(:func:`viewadapt.detect.train_on_windows`: the source view's background windows,
frame-view copies of every positive, the same seed).

Writes ``source_detectors.npz`` and ``occlusion.json`` (the copies drawn, per mode) into
``--out``; compare the models on a real clip with :mod:`benchmark.studies.footage_models`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

__all__ = ["MODES", "occlusion_copy", "occluded_copies", "main"]

#: The copies a crop can get, in the order of their probabilities (0.35, 0.35, 0.3).
MODES = ("front", "behind", "pole")
_PROBABILITIES = (0.35, 0.35, 0.3)


def _moved(img, mask, dx: float, dy: float, s: float):
    """``img`` and ``mask`` scaled by ``s`` about the window's bottom centre, then moved by
    ``(dx, dy)``; outside: zeros."""
    import cv2

    h, w = mask.shape
    cx, cy = w / 2, h - 4
    A = np.array([[s, 0, cx - s * cx + dx], [0, s, cy - s * cy + dy]], np.float32)
    out = cv2.warpAffine(img, A, (w, h), flags=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT)
    m = cv2.warpAffine(mask.astype(np.float32), A, (w, h), flags=cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_CONSTANT)
    return out, m


def occlusion_copy(window, mask, partner, partner_mask, rng, *, mode=None):
    """One occluded copy of a person window.

    Parameters
    ----------
    window, partner : (128, 64, 3) uint8
        The person's crop and another person's.
    mask, partner_mask : (128, 64) bool
        Their silhouettes (the pixels of the body).
    rng : numpy.random.Generator
        The draw (mode, placement, pole).
    mode : str, optional
        One of :data:`MODES`; default drawn.

    Returns
    -------
    (128, 64, 3) uint8 ndarray and the mode.
    """
    if mode is None:
        mode = MODES[int(rng.choice(len(MODES), p=_PROBABILITIES))]
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    h, w = mask.shape
    out = window.astype(np.float32)
    if mode != "pole":
        dx = rng.choice([-1, 1]) * rng.uniform(0.24, 0.48) * w
        q, m = _moved(partner.astype(np.float32), partner_mask, dx, rng.uniform(-6, 6),
                      rng.uniform(0.9, 1.1))
        m = m[..., None]
        if mode == "behind":
            m = m * (1 - mask.astype(np.float32)[..., None])
        out = out * (1 - m) + q * m
    else:
        x, width = rng.uniform(10, w - 10), rng.uniform(2, 7)
        level, shading = rng.uniform(30, 210), rng.uniform(-25, 25)
        xs = np.arange(w)[None, :, None] + 0.5
        cover = np.clip(np.minimum(xs - (x - width / 2), (x + width / 2) - xs) + 0.5, 0, 1)
        shade = level + shading * ((xs - x) / max(width, 1.0))
        colour = np.broadcast_to(shade, (h, w, 1)) * rng.uniform(0.85, 1.15, 3)[None, None, :]
        out = out * (1 - cover) + colour * cover
    return np.clip(out + 0.5, 0, 255).astype(np.uint8), mode


def occluded_copies(windows, masks, person_ids, *, modes=MODES, seed: int = 0):
    """One copy per window whose drawn mode is in ``modes`` (:func:`occlusion_copy`; the
    neighbour another person's window, drawn with the rest from ``seed``): ``(copies,
    {mode: count})``."""
    ids = np.asarray(person_ids)
    several = len(set(ids.tolist())) > 1
    if not several and set(modes) - {"pole"}:
        raise ValueError("a neighbour needs crops of at least two persons")
    rng = np.random.default_rng(1000 + int(seed))
    copies, counts = [], {m: 0 for m in MODES}
    for i, win in enumerate(windows):
        j = i
        while several and ids[j] == ids[i]:
            j = int(rng.integers(len(windows)))
        out, mode = occlusion_copy(win, masks[i], windows[j], masks[j], rng)
        if mode in modes:
            copies.append(out)
            counts[mode] += 1
    return copies, counts


def main(argv=None) -> int:
    from dataclasses import replace

    from benchmark.crops.features import background_windows, person_windows
    from benchmark.data import DatasetError, load_dataset, read_depth_map
    from benchmark.frames.methods import dataset_provenance
    from viewadapt.detect import train_on_windows
    from viewadapt.io.files import atomic_output_dir, check_output_dir

    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.occlusion_copies",
                                 description=__doc__.split("\n\n")[1])
    ap.add_argument("--data", type=Path, required=True,
                    help="a generated dataset whose crops have depth maps")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--modes", choices=("all", "neighbours", "poles"), default="all")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="smaller detectors (tests)")
    args = ap.parse_args(argv)
    check_output_dir(args.out)
    ds = load_dataset(args.data)
    pw = person_windows(ds, 0)
    rows = ds.persons.set_index("path").loc[list(pw.meta["path"])].reset_index()
    if "depth_path" not in rows.columns:
        ap.error(f"{args.data}: its crops have no depth maps (rerun `viewadapt generate` "
                 "with the same --out to add them)")
    try:
        masks = [np.isfinite(read_depth_map(ds.root, r)) for r in rows.to_dict("records")]
    except DatasetError as exc:
        ap.error(str(exc))
    pos = list(pw.images(ds.root))
    modes = {"all": MODES, "neighbours": ("front", "behind"), "poles": ("pole",)}[args.modes]
    copies, counts = occluded_copies(pos, masks, pw.meta["person_id"], modes=modes,
                                     seed=args.seed)
    neg = list(background_windows(ds, 0, stride=16).images(ds.root))
    print(f"{len(pos)} crops, {len(copies)} occluded copies {counts}, {len(neg)} negatives")
    models = train_on_windows(pos + copies, neg, seed=args.seed, quick=args.quick,
                              frame_view="both")
    models = replace(models, training=dict(
        seed=args.seed, frame_view="both", quick=args.quick, source_index=0,
        occlusion_copies=dict(modes=list(modes), counts=counts), crops=len(pos),
        background_windows=len(neg), dataset=dataset_provenance(ds)))
    with atomic_output_dir(args.out) as tmp:
        models.save(tmp / "source_detectors.npz")
        (tmp / "occlusion.json").write_text(json.dumps(
            {"modes": list(modes), "counts": counts, "seed": args.seed}, indent=1))
    print(f"wrote {args.out}/source_detectors.npz, occlusion.json")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
