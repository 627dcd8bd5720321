"""One-off: dsfx with its elevation-0 backgrounds replaced by the clean renders of ds (the negatives clean,
everything else through camera effects), for the decomposition."""
import json, os, shutil
from pathlib import Path
import numpy as np
import pandas as pd
ds, fx, out = Path("/tmp/exp/ds"), Path("/tmp/exp/dsfx"), Path("/tmp/exp/fx_cleanneg")
out.mkdir()
cfg = json.loads((fx / "dataset.json").read_text())
cfg["hybrid"] = "every image from the camera-effects render dsfx except the elevation-0 backgrounds, from ds (same renders)"
(out / "dataset.json").write_text(json.dumps(cfg, indent=1))
for f in ("manifest.parquet", "manifest.csv", "frames_coco.json"):
    shutil.copy(fx / f, out / f)
m = pd.read_parquet(fx / "manifest.parquet")
n_fx = 0
for p, e, k in zip(m["path"], m["elevation"], m["kind"]):
    src = (ds if (np.isclose(e, 0) and k == "background") else fx) / p
    n_fx += src.is_relative_to(fx)
    dst = out / p
    dst.parent.mkdir(parents=True, exist_ok=True)
    os.symlink(src, dst)
for d in ("depth", "frames"):
    if (fx / d).exists() and not (out / d).exists():
        os.symlink(fx / d, out / d)
print(len(m), "files,", n_fx, "from dsfx")
