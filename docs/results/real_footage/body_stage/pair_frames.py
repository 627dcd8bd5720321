"""One-off: paired LAMR differences of saved `bench frames` detections (bootstrap over
frames, benchmark.frames.phases). argv: DATA A/detections.json method_a B/detections.json
method_b"""
import json, sys
from pathlib import Path

import numpy as np

from benchmark.frames.methods import load_frames
from benchmark.frames.phases import frame_matches, matches_lamr, paired_lamr_difference

frames = load_frames(sys.argv[1])
keys = [f"{f.path.name}@{f.scene_id}" for f in frames]
a, b = (json.loads(Path(p).read_text())[m] for p, m in (sys.argv[2:4], sys.argv[4:6]))
da = [np.asarray(a[k], float).reshape(-1, 5) for k in keys]
db = [np.asarray(b[k], float).reshape(-1, 5) for k in keys]
d = paired_lamr_difference(da, db, frames, n_boot=1000, rng=np.random.default_rng(0))
print(json.dumps(dict(a=matches_lamr(frame_matches(da, frames)),
                      b=matches_lamr(frame_matches(db, frames)), a_minus_b=d)))
