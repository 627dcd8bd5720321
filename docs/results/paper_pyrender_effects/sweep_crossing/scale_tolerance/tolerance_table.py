"""One-off: the source detector's miss rate on its own view's persons scaled vertically.

``python tolerance_table.py RENDERED_RUN K=RUN ... [--control LABEL=RUN] [--png FILE]
[--pair LABEL_A LABEL_B ...]``: each RUN a
``bench crossval --sources 0`` on a ``scaled_positives.py`` dataset (RENDERED_RUN: the same
on the render itself, its pi/4 persons as rendered). Prints the ``unadapted`` miss rate at
1e-2 FPPW per scale with 95 % intervals over the test persons, the paired difference of
each stretch ``K > 1`` against the compression ``1/K``, and of each row against the
rendered pi/4 persons (one bootstrap draw of persons for every row); ``--png``: the miss
rate against K, drawn; ``--pair``: also the paired difference B - A of two rows (any
labels, e.g. ``composited_positives.py``'s runs given with ``--control``). Checks first
that every run scored the same negatives alike (the same fold models)."""
import sys

import numpy as np
import pandas as pd

from benchmark.studies.sweep_intervals import bootstrap_miss_rates, person_hits

args = sys.argv[1:]
png, pairs = None, []
if "--png" in args:
    i = args.index("--png")
    png, args = args[i + 1], args[:i] + args[i + 2:]
while "--pair" in args:
    i = args.index("--pair")
    pairs.append((args[i + 1], args[i + 2]))
    args = args[:i] + args[i + 3:]
runs = {"rendered pi/4": args[0]}
for a in args[1:]:
    if a == "--control":
        continue
    label, run = a.split("=", 1)
    runs[label] = run
parts, neg = [], None
for label, run in runs.items():
    d = pd.read_parquet(f"{run}/scores.parquet")
    d = d[(d.method == "unadapted") & (d.source_elevation == 0)].copy()
    n = d[d.label == 0].sort_values(["path", "x", "y"])["score"].to_numpy()
    if neg is None:
        neg = n
    assert len(n) == len(neg) and np.allclose(n, neg, rtol=0, atol=1e-9), label
    d["method"], d["estimate"] = label, np.nan
    parts.append(d)
keys, persons, hits, counts = person_hits(pd.concat(parts, ignore_index=True), 1e-2)
mr = bootstrap_miss_rates(hits, counts, 1000, np.random.default_rng(0))
names = [k[0] for k in keys]


def ci(v):
    lo, hi = np.percentile(v[1:], [2.5, 97.5])
    return f"{v[0]:.3f} ({lo:.3f}–{hi:.3f})" if abs(v[0]) < 10 else "-"


def diff(v):
    lo, hi = np.percentile(v[1:], [2.5, 97.5])
    return f"{v[0]:+.3f} ({lo:+.3f}…{hi:+.3f})"


print(f"{len(persons)} test persons, 1000 bootstrap draws of them; the same negatives "
      f"({len(neg)} windows) and fold models in every run\n")
print("| pi/4 test persons | k | log k | unadapted miss at 1e-2 FPPW | minus rendered pi/4 |")
print("|---|---|---|---|---|")
r0 = names.index("rendered pi/4")
for i, name in enumerate(names):
    try:
        k = float(name)
        desc = f"elevation-0 persons x {k:g} vertically" if k != 1 else "elevation-0 persons"
        kk = f"{k:g} | {np.log(k):+.3f}"
    except ValueError:
        desc, kk = name, "| "
    print(f"| {desc} | {kk} | {ci(mr[:, i])} | "
          f"{diff(mr[:, i] - mr[:, r0]) if i != r0 else ''} |")
print("\n| stretch k | compression 1/k | miss(k) - miss(1/k) |\n|---|---|---|")
for i, name in enumerate(names):
    try:
        k = float(name)
    except ValueError:
        continue
    for j, other in enumerate(names):
        try:
            if k > 1 and abs(float(other) * k - 1) < 0.01:
                print(f"| {k:g} | {float(other):g} | {diff(mr[:, i] - mr[:, j])} |")
        except ValueError:
            pass
if pairs:
    print("\n| A | B | miss(B) - miss(A) |\n|---|---|---|")
    for a, b in pairs:
        print(f"| {a} | {b} | {diff(mr[:, names.index(b)] - mr[:, names.index(a)])} |")

if png:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ks = sorted((float(n), i) for i, n in enumerate(names) if n.replace(".", "", 1).isdigit())
    x = np.array([k for k, _ in ks])
    lo, hi = (np.percentile(mr[1:, [i for _, i in ks]], q, axis=0) for q in (2.5, 97.5))
    y = mr[0, [i for _, i in ks]]
    fig, ax = plt.subplots(figsize=(6, 3.6))
    ax.errorbar(x, y, yerr=[y - lo, hi - y], fmt="o-", capsize=3,
                label="elevation-0 persons scaled vertically by k")
    ax.axhline(mr[0, r0], color="C3", ls="--",
               label=f"rendered pi/4 persons, unadapted ({mr[0, r0]:.3f})")
    ax.axvline(0.789, color="0.5", ls=":", label="rendered body's extent at pi/4 (0.789)")
    ax.set_xscale("log")
    ax.set_xticks(x, [f"{k:g}" for k in x])
    ax.minorticks_off()
    ax.set_xlabel("vertical scale k (log axis; < 1 compressed, > 1 stretched)")
    ax.set_ylabel("miss rate at 1e-2 FPPW")
    ax.set_title("Source HOG/SVM (elevation 0), seed-1 effects render, 68 test persons",
                 fontsize=9)
    ax.legend(fontsize=7, loc="upper center")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
