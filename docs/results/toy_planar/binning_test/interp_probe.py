"""One-off (docs/training.md point 60): the warp's orientation energy shares (0, 90, 180-degree
bins) with bilinear, bicubic, Lanczos and nearest-neighbour interpolation.

    python interp_probe.py DATA
"""
import sys
from pathlib import Path

import cv2
import numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parent))
from binning_test import grads, votes, shares
from viewadapt.geometry import elevation_homography
from benchmark.data import load_dataset, read_image
ds = load_dataset(sys.argv[1]); et = ds.elevation_index(np.pi / 4)
p = ds.persons; b = ds.backgrounds
wins = {"persons": [cv2.cvtColor(read_image(ds.root / r), cv2.COLOR_RGB2GRAY) for r in p[p.elevation_index == et].path], "backgrounds": []}
for r in b[b.elevation_index == et].path:
    img = cv2.cvtColor(read_image(ds.root / r), cv2.COLOR_RGB2GRAY)
    for y in range(0, img.shape[0] - 127, 32):
        for x in range(0, img.shape[1] - 63, 32):
            wins["backgrounds"].append(img[y:y + 128, x:x + 64])
for e in (np.pi / 4, 1.0):
    H = elevation_homography(0.0, e)
    for name, ws in wins.items():
        out = []
        for interp in (cv2.INTER_LINEAR, cv2.INTER_CUBIC, cv2.INTER_LANCZOS4, cv2.INTER_NEAREST):
            acc = np.zeros(9)
            for w in ws:
                g = w.astype(np.float64)
                wp = cv2.warpPerspective(g, H, (64, 128), flags=interp | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE)
                m, th = grads(wp)
                acc += (votes(th.ravel()) * m.ravel()[:, None]).sum(0)
            s = shares(acc)
            out.append(f"{s[0]:.3f}/{s[4]:.3f}/{s[8]:.3f}")
        print(f"{name} e={e:.3f} linear {out[0]} cubic {out[1]} lanczos {out[2]} nearest {out[3]}", flush=True)
