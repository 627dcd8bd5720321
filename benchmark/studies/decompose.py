"""Where the planar model's prediction fails on rendered 3-D people: measured, label-free.

``python -m benchmark.studies.decompose --data DIR --out RES`` reads the crops and their depth maps
(pairs of views of the same instance) and writes, beside a Markdown summary:

* **silhouette** (``silhouette.csv``): per elevation, the rendered body's height, top and
  bottom row, and width at five heights, against what the person plane predicts (its 96 px
  person mapped by the crop homography) and what the mean-body model predicts (its mesh's
  depth-map silhouette);
* **orientations** (``orientations.csv``): at body pixels visible in both views with a
  strong gradient in both, the measured source-view gradient orientation against each
  rule's prediction from the target-view orientation -- no remapping (``none``), the
  covariant rule and the literal eq. (3) (``paper``), each with the plane's Jacobian, the
  mean body's, and the exact Jacobian of the rendered correspondences -- split into pixels
  on the silhouette boundary (occluding contours) and inside it;
* **score shifts** (``score_shift.csv``, from a cross-validation's ``scores.parquet`` when
  ``--results`` is given): per method, the mean score of the test persons and of the top 1 %
  of background windows.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from viewadapt.geometry import apply_homography, homography_jacobian
from viewadapt.mapping import GridMapping, mapping_jacobian
from viewadapt.objectmodel import crop_view_mapping, object_model
from viewadapt.remap import map_angles
from viewadapt.surface import surface_depth, view_correspondence

from benchmark.data import load_dataset, manifest_camera, read_depth_map, read_image

__all__ = ["silhouette_table", "orientation_table", "score_shift_table", "main"]


def _extent(mask):
    """Top row, bottom row (pixel edges), height and widths at 10/30/50/70/90 % down."""
    rows = np.flatnonzero(mask.any(axis=1))
    if len(rows) == 0:
        return None
    top, bot = rows[0] - 0.5, rows[-1] + 0.5
    out = {"top": top, "bottom": bot, "height": bot - top}
    for f in (0.1, 0.3, 0.5, 0.7, 0.9):
        r = int(round(top + f * (bot - top)))
        out[f"width_{int(f * 100)}"] = float(mask[min(max(r, 0), mask.shape[0] - 1)].sum())
    return out


def silhouette_table(ds, cfg_distance=10.0, framing="plane") -> pd.DataFrame:
    """Measured silhouettes per elevation (mean and sd over crops) beside the plane's and
    the mean body's predictions."""
    from viewadapt.geometry import crop_camera, crop_homography

    p = ds.persons
    rows = []
    body = object_model("body")
    V, F = body.mesh()
    for e, g in p.groupby("elevation"):
        meas = [_extent(np.isfinite(read_depth_map(ds.root, r))) for r in g.to_dict("records")]
        meas = pd.DataFrame([m for m in meas if m])
        H = crop_homography(float(e), distance=cfg_distance, framing=framing)
        head, feet = apply_homography(H, np.array([[31.5, 15.5], [31.5, 111.5]]))
        plane = {"top": head[1] - 0.5, "bottom": feet[1] + 0.5,
                 "height": feet[1] - head[1] + 1.0}
        cam = crop_camera(float(e), distance=cfg_distance)
        bm = _extent(np.isfinite(surface_depth(V, F, cam, (128, 64))))
        for k in ("top", "bottom", "height", "width_10", "width_30", "width_50", "width_70",
                  "width_90"):
            rows.append({"elevation": float(e), "quantity": k,
                         "measured_mean": float(meas[k].mean()),
                         "measured_sd": float(meas[k].std()), "n": len(meas),
                         "plane": plane.get(k, np.nan), "body_model": bm[k]})
    return pd.DataFrame(rows)


def _grad(img):
    import cv2

    g = img.astype(np.float32).mean(axis=2) if img.ndim == 3 else img.astype(np.float32)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
    return np.hypot(gx, gy), np.mod(np.arctan2(gy, gx), np.pi)


def _angle_error(a, b):
    d = np.abs(np.mod(a - b, np.pi))
    return np.degrees(np.minimum(d, np.pi - d))


