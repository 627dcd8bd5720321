"""One-off: how closely the HOG stage's window scores follow image warping's, per window,
on frames of a clip (no labels read). argv: out.json variant [variant ...];
variant = rho (raw cells per source cell)."""
import json, sys, time
from pathlib import Path
import numpy as np
import viewadapt.detect.renorm as renorm
from benchmark.footage.run import open_clip
from benchmark.frames.methods import FrameMethods, warp_scores
from benchmark.frames.spec import FrameMethod
from viewadapt.io import SourceDetectors
D = Path("../shared/data/pets09_s2l1_view001")
models = SourceDetectors.load(Path("viewadapt/data/source_detectors.npz"))
frames = None
res = {}
for v in sys.argv[2:]:
    renorm.RENORM_CELLS_PER_SOURCE_CELL = float(v)
    clip = open_clip([D / "img1"], D / "calibration/View_001.xml", D / "gt/gt.txt", D / "ignore.json", every=15)
    fm = FrameMethods(clip.camera, models, person_heights=(1.75,), lens=np.asarray(clip.dist).tolist())
    m = FrameMethod.parse("hog_adapted"); fm.prepare(m)
    op = fm.adapted.operator("hog")
    H = fm.windows.homographies
    allw, alls, allf, allsc = [], [], [], []
    for i, fr in enumerate(clip.stream):
        img = fr.image
        feats = op.frame_features(img)
        fold = np.empty(op.n_windows); where = {}
        for li, (layer, ft) in enumerate(zip(op.layers, feats)):
            fold[layer.index] = layer.operator.fold_scores(ft)
            for j, g in enumerate(layer.index):
                where[g] = (li, j)
        rng = np.random.default_rng(i)
        idx = np.union1d(np.argsort(fold)[-300:], rng.choice(len(fold), 300, replace=False))
        st = np.empty(len(idx))
        for li, (layer, ft) in enumerate(zip(op.layers, feats)):
            sel = [k for k, g in enumerate(idx) if where[g][0] == li]
            if sel:
                st[sel] = layer.operator.stage.scores(np.array([where[idx[k]][1] for k in sel]), ft.raw)
        w = warp_scores(img, H[idx], models, "hog")
        allw.append(w); alls.append(st); allf.append(fold[idx]); allsc.append(fm.windows.scale[idx])
    w, s, f = map(np.concatenate, (allw, alls, allf))
    top = w > np.quantile(w, 0.5)
    res[v] = dict(n=len(w), r_stage=float(np.corrcoef(w, s)[0, 1]), r_fold=float(np.corrcoef(w, f)[0, 1]),
                  r_stage_top=float(np.corrcoef(w[top], s[top])[0, 1]),
                  mad_stage=float(np.mean(np.abs(w - s))), bias=float(np.mean(s - w)))
    print(v, res[v], flush=True)
    np.savez(f'/tmp/s10/fid_{v}.npz', w=w, s=s, f=f, sc=np.concatenate(allsc))
Path(sys.argv[1]).write_text(json.dumps(res, indent=1))
