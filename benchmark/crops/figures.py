"""Figures: HOG glyphs, the remapping illustration (like the paper's Fig. 4), fidelity bars."""

from __future__ import annotations

import numpy as np

__all__ = ["render_hog", "plot_remap_illustration", "plot_fidelity", "save_figure"]


def render_hog(cells, *, cell_px: int = 16, gain: float | None = None) -> np.ndarray:
    """Draw HOG cell histograms as glyphs: one line per bin along the *edge* direction.

    Parameters
    ----------
    cells : (n_y, n_x, B) ndarray
    cell_px : int
        Glyph size in pixels.
    gain : float, optional
        Brightness scale; default normalises by the 99th percentile of ``cells``.

    Returns
    -------
    (n_y cell_px, n_x cell_px) float ndarray in [0, 1].
    """
    import cv2

    C = np.asarray(cells, dtype=np.float64)
    ny, nx, B = C.shape
    if gain is None:
        p = np.percentile(C, 99)
        gain = 1.0 / p if p > 0 else 1.0
    out = np.zeros((ny * cell_px, nx * cell_px), np.float32)
    r = cell_px / 2 - 1
    for b in range(B):
        theta = (b + 0.5) * np.pi / B + np.pi / 2       # edge is perpendicular to gradient
        dx, dy = r * np.cos(theta), r * np.sin(theta)
        layer = np.zeros_like(out)
        for i in range(ny):
            for j in range(nx):
                v = float(min(C[i, j, b] * gain, 1.0))
                if v <= 0:
                    continue
                cx, cy = (j + 0.5) * cell_px, (i + 0.5) * cell_px
                cv2.line(layer, (int(round(cx - dx)), int(round(cy - dy))),
                         (int(round(cx + dx)), int(round(cy + dy))), v, 1, cv2.LINE_AA)
        out = np.maximum(out, layer)
    return out


def save_figure(fig, path_stem) -> list:
    """Save ``fig`` as PNG and PDF next to each other; returns the paths."""
    paths = []
    for ext in ("png", "pdf"):
        p = f"{path_stem}.{ext}"
        fig.savefig(p, dpi=150, bbox_inches="tight")
        paths.append(p)
    return paths


def plot_remap_illustration(image, x, y, H_st, *, title=""):
    """The paper's Fig. 4 on one window: image, HOG, remapped HOG, warped image, its HOG.

    Parameters
    ----------
    image : (M, N[, 3]) uint8 ndarray, the target-view image.
    x, y : int, top-left pixel of the 64x128 target window in ``image``.
    H_st : (3, 3) ndarray, source window -> target window.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from viewadapt.adapt import hog_remap_matrix
    from viewadapt.hog import hog_cells
    from viewadapt.warp import translation, warp_to_source_view

    target = np.ascontiguousarray(image[y:y + 128, x:x + 64])
    warped = warp_to_source_view(image, translation(x, y) @ H_st)
    cells_t = hog_cells(target)
    G = hog_remap_matrix(H_st, target_cell_size=4)
    remapped = (G @ hog_cells(target, cell_size=4).ravel()).reshape(16, 8, 9)
    cells_w = hog_cells(warped)
    gain = 1.0 / max(np.percentile(cells_w, 99), 1e-9)
    panels = [(target, "(a) target window"), (render_hog(cells_t, gain=gain), "(b) HOG"),
              (render_hog(remapped, gain=gain), "(c) remapped HOG, G x"),
              (warped, "(d) window warped\nto source view"),
              (render_hog(cells_w, gain=gain), "(e) HOG of warped")]
    fig, axes = plt.subplots(1, 5, figsize=(10, 4.4))
    for ax, (im, name) in zip(axes, panels):
        ax.imshow(im, cmap="gray" if im.ndim == 2 else None, interpolation="nearest")
        ax.set_title(name, fontsize=9)
        ax.axis("off")
    r = np.corrcoef(remapped.ravel(), cells_w.ravel())[0, 1]
    r0 = np.corrcoef(cells_t.ravel(), cells_w.ravel())[0, 1]
    fig.suptitle(f"{title}  corr(c, e) = {r:.3f}, corr(b, e) = {r0:.3f}", fontsize=10)
    return fig


def plot_fidelity(summary, *, target_cell_size: int = 8):
    """Median per-window correlation (bars) with the 10th percentile (whisker) per rule."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    feats = [f for f in ("hog_cells", "hog_blocks", "hog_local", "acf_gradient", "acf")
             if f in set(summary["feature"])]
    rules = ["unadapted", "none", "paper", "covariant"]
    colours = {"unadapted": "#999999", "none": "#88aadd", "paper": "#dd8844",
               "covariant": "#336633"}
    fig, axes = plt.subplots(1, len(feats), figsize=(3.2 * len(feats), 3.4), sharey=True)
    axes = np.atleast_1d(axes)
    for ax, feat in zip(axes, feats):
        d = summary[summary["feature"] == feat]
        pairs = d[["source_elevation", "target_elevation"]].drop_duplicates().to_numpy()
        width = 0.8 / len(rules)
        for i, rule in enumerate(rules):
            sel = d[(d["rule"] == rule) & (d["form"].isin(["per-cell", "-"]))]
            if feat.startswith("hog"):
                tc = 8 if rule == "unadapted" else target_cell_size
                sel = sel[sel["target_cell_size"] == tc]
            med, p10 = [], []
            for es, et in pairs:
                row = sel[(sel["source_elevation"] == es) & (sel["target_elevation"] == et)]
                med.append(float(row["median"].iloc[0]) if len(row) else np.nan)
                p10.append(float(row["p10"].iloc[0]) if len(row) else np.nan)
            xs = np.arange(len(pairs)) + (i - (len(rules) - 1) / 2) * width
            ax.bar(xs, med, width, color=colours[rule], label=rule)
            ax.errorbar(xs, med, yerr=[np.subtract(med, p10), np.zeros(len(med))],
                        fmt="none", ecolor="k", lw=0.8, capsize=2)
        ax.set_xticks(np.arange(len(pairs)))
        ax.set_xticklabels([f"{np.rad2deg(a):.1f}°→{np.rad2deg(b):.1f}°" for a, b in pairs],
                           fontsize=8)
        ax.axhline(0.9, color="k", ls=":", lw=0.8)
        ax.set_title(feat, fontsize=10)
        ax.set_ylim(0, 1)
    axes[0].set_ylabel("median per-window Pearson r\n(whisker: 10th percentile)")
    axes[-1].legend(fontsize=8, loc="lower right")
    fig.suptitle(f"Remap fidelity: G x_target vs features of the warped window "
                 f"(target cells {target_cell_size} px, per-cell A)", fontsize=10)
    fig.tight_layout()
    return fig