def orientation_table(ds, source: float, target: float, *, max_pairs: int = 400,
                      strong: float = 0.7, framing="plane", distance=10.0,
                      seed: int = 0) -> pd.DataFrame:
    """Median angular error (degrees) of each rule x Jacobian at predicting the source-view
    gradient orientation from the target view's, over paired body pixels."""
    import cv2

    from viewadapt.geometry import elevation_homography

    p = ds.persons
    es, et = ds.elevation_index(source), ds.elevation_index(target)
    key = ["person_id", "scene_id", "instance"]
    S = p[p["elevation_index"] == es].set_index(key)
    T = p[p["elevation_index"] == et].set_index(key)
    pairs = S.index.intersection(T.index)
    rng = np.random.default_rng(seed)
    pick = rng.permutation(len(pairs))[:max_pairs]
    H = elevation_homography(source, target, distance=distance, framing=framing)
    body = crop_view_mapping(object_model("body"), source, target, distance=distance,
                             framing=framing)
    acc = {}
    for k in pick:
        rs, rt = S.loc[pairs[k]].to_dict(), T.loc[pairs[k]].to_dict()
        ds_, dt_ = read_depth_map(ds.root, rs), read_depth_map(ds.root, rt)
        uv, vis = view_correspondence(ds_, manifest_camera(rs), dt_, manifest_camera(rt))
        ms, ths = _grad(read_image(ds.root / rs["path"]))
        mt, tht = _grad(read_image(ds.root / rt["path"]))
        j = np.rint(np.nan_to_num(uv[..., 0], nan=-1)).astype(int)
        i = np.rint(np.nan_to_num(uv[..., 1], nan=-1)).astype(int)
        ok = vis & (j >= 0) & (j < 64) & (i >= 0) & (i < 128)
        mask = np.isfinite(ds_).astype(np.uint8)
        edge = (mask - cv2.erode(mask, np.ones((3, 3), np.uint8))).astype(bool)
        body_px = mask.astype(bool)
        mt_s = np.zeros_like(ms)
        tht_s = np.zeros_like(ths)
        mt_s[ok], tht_s[ok] = mt[i[ok], j[ok]], tht[i[ok], j[ok]]
        thr_s = np.quantile(ms[body_px], strong)
        thr_t = np.quantile(mt[np.isfinite(dt_)], strong)
        sel = ok & (ms > thr_s) & (mt_s > thr_t)
        yy, xx = np.nonzero(sel)
        if len(yy) == 0:
            continue
        pts = np.stack([xx, yy], -1).astype(float)
        exact = GridMapping(np.where(vis[..., None], uv, np.nan))
        Js = {"plane": homography_jacobian(H, pts), "body": mapping_jacobian(body, pts),
              "exact": mapping_jacobian(exact, pts, step=0.5)}
        th_t, th_s = tht_s[sel], ths[sel]
        where = {"boundary": edge[sel], "interior": ~edge[sel]}
        preds = {"none": th_t}
        for jn, J in Js.items():
            good = np.isfinite(J).all(axis=(1, 2)) & (np.linalg.det(np.nan_to_num(J)) > 0)
            Jg = np.where(good[:, None, None], J, np.eye(2))
            for rule in ("covariant", "paper"):
                pr = map_angles(th_t, Jg, rule)
                pr[~good] = np.nan
                preds[f"{rule}, {jn} J"] = pr
        for name, pr in preds.items():
            err = _angle_error(pr, th_s)
            for wn, w in where.items():
                acc.setdefault((name, wn), []).append(err[w & np.isfinite(err)])
    rows = []
    for (name, wn), parts in acc.items():
        e = np.concatenate(parts)
        rows.append({"prediction": name, "pixels": wn, "n": int(len(e)),
                     "median_error_deg": float(np.median(e)),
                     "mean_error_deg": float(np.mean(e))})
    return pd.DataFrame(rows).sort_values(["pixels", "median_error_deg"])


def score_shift_table(scores: pd.DataFrame, detector="hog", source=0.0) -> pd.DataFrame:
    """Per method: persons' mean score and the mean of the top 1 % background scores."""
    d = scores[(scores["detector"] == detector) & np.isclose(scores["source_elevation"], source)]
    rows = []
    for m, g in d.groupby("method", sort=False):
        pos = g.loc[g["label"] == 1, "score"].to_numpy()
        neg = np.sort(g.loc[g["label"] == 0, "score"].to_numpy())[::-1]
        top = neg[: max(1, len(neg) // 100)]
        rows.append({"method": m, "persons_mean": float(pos.mean()),
                     "top1pct_background_mean": float(top.mean()),
                     "margin": float(pos.mean() - top.mean())})
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmark.studies.decompose", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, required=True, help="dataset with depth maps")
    ap.add_argument("--out", type=Path, required=True, help="output directory")
    ap.add_argument("--results", type=Path, default=None,
                    help="a `bench crossval` results directory (for the score shifts)")
    ap.add_argument("--pairs", type=int, default=400, help="instances for the orientations")
    args = ap.parse_args(argv)
    ds = load_dataset(args.data)
    framing = str(ds.config.get("framing", "plane"))
    dist = float(ds.config.get("distance", 10.0))
    args.out.mkdir(parents=True, exist_ok=True)
    lines = ["# Decomposition: the planar model against rendered 3-D people", ""]
    sil = silhouette_table(ds, dist, framing)
    sil.to_csv(args.out / "silhouette.csv", index=False)
    lines += ["## Silhouette per elevation (pixels; measured mean ± sd over crops)", "",
              "| elevation | quantity | measured | plane | mean body |", "|---|---|---|---|---|"]
    for _, r in sil.iterrows():
        lines.append(f"| {r['elevation']:.3f} | {r['quantity']} | {r['measured_mean']:.1f} ± "
                     f"{r['measured_sd']:.1f} | {r['plane']:.1f} | {r['body_model']:.1f} |")
    lines.append("")
    for s, t in ((0.0, np.pi / 4), (np.pi / 8, np.pi / 4)):
        tab = orientation_table(ds, s, t, max_pairs=args.pairs, framing=framing,
                                distance=dist)
        tab.to_csv(args.out / f"orientations_{s:.3f}.csv", index=False)
        lines += [f"## Gradient orientations, {s:.3f} → {t:.3f} rad (median |error|, degrees)",
                  "", "| prediction | pixels | n | median | mean |", "|---|---|---|---|---|"]
        for _, r in tab.iterrows():
            lines.append(f"| {r['prediction']} | {r['pixels']} | {r['n']} | "
                         f"{r['median_error_deg']:.1f} | {r['mean_error_deg']:.1f} |")
        lines.append("")
    if args.results is not None:
        sc = pd.read_parquet(args.results / "scores.parquet")
        for det in sorted(sc["detector"].unique()):
            sh = score_shift_table(sc, det)
            sh.to_csv(args.out / f"score_shift_{det}.csv", index=False)
            lines += [f"## Score shifts, {det}, 0 → π/4", "",
                      "| method | persons' mean | top-1 % background mean | margin |",
                      "|---|---|---|---|"]
            for _, r in sh.iterrows():
                lines.append(f"| {r['method']} | {r['persons_mean']:+.3f} | "
                             f"{r['top1pct_background_mean']:+.3f} | {r['margin']:+.3f} |")
            lines.append("")
    (args.out / "decomposition.md").write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
