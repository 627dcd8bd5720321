import numpy as np
from pathlib import Path
from viewadapt.io import SourceDetectors
from viewadapt.boosting import AdaBoostTrees
g = SourceDetectors.load(Path("/tmp/s10/gated.npz"))
params, arr = g.acf.to_arrays()
n = g.acf.n_estimators_; k = 18; L = n // k
# gated order: member0's L trees, then the other 17 round-robin; make member-major
idx = list(range(L))
rest = np.arange(L, n).reshape(L, k - 1)          # rows: rounds, cols: members 1..17
for j in range(k - 1):
    idx += list(rest[:, j])
idx = np.array(idx)
out = {key: arr[key][idx] for key in ("feature_", "threshold_", "value_", "train_loss_")}
out["classes_"] = arr["classes_"]
out["cascade_scale_"] = np.repeat(k / np.arange(1, k + 1), L)
m = AdaBoostTrees.from_arrays(params, out)
s = SourceDetectors(g.hog_weights, g.hog_bias, m, training=dict(g.training, acf_gate="sequential"))
s.save(Path("/tmp/s10/seq.npz"))
X = np.random.default_rng(0).random((500, m.n_features_in_))
import copy
a = copy.deepcopy(m); a.cascade_threshold = None; b = copy.deepcopy(g.acf); b.cascade_threshold = None
print(np.abs(a.decision_function(X) - b.decision_function(X)).max())
