"""Power-law scaling of the ACF gradient channels between frame and canonical resolution.

    python -m benchmark.studies.acf_scaling --data DIR [--windows 40] [--seed 0]

The adapted ACF operator reads channels computed on the frame at its native resolution,
where a window's person is ``s`` frame pixels per canonical pixel (``s < 1`` for all but
the nearest persons). Colour channels are intensive and do not change with ``s``; the
normalised gradient magnitude and orientation channels do, following the power law of
Dollár et al. (2014, "Fast Feature Pyramids"): ``f(frame) ~ f(canonical) * s ** -lambda``.

This script measures ``lambda`` without labels: random candidate windows of every frame
of a dataset, for each the sum of the remapped gradient channels (``G x`` from the frame's
channels, no scaling) over the sum of the same channels of the window warped to 64x128
(what image warping computes), and a least-squares line through ``log ratio`` against
``log s``. The slope's negative is ``viewadapt.detect.ACF_GRADIENT_LAMBDA``. Not a test.
"""

from __future__ import annotations

import argparse

import numpy as np


def measure(data, *, windows_per_frame: int = 40, seed: int = 0, heights=(1.75,)):
    """Returns (scales, ratios) over random candidate windows of the dataset's frames."""
    from benchmark.frames.methods import load_frames
    from viewadapt.detect import (
        ACF_SHRINK, CELLS_PER_SOURCE_CELL, FRAME_CELL_SIZES, TemplateGroup, acf_frame_features,
        acf_frame_remap, acf_window_features, choose_cell_sizes, select_candidate_windows,
    )
    from viewadapt.warp import warp_to_source_view

    rng = np.random.default_rng(seed)
    scales, ratios = [], []
    for f in load_frames(data):
        img = f.image()
        win = select_candidate_windows(f.camera, f.camera.image_size, person_heights=heights)
        idx = rng.choice(len(win), min(windows_per_frame, len(win)), replace=False)
        cells = choose_cell_sizes(win.scale[idx], ACF_SHRINK,
                                  cells_per_source_cell=CELLS_PER_SOURCE_CELL,
                                  allowed=FRAME_CELL_SIZES)
        maps = acf_frame_features(img, sorted(set(cells.tolist())), pad=0).maps
        for n, c in zip(idx, cells):
            H = win.homographies[n]
            warped = acf_window_features(warp_to_source_view(img, H)).astype(np.float64)
            x = maps[int(c)]
            g = TemplateGroup(int(c), 0, (0, 0), x.shape[:2], np.array([0]), np.zeros((1, 2), int))
            remapped = (acf_frame_remap(H, g, "covariant") @ x.astype(np.float64).ravel())
            remapped = remapped.reshape(warped.shape)
            if warped[3:].sum() > 1e-3:                  # skip textureless windows
                scales.append(win.scale[n])
                ratios.append(remapped[3:].sum() / warped[3:].sum())
    return np.array(scales), np.array(ratios)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="dataset directory with frames_coco.json")
    p.add_argument("--windows", type=int, default=40, help="random windows per frame")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    from viewadapt.detect import ACF_GRADIENT_LAMBDA

    s, r = measure(a.data, windows_per_frame=a.windows, seed=a.seed)
    if len(s) < 10 or np.ptp(np.log(s)) < 0.3:
        print(f"too few windows or scales to fit ({len(s)} windows)")
        return 1
    lam = -np.polyfit(np.log(s), np.log(r), 1)[0]
    print(f"{len(s)} windows, s = {s.min():.2f}..{s.max():.2f}: lambda = {lam:.3f} "
          f"(viewadapt.detect.ACF_GRADIENT_LAMBDA = {ACF_GRADIENT_LAMBDA})")
    print("  s range      windows  median ratio  s ** -lambda")
    for lo, hi in ((0, .3), (.3, .45), (.45, .6), (.6, .8), (.8, np.inf)):
        m = (s >= lo) & (s < hi)
        if m.any():
            print(f"  {lo:.2f}-{hi:.2f}  {m.sum():9d}  {np.median(r[m]):12.3f}  "
                  f"{np.median(s[m]) ** -lam:12.3f}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
