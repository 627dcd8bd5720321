"""One-off probe (docs/training.md point 54): the covariant orientation map on some pixels of each
test window only, S only on the others. HOG 0 -> pi/4 on DATA under `regularised`, the
cross-validation's nine fold models, at the true elevation, S from the plane for every part.
Every test window's 4-px cells are split exactly (cell sums are linear) into an "inside" part and
the rest:
  depth       inside = the test person's own pixels (its crop's depth map is finite there);
              background windows have none, so they are all "rest";
  depth2      the same mask dilated by 2 px (a 3x3 square, twice), so that the gradients on both
              sides of the silhouette's edge count as the person's;
  silhouette  inside = the mean body's silhouette in the target crop camera, the same mask for
              every window (what a detector could use without knowing the person).
Rows: S only everywhere (A identity), covariant everywhere, covariant on the inside only,
covariant on the rest only; each against A identity, paired bootstrap over test persons.
  ground      the depth split with other maps on the rest (point 55): S only, eq. (3), or the
              ground plane's own orientation map (per source cell, the covariant map of the
              Jacobian of source -> target pixels through the ground Z = 0 between the two
              crop cameras; the identity where a source cell's ray misses the ground); and
              eq. (3) and the ground map on every pixel.
  silhouette-ground  the silhouette split with the ground plane's map outside it.
  ground-control     as ground, but every background window is split by the depth mask of a
              test person drawn at random (seed 0), so negatives are split as positives are
              (the split then says nothing about which windows hold a person).
Usage: pixel_split.py depth|depth2|silhouette|ground|silhouette-ground|ground-control DATA
       OUT CACHE"""
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from benchmark.crops.crossval import (CrossvalConfig, fold_masks, run_crossval, variant_remap,
                                      view_maps)
from benchmark.crops.detectors import detector_spec
from benchmark.crops.features import FeatureCache, background_windows, person_windows
from benchmark.crops.folds import make_folds
from benchmark.data import load_dataset, read_depth_map
from benchmark.recipes import get_recipe
from benchmark.studies.sweep_decomposition import split_remap
from benchmark.studies.sweep_intervals import bootstrap_miss_rates, person_hits
from viewadapt.adapt import remap_features
from viewadapt.detect import cell_sums, fast_orientation_channels
from viewadapt.geometry import WINDOW_HEIGHT, WINDOW_WIDTH, crop_camera, elevation_homography
from viewadapt.objectmodel import object_model
from viewadapt.remap import CellGrid
from viewadapt.surface import surface_depth


def ground_remap(t, distance, target_cell_size):
    """S of the person plane 0 -> t with, per source cell, the ground plane's covariant
    orientation map (the identity where the cell's ray misses the ground)."""
    def ground_h(cam):                       # ground (X, Y, 1) -> image pixels
        return cam.K @ np.column_stack([cam.R[:, 0], cam.R[:, 1], cam.t])

    cs, ct = crop_camera(0.0, distance=distance), crop_camera(float(t), distance=distance)
    Hg = ground_h(ct) @ np.linalg.inv(ground_h(cs))          # source -> target, via the ground
    c = CellGrid.for_window(WINDOW_WIDTH, WINDOW_HEIGHT, 8).centers()
    g = np.linalg.solve(ground_h(cs), np.c_[c, np.ones(len(c))].T).T
    X = np.c_[g[:, :2] / g[:, 2:], np.zeros(len(c))]
    hits = (X @ cs.R.T + cs.t)[:, 2] > 0                     # in front of the source camera
    G = split_remap(elevation_homography(0.0, float(t), distance=distance), Hg, "covariant",
                    target_cell_size, keep=hits)
    return G, int(hits.sum())


def mean_silhouette(e, distance):
    V, F = object_model("body").mesh()
    d = surface_depth(V, F, crop_camera(float(e), distance=distance), (WINDOW_HEIGHT, WINDOW_WIDTH))
    return np.isfinite(d)


def inside_cells(ds, windows, masks):
    """Each window's 4-px cells over the pixels of its mask (``masks``: one per window)."""
    return np.array([cell_sums(fast_orientation_channels(img) * m.astype(np.float32)[..., None],
                               4).ravel() for img, m in zip(windows.images(ds.root), masks)],
                    dtype=np.float32)


