"""One-off: LAMR of saved `bench footage` detections, paired with another run's (10-frame
block bootstrap, as bench footage pairs). argv: A/detections.json method_a
B/detections.json method_b"""
import json, sys
from pathlib import Path

import numpy as np

from benchmark.footage.run import open_clip
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap

D = Path("../shared/data/pets09_s2l1_view001")
clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json")
size = clip.camera.image_size
a = json.loads(Path(sys.argv[1]).read_text())[sys.argv[2]]
b = json.loads(Path(sys.argv[3]).read_text())[sys.argv[4]]
frames = list(clip.stream)
truth = [clip.truth_of(f) for f in frames]
keys = [str(f.source) if clip.stream.paths is not None else str(f.index) for f in frames]
ma, _ = evaluation_matches([np.asarray(a[k], float).reshape(-1, 5) for k in keys], truth, size,
                           regions=clip.regions)
mb, _ = evaluation_matches([np.asarray(b[k], float).reshape(-1, 5) for k in keys], truth, size,
                           regions=clip.regions)
d = paired_groups_bootstrap([ma], [mb], block=10)
print(json.dumps(dict(a=matches_lamr(ma), b=matches_lamr(mb), a_minus_b=d)))
