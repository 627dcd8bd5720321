"""One-off: the covariant (and eq. (3)) orientation maps mean-preserving (each cell's mean kept, its deviation mapped), scored in
sweep_decomposition's sweep beside the plain ones.

    python mean_kept.py RECIPE DATA OUT CACHE     (RECIPE: a recipe name, or camera_<group> of effects_ablation)
"""
import sys
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

import benchmark.recipes as R
import benchmark.studies.sweep_decomposition as sd
from viewadapt.adapt import hog_remap_matrix
from viewadapt.camera.effects import SURVEILLANCE_CAMERA as CAM, CameraEffects
from viewadapt.geometry import WINDOW_HEIGHT, WINDOW_WIDTH, elevation_homography, homography_jacobian
from viewadapt.remap import CellGrid, assemble_remap_matrix, orientation_remap_matrix

GROUPS = {"noise": dict(noise_sigma=CAM.noise_sigma)}


def balance(A):
    """Each cell's mean kept, its deviation from the mean mapped by A: A + (1 - A 1) 1^T / B."""
    B = A.shape[-1]
    return A + (1.0 - A.sum(-1, keepdims=True)) / B


def balanced_blocks(H_st, rule):
    grid = CellGrid.for_window(WINDOW_WIDTH, WINDOW_HEIGHT, 8)
    A = orientation_remap_matrix(homography_jacobian(H_st, grid.centers()), 9, rule)
    A = balance(A)
    return assemble_remap_matrix(sp.identity(grid.n_cells, format="csr"), A, n_bins=9)


def methods(e, truth, cfg):
    H = lambda x: elevation_homography(0.0, x, distance=cfg.distance, framing=cfg.framing)
    He, Ht = H(e), H(truth)
    S = lambda h: hog_remap_matrix(h, target_cell_size=cfg.target_cell_size, rule="none")
    out = sd._methods_plain(e, truth, cfg)
    for rule, name in (("covariant", "covariant"), ("paper", "eq. (3)")):
        if e == 0.0:
            out[f"{name} balanced: S true, A estimated"] = S(Ht)
            out[f"{name} balanced: G(e, e)"] = S(He)
            continue
        out[f"{name} balanced: S true, A estimated"] = (balanced_blocks(He, rule) @ S(Ht)).tocsr()
        out[f"{name} balanced: G(e, e)"] = (balanced_blocks(He, rule) @ S(He)).tocsr()
    return out


recipe, data, out, cache = sys.argv[1:5]
if recipe.startswith("camera_"):
    g = recipe.split("_", 1)[1]
    rec = replace(R.get_recipe("camera"), name=recipe, camera=CameraEffects(**GROUPS[g]),
                  summary=f"as rotated, the training windows through the camera recipe's {g} only")
    orig = R.get_recipe
    R.get_recipe = lambda n: rec if n == recipe else orig(n)
    R.RECIPES = dict(R.RECIPES, **{recipe: rec})
sd._methods_plain = sd._methods
sd._methods = methods
sys.exit(sd.main(["--data", data, "--out", out, "--cache", cache, "--recipe", recipe, "--jobs", "2"]))
