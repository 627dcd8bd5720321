"""One-off (docs/training.md point 60): which approximation makes the covariant A turn
gradients differently from a warp. Over target-view windows (persons, background windows):
(a) warp: the window warped by H(0 -> e) (bilinear), gradients on the warped image, each
    voting bilinearly into 9 unsigned bins;
(b) pixel map: gradients on the target image, each angle mapped exactly by the covariant rule
    (J^T at its source point), then voting bilinearly -- A's physics without its bins;
(c) box A: gradients on the target image voting bilinearly into target bins, each pixel's
    two votes then moved by the covariant orientation_remap_matrix (A's box model of a bin).
Energy shares per bin, summed over all windows (magnitudes unchanged in (b) and (c), as A).
If (b) ~ (a) and (c) differs, A's binning is the cause; if (b) ~ (c), the gradients' resolution.
(d), added after that run to test its reading: the source-view gradient taken on the target
image by central differences at the source's pixel spacing (the target sampled bilinearly at
q +- J e_x and q +- J e_y, J = d target / d source), each target pixel weighted by the source
area it stands for, 1 / det J; no angle map.

    python binning_test.py DATA
"""
import sys

import cv2
import numpy as np

from viewadapt.geometry import elevation_homography, homography_jacobian
from viewadapt.remap import map_angles, orientation_remap_matrix
from benchmark.data import load_dataset, read_image

B = 9
C = (np.arange(B) + 0.5) * np.pi / B


def grads(gray):
    gx = cv2.Sobel(gray, cv2.CV_64F, 1, 0, ksize=1)
    gy = cv2.Sobel(gray, cv2.CV_64F, 0, 1, ksize=1)
    return np.hypot(gx, gy), np.mod(np.arctan2(gy, gx), np.pi)


def votes(theta):
    """(N, B) bilinear votes of unsigned angles between the two nearest bin centres."""
    t = theta / (np.pi / B) - 0.5
    b0 = np.floor(t).astype(int)
    f = t - b0
    V = np.zeros((len(theta), B))
    V[np.arange(len(t)), np.mod(b0, B)] += 1 - f
    V[np.arange(len(t)), np.mod(b0 + 1, B)] += f
    return V


def shares(v):
    return v / v.sum()


def main():
    ds = load_dataset(sys.argv[1])
    et = ds.elevation_index(np.pi / 4)
    p = ds.persons
    paths = list(p[p["elevation_index"] == et]["path"])
    b = ds.backgrounds
    bpaths = list(b[b["elevation_index"] == et]["path"])
    windows = {"persons": [], "backgrounds": []}
    for rel in paths:
        windows["persons"].append(cv2.cvtColor(read_image(ds.root / rel), cv2.COLOR_RGB2GRAY))
    for rel in bpaths:
        img = cv2.cvtColor(read_image(ds.root / rel), cv2.COLOR_RGB2GRAY)
        for y in range(0, img.shape[0] - 128 + 1, 32):
            for x in range(0, img.shape[1] - 64 + 1, 32):
                windows["backgrounds"].append(img[y:y + 128, x:x + 64])
    ys, xs = np.mgrid[0:128, 0:64].astype(np.float64)
    for e in (np.pi / 4, 1.0):
        H = elevation_homography(0.0, e)
        Hi = np.linalg.inv(H)
        # each target pixel's source point and the Jacobian there
        q = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], 0)
        ps = Hi @ q
        ps = (ps[:2] / ps[2]).T
        J = homography_jacobian(H, ps)                     # d target / d source
        A = orientation_remap_matrix(J, B, "covariant")    # (N, out, in)
        inside = (ps[:, 0] >= -0.5) & (ps[:, 0] < 63.5) & (ps[:, 1] >= -0.5) & (ps[:, 1] < 127.5)
        for name, wins in windows.items():
            a = np.zeros(B); bb = np.zeros(B); c = np.zeros(B); none = np.zeros(B)
            d = np.zeros(B)
            qx, qy = xs.ravel()[inside], ys.ravel()[inside]
            Ji = J[inside]
            wdet = 1.0 / np.linalg.det(Ji)
            for w in wins:
                g = w.astype(np.float64)
                warped = cv2.warpPerspective(g, H, (64, 128), flags=cv2.INTER_LINEAR
                                             | cv2.WARP_INVERSE_MAP,
                                             borderMode=cv2.BORDER_REPLICATE)
                m, th = grads(warped)
                a += (votes(th.ravel()) * m.ravel()[:, None]).sum(0)
                m, th = grads(g)
                m, th = m.ravel()[inside], th.ravel()[inside]
                mapped = map_angles(th, J[inside], "covariant")
                bb += (votes(mapped) * m[:, None]).sum(0)
                vt = votes(th) * m[:, None]
                c += np.einsum("nij,nj->i", A[inside], vt)
                none += vt.sum(0)
                gs = []
                for k in (0, 1):                     # source axis x, then y
                    dx, dy = Ji[:, 0, k], Ji[:, 1, k]
                    plus = cv2.remap(g, (qx + dx).reshape(-1, 1).astype(np.float32),
                                     (qy + dy).reshape(-1, 1).astype(np.float32),
                                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
                    minus = cv2.remap(g, (qx - dx).reshape(-1, 1).astype(np.float32),
                                      (qy - dy).reshape(-1, 1).astype(np.float32),
                                      cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
                    gs.append((plus - minus).ravel())
                md = np.hypot(gs[0], gs[1]) * wdet
                d += (votes(np.mod(np.arctan2(gs[1], gs[0]), np.pi)) * md[:, None]).sum(0)
            f = lambda v: " ".join(f"{x:.3f}" for x in shares(v))
            print(f"{name} e={e:.3f}\n  (a) warp      {f(a)}\n  (b) pixel map {f(bb)}\n"
                  f"  (c) box A     {f(c)}\n  (d) source-spaced differences {f(d)}\n"
                  f"  none          {f(none)}", flush=True)


if __name__ == "__main__":
    main()
