"""Remap fidelity 0 -> pi/4 at two crop-camera distances (docs/training.md point 67).

The findings' fidelity measure (benchmark.crops.fidelity: Pearson correlation between the
remapped target features G x and the features of the window warped into the source view,
scikit-image's natural images plus three synthetic pattern images, 20 windows each), the same
windows read with the plane homography of a 5 m and of a 10 m crop camera. Prints the mean
correlation per feature, rule, form and target cell size, and the difference 5 m - 10 m.

    python fidelity_distance.py > fidelity_distance.txt
"""
import numpy as np
import pandas as pd

from benchmark.crops.fidelity import remap_fidelity, sample_images, synthetic_images

imgs = sample_images() | synthetic_images(np.random.default_rng(0))
out = []
for d in (5.0, 10.0):
    df = remap_fidelity(imgs, pairs=((0.0, np.pi / 4),), windows_per_image=20, acf=False,
                        rng=np.random.default_rng(1), distance=d)
    out.append(df.assign(distance=d))
df = pd.concat(out)
t = df.groupby(["feature", "rule", "form", "target_cell_size", "distance"]).pearson.mean()
t = t.unstack()
t["5 m - 10 m"] = t[5.0] - t[10.0]
print(t.round(3).to_string())
