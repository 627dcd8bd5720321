"""One-off: what box voting does to adapted HOG and to image warping of the same model on
PETS, paired: voted - plain of each method, and adapted - warping under each setting, each
with the paired 10-frame block bootstrap (viewadapt.detect.evaluation.paired_groups_bootstrap).
argv: OUT.json PLAIN_detections.json VOTED_detections.json (each holding hog_adapted and
hog_warp, from `viewadapt bench footage --methods hog_adapted hog_warp --box-voting 0 / 1`)"""
import json, sys
from pathlib import Path

from benchmark.footage.run import open_clip, stored_detections
from viewadapt.detect.evaluation import evaluation_matches, matches_lamr, paired_groups_bootstrap

D = Path("../shared/data/pets09_s2l1_view001")
clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json")
size = clip.camera.image_size
matches = {}
for setting, path in (("plain", sys.argv[2]), ("voted", sys.argv[3])):
    d = json.loads(Path(path).read_text())
    keys = list(d["hog_adapted"])                   # the run's frames, in its order
    truth = clip.stored_truth(keys)
    for m in ("hog_adapted", "hog_warp"):
        matches[setting, m] = evaluation_matches(stored_detections(d[m], keys), truth, size,
                                                 regions=clip.regions)[0]
res = {f"{s} {m}": matches_lamr(v) for (s, m), v in matches.items()}
for m in ("hog_adapted", "hog_warp"):
    res[f"{m}: voted - plain"] = paired_groups_bootstrap([matches["voted", m]],
                                                         [matches["plain", m]], block=10)
for s in ("plain", "voted"):
    res[f"{s}: adapted - warping"] = paired_groups_bootstrap([matches[s, "hog_adapted"]],
                                                             [matches[s, "hog_warp"]], block=10)
for k, v in res.items():
    print(k, v, flush=True)
Path(sys.argv[1]).write_text(json.dumps(res, indent=1))
