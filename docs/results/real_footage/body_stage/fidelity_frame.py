"""One-off: the HOG stage and fold with the body and the plane against image warping with
each (out(p) = frame(mapping(p)), hidden points read on the plane), window by window on
one rendered frame of the paper preset (150 top windows of the plane stage, 250 random).
argv: frame index. Output: fidelity_frame.txt."""
import sys, numpy as np, cv2
from benchmark.frames.methods import load_frames
from viewadapt.detect import select_candidate_windows, build_adapted_linear_operator, hog_window_features
from viewadapt.detect.frame_remap import window_mapping, resolve_object_model
from viewadapt.io import SourceDetectors, shipped_model_path

frames = load_frames('/tmp/exp/ds104')
fr = frames[int(sys.argv[1]) if len(sys.argv) > 1 else 0]
img = cv2.imread(str(fr.path))
gray = img
models = SourceDetectors.load(shipped_model_path())
W, b = models.hog_weights, models.hog_bias
win = select_candidate_windows(fr.camera)
print("windows", len(win.homographies))
ops = {}
for name, om, rn in [("plane_stage", "plane", True), ("body_stage", "body", True), ("body_fold", "body", False), ("plane_fold", "plane", False)]:
    ops[name] = build_adapted_linear_operator(win, W, b, renorm=rn, object_model=om, verify_threshold=-1e9)
sc = {k: op.scores(op.frame_features(img)) for k, op in ops.items()}
R = ops["body_stage"].stage.cell_maps
print("maps", R.shape, "NaN cells frac", np.isnan(R[..., 0]).mean())
ys, xs = np.mgrid[0:16, 0:8]
c0 = np.stack([8.0 * xs + 3.5, 8.0 * ys + 3.5], -1)
dd = np.linalg.norm(R[..., :2] - c0, axis=-1)
print("displacement px median/90%/max", np.nanmedian(dd), np.nanpercentile(dd, 90), np.nanmax(dd))
print("J diag median", np.nanmedian(R[..., 2]), np.nanmedian(R[..., 5]), "offdiag", np.nanmedian(np.abs(R[..., 3])), np.nanmedian(np.abs(R[..., 4])))
rng = np.random.default_rng(0)
top = np.argsort(-sc["plane_stage"])[:150]
idx = np.unique(np.concatenate([top, rng.choice(len(win.homographies), 250, replace=False)]))
model = resolve_object_model("body")
gy, gx = np.mgrid[0:128, 0:64].astype(np.float64)
pts = np.stack([gx, gy], -1).reshape(-1, 2)
warp = {"body": [], "plane": []}
for n in idx:
    Hn = np.asarray(window_mapping(win, n, "plane"))
    q = np.c_[pts, np.ones(len(pts))] @ Hn.T
    pp = q[:, :2] / q[:, 2:]
    for om in ("body", "plane"):
        p = window_mapping(win, n, model)(pts) if om == "body" else pp
        p = np.where(np.isfinite(p), p, pp).reshape(128, 64, 2).astype(np.float32)
        crop = cv2.remap(img, p[..., 0], p[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        warp[om].append(float((hog_window_features(crop) * W).sum() + b))
for om in warp:
    warp[om] = np.array(warp[om])
for k in sc:
    print(k, "corr with body warp %.3f, with plane warp %.3f" % (np.corrcoef(sc[k][idx], warp["body"])[0, 1], np.corrcoef(sc[k][idx], warp["plane"])[0, 1]))
print("body warp vs plane warp %.3f" % np.corrcoef(warp["body"], warp["plane"])[0, 1])