def main(mode, data, out, cache_dir):
    ds = load_dataset(data)
    cfg = CrossvalConfig(seed=0, n_jobs=1, sources=(0.0,), detectors=("hog",), ablations=False,
                         synthesised=False, upper_bound=False, object_models=("plane",),
                         distance=float(ds.config.get("distance", 10.0)),
                         framing=str(ds.config.get("framing", "plane")))
    cfg.recipe = get_recipe("regularised")
    cache = FeatureCache(ds, cache_dir, n_jobs=1)
    models = {}
    run_crossval(ds, cfg, cache, models=models, progress=False)
    spec = detector_spec("hog")
    et = ds.elevation_index(cfg.target)
    pw, bw = person_windows(ds, et), background_windows(ds, et, stride=cfg.bg_stride)
    X4 = np.vstack([cache.get(pw, "cells4"), cache.get(bw, "cells4")])
    if mode in ("depth", "depth2", "ground", "ground-control"):
        rows = ds.persons.set_index("path").loc[pw.meta["path"]].reset_index()
        masks = [np.isfinite(read_depth_map(ds.root, r)) for _, r in rows.iterrows()]
        if mode == "depth2":
            import cv2

            masks = [cv2.dilate(m.astype(np.uint8), None, iterations=2).astype(bool)
                     for m in masks]
        if mode == "ground-control":
            drawn = np.random.default_rng(0).integers(len(masks), size=len(bw))
            Xb_in = inside_cells(ds, bw, [masks[i] for i in drawn])
        else:
            Xb_in = np.zeros((len(bw), X4.shape[1]), np.float32)
        Xin = np.vstack([inside_cells(ds, pw, masks), Xb_in])
    else:                                    # silhouette, silhouette-ground
        m = mean_silhouette(cfg.target, cfg.distance)
        Xin = np.vstack([inside_cells(ds, pw, [m] * len(pw)), inside_cells(ds, bw, [m] * len(bw))])
    maps = view_maps(0.0, cfg.target, cfg)["plane"]
    G = {"cov": variant_remap("hog", maps, "adapted", cfg),
         "S": variant_remap("hog", maps, "adapted[S only]", cfg)}
    inside = "covariant on the person's own pixels" if mode != "silhouette" else \
        "covariant inside the mean body's silhouette"
    methods = {"A identity (S only)": ("S", "S"), "covariant everywhere": ("cov", "cov"),
               inside: ("cov", "S"), "covariant on the rest only": ("S", "cov")}
    if mode in ("ground", "silhouette-ground", "ground-control"):
        G["eq3"] = variant_remap("hog", maps, "adapted[paper eq.3]", cfg)
        G["ground"], n_hit = ground_remap(cfg.target, cfg.distance, cfg.target_cell_size)
        print(f"ground map: {n_hit} of 128 source cells see the ground")
    if mode == "silhouette-ground":
        methods = {"A identity (S only)": ("S", "S"), "covariant everywhere": ("cov", "cov"),
                   "eq. (3) everywhere": ("eq3", "eq3"),
                   "covariant inside the mean body's silhouette, the ground map outside": ("cov", "ground"),
                   "the ground map everywhere": ("ground", "ground")}
    elif mode in ("ground", "ground-control"):
        methods = {"A identity (S only)": ("S", "S"),
                   "covariant on the person, S only on the rest": ("cov", "S"),
                   "covariant on the person, eq. (3) on the rest": ("cov", "eq3"),
                   "covariant on the person, the ground map on the rest": ("cov", "ground"),
                   "eq. (3) everywhere": ("eq3", "eq3"), "the ground map everywhere": ("ground", "ground")}
    labels = np.r_[np.ones(len(pw)), np.zeros(len(bw))]
    pids = np.r_[pw.meta["person_id"].to_numpy(), np.full(len(bw), "")]
    folds = make_folds(ds.persons["person_id"], ds.persons["scene_id"],
                       rng=np.random.default_rng(cfg.seed))
    tests = [np.r_[fold_masks(pw.meta, fold, False), fold_masks(bw.meta, fold, False)]
             for fold in folds]
    part = {"in": Xin, "rest": X4 - Xin}
    remapped = {}                            # (map, part) -> its remapped cells, made once

    def mapped(g, k):
        if (g, k) not in remapped:
            remapped[(g, k)] = remap_features(G[g], part[k])
        return remapped[(g, k)]

    frames = []
    for name, (gi, gr) in methods.items():
        X = (mapped(gi, "in") + mapped(gr, "rest")).astype(np.float32)
        for fold, t in zip(folds, tests):
            frames.append(pd.DataFrame({"method": name, "estimate": cfg.target, "label": labels[t],
                                        "score": spec.score(models[("hog", 0.0, fold.name)], X[t]),
                                        "person_id": pids[t]}))
    keys, persons, hits, counts = person_hits(pd.concat(frames, ignore_index=True), 1e-2)
    names = [k[0] for k in keys]
    mr = bootstrap_miss_rates(hits, counts, 1000, np.random.default_rng(0))
    i0 = names.index("A identity (S only)")
    lines = [f"# The covariant map on part of each window ({mode}; `{data}`, regularised, "
             "HOG 0 → π/4, at the truth, S from the plane)", "",
             "| map | miss rate at 10⁻² FPPW | cost against A identity (paired, 95 %) |",
             "|---|---|---|"]
    for n in methods:
        d = mr[:, names.index(n)] - mr[:, i0]
        lo, hi = np.percentile(d[1:], [2.5, 97.5])
        lines.append(f"| {n} | {mr[0, names.index(n)]:.3f} | {d[0]:+.3f} ({lo:+.3f}…{hi:+.3f}) |")
    Path(out).mkdir(parents=True, exist_ok=True)
    (Path(out) / f"{mode}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    if len(sys.argv) != 5 or sys.argv[1] not in ("depth", "depth2", "silhouette", "ground",
                                                     "silhouette-ground", "ground-control"):
        raise SystemExit(__doc__)
    main(*sys.argv[1:5])
