"""One-off: a dataset with ds's clean renders at elevations 0 and pi/8 and dsfx's effects renders (the same
renders through camera effects) at pi/4, for the decomposition with test windows through effects only."""
import json, os, shutil
from pathlib import Path
import numpy as np
import pandas as pd
ds, fx, out = Path("/tmp/exp/ds"), Path("/tmp/exp/dsfx"), Path("/tmp/exp/ds_testfx")
out.mkdir()
cfg = json.loads((ds / "dataset.json").read_text())
cfg["hybrid"] = "elevation pi/4 images from the camera-effects render dsfx (same renders), others from ds"
(out / "dataset.json").write_text(json.dumps(cfg, indent=1))
for f in ("manifest.parquet", "manifest.csv", "frames_coco.json"):
    shutil.copy(ds / f, out / f)
m = pd.read_parquet(ds / "manifest.parquet")
n_fx = 0
for p, e in zip(m["path"], m["elevation"]):
    src = (fx if np.isclose(e, np.pi / 4) else ds) / p
    n_fx += src.is_relative_to(fx)
    dst = out / p
    dst.parent.mkdir(parents=True, exist_ok=True)
    os.symlink(src, dst)
for d in ("depth", "frames"):
    if (ds / d).exists() and not (out / d).exists():
        os.symlink(ds / d, out / d)
print(len(m), "files,", n_fx, "from dsfx")
