"""Nine-fold person/scene-disjoint cross-validation of viewpoint adaptation methods.

For each source elevation ``s`` and the target elevation ``t`` (Wang et al. 2017, Fig. 5),
each detector is trained on source-view crops (negatives: windows of the training scenes'
backgrounds at ``s``, with hard-negative mining) and tested on target-view crops of the
test persons in the test scenes, against target-view background windows of the test
scenes. Methods:

``unadapted``      the source detector as it is;
``adapted``        classifier adaptation through ``G = S (x) A`` (covariant angle rule,
                   per-cell ``A``, 4 px target cells by default) -- ``w' = G^T w`` for linear
                   models on cells, ``N(G x)`` for block-normalised HOG, ``G[used] x`` for trees;
``adapted[...]``   ablations: ``S only`` (no angle remapping), ``paper eq.3`` (literal rule),
                   ``single A`` (one ``A`` for the window, as in the paper);
``adapted[body]``  ``G`` through the mean-body object model instead of the person plane
                   (:mod:`viewadapt.objectmodel`; ``[body, S only]``, ``[body, paper eq.3]``
                   with the other angle rules);
``image warping``  every test window warped into the source view (Li et al. 2008);
                   ``image warping[body]`` through the mean-body model;
``exact geometry`` a diagnostic upper bound: each test *positive* adapted through ``G`` from
                   its own rendered correspondences (the generator's depth maps), the
                   negatives as ``adapted`` (``exact geometry[paper eq.3]``: the literal
                   rule on the exact Jacobians, negatives as ``adapted[paper eq.3]``);
``synthesised``    source training crops and negatives warped into the target view, retrained
                   (needs no target data either);
``oracle``         trained on the target view (the ``s == t`` row).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np
import pandas as pd

from viewadapt.geometry import elevation_homography
from viewadapt.objectmodel import correspondence_mapping, crop_view_mapping, object_model

from benchmark.data import (
    Dataset, DatasetError, manifest_camera, missing_planned_images, read_depth_map,
)
from benchmark.crops.detectors import detector_spec, feature_key
from benchmark.crops.features import FeatureCache, background_windows, person_windows
from benchmark.crops.folds import Fold, make_folds
from benchmark.recipes import DEFAULT_RECIPE, RECIPES, Recipe, get_recipe
from benchmark.frames.spec import OBJECT_MODEL_TAGS, RULE_TAGS, variant_label

__all__ = ["CrossvalConfig", "ADAPT_VARIANTS", "EXACT_VARIANTS", "run_crossval",
           "require_complete", "training_windows", "exact_geometry_wanted"]


def _adapt_variants() -> dict:
    out = {}
    for model in OBJECT_MODEL_TAGS:
        out.update({variant_label("adapted", rule, model): (rule, True, model)
                    for rule in RULE_TAGS})
        if model == "plane":
            out[variant_label("adapted", extra="single A")] = ("covariant", False, "plane")
    return out


#: method name -> (angle rule, per-cell A, object model): every object model with every
#: angle rule, named as the frames' adapted variants (:func:`benchmark.frames.spec.variant_label`,
#: e.g. ``adapted[body, paper eq.3]``), and ``adapted[single A]`` (one ``A`` per window)
ADAPT_VARIANTS = _adapt_variants()
#: variants every detector runs; those with ``ablations`` run all with ``cfg.ablations``
CORE_VARIANTS = ("adapted", "adapted[body]")
#: upper-bound rows -> (angle rule, the variant whose negatives they share)
EXACT_VARIANTS = {variant_label("exact geometry", rule): (rule, variant_label("adapted", rule))
                  for rule in ("covariant", "paper")}


def require_complete(ds: Dataset, *, allow_incomplete: bool = False) -> str | None:
    """Refuse (:class:`DatasetError`) a dataset whose manifest lacks images its
    ``dataset.json`` plans: its folds would silently miss persons or scenes. With
    ``allow_incomplete`` return the warning to print and record instead (None if complete).
    """
    gap = missing_planned_images(ds)
    if gap is None:
        return None
    missing, planned = gap
    msg = (f"{ds.root} is incomplete: {missing} of the {planned} images its dataset.json "
           "plans are missing (an unfinished or sharded `viewadapt generate`; rerun it "
           "with the same --out to finish)")
    if not allow_incomplete:
        raise DatasetError(msg + ", or pass --allow-incomplete to run on it anyway")
    return msg


def variant_names(spec, cfg) -> list:
    """The adapted variants a detector spec runs under ``cfg``."""
    names = [v for v in ADAPT_VARIANTS if cfg.ablations and spec.ablations
             or v in CORE_VARIANTS]
    return [v for v in names if ADAPT_VARIANTS[v][2] in cfg.object_models]


@dataclass
class CrossvalConfig:
    sources: tuple = (0.0, np.pi / 8, np.pi / 4)
    target: float = np.pi / 4
    detectors: tuple = ("hog", "hog_local", "acf", "opencv")
    ablations: bool = True
    synthesised: bool = True
    #: object models of the adapted and image-warping rows ("plane", "body")
    object_models: tuple = ("plane", "body")
    #: the exact-geometry rows (HOG detectors; needs the dataset's depth maps and the plane
    #: among ``object_models``: they share its adapted rows' negatives)
    upper_bound: bool = True
    target_cell_size: int = 4
    #: the SVMs' regularisation, unless the recipe sets its own (``Recipe.svm_c``)
    C: float = 0.01
    mining_rounds: int = 1
    initial_negatives: int = 5000
    max_hard_negatives: int = 5000
    acf_estimators: int = 256
    acf_stages: tuple = (32, 128, 256)
    # speed over the toolbox's defaults (256 bins, all features per tree): 64 quantile bins
    # and a random 1/8 of the features per tree train ~4x faster (benchmark/studies/core_speed.py)
    acf_max_bins: int = 64
    acf_max_features: float = 0.125
    bg_stride: int = 16
    distance: float = 10.0
    #: how the dataset's crops were framed ("plane" or "silhouette", from dataset.json):
    #: the homographies between elevations follow it (viewadapt.geometry.crop_homography)
    framing: str = "plane"
    seed: int = 0
    n_jobs: int = 1
    #: the source-training recipe (:mod:`benchmark.recipes`; a :class:`Recipe` or its name):
    #: every method that trains uses it
    recipe: Recipe = RECIPES[DEFAULT_RECIPE]
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        self.recipe = get_recipe(self.recipe)

    @classmethod
    def for_dataset(cls, ds, **settings) -> "CrossvalConfig":
        """The configuration for dataset ``ds``: its crop camera's ``distance`` and its
        crops' ``framing`` (``dataset.json``; 10 m and ``"plane"`` when it records none),
        the other ``settings`` as given."""
        return cls(distance=float(ds.config.get("distance", 10.0)),
                   framing=str(ds.config.get("framing", "plane")), **settings)


def task_seed(master: int, detector: str, source: float, fold: Fold) -> int:
    """Seed of one (detector, source, fold) training: derived from the ids, so the sweep and
    the cross-validation train identical source models."""
    import zlib

    key = zlib.crc32(f"{detector}|{source:.6f}|{fold.name}".encode())
    return int(np.random.default_rng([master, key]).integers(2**31 - 1))


def variant_remap(det, H, variant, cfg):
    """``G`` of a variant for detector ``det``; ``H`` is the source -> target homography or
    point mapping."""
    rule, per_cell, _ = ADAPT_VARIANTS[variant]
    return detector_spec(det).remap_matrix(H, rule=rule, per_cell=per_cell, config=cfg)


def view_maps(s, t, cfg) -> dict:
    """Source -> target maps of the crops per object model: {"plane": H, "body": mapping}."""
    out = {}
    for m in cfg.object_models:
        if m == "plane":
            out[m] = elevation_homography(s, t, distance=cfg.distance, framing=cfg.framing)
        else:
            out[m] = crop_view_mapping(object_model(m), s, t, distance=cfg.distance,
                                       framing=cfg.framing)
    return out


def warp_field(mapping, H, size=(64, 128)) -> np.ndarray:
    """(h, w, 2) float32 target pixel of every source pixel centre (for ``cv2.remap``):
    ``mapping`` where defined, the homography ``H`` where not."""
    from viewadapt.geometry import apply_homography

    w, h = size
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    p = np.stack([xs, ys], -1)
    m = np.asarray(mapping(p), dtype=np.float64)
    bad = ~np.isfinite(m).all(-1)
    m[bad] = apply_homography(H, p[bad])
    return m.astype(np.float32)


def exact_remaps(det, s, t, rows, data, cfg, rules, memo=None):
    """``{rule: [G per row]}``: ``G`` of each target positive in ``rows`` from its own
    correspondences (source crop of the same instance at ``s``: its depth maps, cameras and
    plane homographies), each instance's mapping built once for every rule. ``memo`` (a
    dict, optional) keeps the matrices for other detectors with the same ``remap_matrix``
    on the same elevations (the two HOG detectors share theirs)."""
    import json

    inst = data["instances"]
    es, et = data["index"][s], data["index"][t]
    spec = detector_spec(det)
    memo = {} if memo is None else memo
    out = {r: [] for r in rules}
    for r in rows.itertuples(index=False):
        ident = (r.person_id, r.scene_id, int(r.instance))
        keys = {rule: (type(spec).remap_matrix, es, et, rule) + ident for rule in rules}
        if any(k not in memo for k in keys.values()):
            src, tgt = inst[ident + (es,)], inst[ident + (et,)]
            Hs = np.array(json.loads(src["H_window_to_image"]))
            Ht = np.array(json.loads(tgt["H_window_to_image"]))
            m = correspondence_mapping(read_depth_map(data["root"], src), manifest_camera(src),
                                       read_depth_map(data["root"], tgt),
                                       manifest_camera(tgt), fallback=Ht @ np.linalg.inv(Hs))
            for rule, k in keys.items():
                if k not in memo:
                    memo[k] = spec.remap_matrix(m, rule=rule, per_cell=True, config=cfg)
        for rule, k in keys.items():
            out[rule].append(memo[k])
    return out


def _suffix(key: str, added: str) -> str:
    return key if not added else added if not key else f"{key}|{added}"


def training_windows(feat, rep, index, key, masks, recipe: Recipe) -> dict:
    """The features a model of view ``index`` trains on under ``recipe``, by kind
    (``"person"``, ``"background"``): the rows ``masks[kind]`` of every set
    :meth:`benchmark.recipes.Recipe.training_suffixes` names,
    ``feat[(rep, kind, index, key + suffix)]`` (each set is the same windows transformed,
    so the same rows), stacked in that order."""
    out = {}
    for kind, a in recipe.training_suffixes():
        out.setdefault(kind, []).append(feat[(rep, kind, index, _suffix(key, a))][masks[kind]])
    return {kind: np.vstack(parts) for kind, parts in out.items()}


def fold_masks(meta, fold: Fold, train: bool):
    persons = fold.train_persons if train else fold.test_persons
    scenes = fold.train_scenes if train else fold.test_scenes
    in_scene = meta["scene_id"].isin(scenes).to_numpy()
    if (meta["label"] == 1).all():
        return in_scene & meta["person_id"].isin(persons).to_numpy()
    return in_scene


def _task(det, s, t, fold, cfg, data, seed, memo=None):
    """All methods for one detector, source elevation and fold -> (DataFrame of scores, the
    source model) (``memo``: see :func:`exact_remaps`)."""
    spec = detector_spec(det)
    src_rep, fine_rep = feature_key(spec.source_features), feature_key(spec.target_features)
    es, et = data["index"][s], data["index"][t]
    pos_t, neg_t = data["meta"][("person", et)], data["meta"][("background", et)]
    mp, mn = fold_masks(pos_t, fold, False), fold_masks(neg_t, fold, False)
    test_meta = pd.concat([pos_t[mp], neg_t[mn]], ignore_index=True)
    F = data["feat"]

    def test_feats(rep, key=""):
        return np.vstack([F[(rep, "person", et, key)][mp], F[(rep, "background", et, key)][mn]])

    def train(key=""):
        pm = fold_masks(data["meta"][("person", es)], fold, True)
        nm = fold_masks(data["meta"][("background", es)], fold, True)
        # a pretrained detector trains on nothing: the recipe's sets are not featurised
        X = training_windows(F, src_rep, es, key, {"person": pm, "background": nm},
                             RECIPES["elevation0"] if spec.pretrained else cfg.recipe)
        Xp, Xn = X["person"], X["background"]
        if not spec.pretrained and (len(Xp) == 0 or len(Xn) == 0):
            raise ValueError(f"fold {fold.name}: no training "
                             f"{'positives' if len(Xp) == 0 else 'negatives'} at elevation "
                             f"{s:.3f}")
        return spec.fit(Xp, Xn, seed=seed, config=cfg)

    results = {}
    model = train()
    X_plain = test_feats(src_rep)
    results["oracle" if es == et else "unadapted"] = spec.score(model, X_plain)
    if es != et:
        Xfine = test_feats(fine_rep)
        for v in variant_names(spec, cfg):
            results[v] = spec.score_adapted(model, Xfine, data["G"][(det, s, t, v)])
        for m in cfg.object_models:
            name = variant_label("image warping", object_model=m)
            results[name] = spec.score(model, test_feats(src_rep, _warp_key(s, m)))
        if _wants_exact(spec, cfg, data):
            n_pos = int(mp.sum())
            rows = pos_t[mp]
            todo = {n: v for n, v in EXACT_VARIANTS.items() if v[1] in results}
            Gs = exact_remaps(det, s, t, rows, data, cfg, sorted({r for r, _ in todo.values()}),
                              memo)
            for name, (rule, neg_variant) in todo.items():
                pos = np.array([spec.score_adapted(model, Xfine[i:i + 1], G)[0]
                                for i, G in enumerate(Gs[rule])])
                results[name] = np.r_[pos, np.asarray(results[neg_variant])[n_pos:]]
        if cfg.synthesised and not spec.pretrained:
            results["synthesised"] = spec.score(train(f"synth{t:.6f}"), X_plain)
    frames = []
    for method, sc in results.items():
        frames.append(test_meta.assign(detector=spec.name, method=method, source_elevation=s,
                                       target_elevation=t, fold=fold.name,
                                       score=np.asarray(sc, np.float64)))
    return pd.concat(frames, ignore_index=True), model


def _warp_key(s, model):
    return f"warp{s:.6f}" + ("" if model == "plane" else f"|{model}")


def exact_geometry_wanted(spec, cfg) -> bool:
    """Whether the run asks ``spec`` for the exact-geometry rows (each test positive adapted
    through its own person's geometry): the upper bound is on and the detector runs them.
    They are run only with the plane among the object models (:func:`_wants_exact`)."""
    return bool(cfg.upper_bound and spec.exact_geometry)


def _wants_exact(spec, cfg, data) -> bool:
    """The exact-geometry rows: when they are wanted, the dataset has depth maps and the
    plane's adapted rows, whose negatives they share, are run."""
    return (exact_geometry_wanted(spec, cfg) and "plane" in cfg.object_models
            and data.get("instances") is not None)


def prepare(ds: Dataset, cfg: CrossvalConfig, cache: FeatureCache, elevations=None) -> dict:
    """Compute (or load) every feature matrix and remapping matrix the runs need."""
    sources = list(cfg.sources) if elevations is None else list(elevations)
    idx = {e: ds.elevation_index(e) for e in set(sources) | {cfg.target}}
    meta, feat, G = {}, {}, {}
    et = idx[cfg.target]
    pw = {e: person_windows(ds, i) for e, i in idx.items()}
    bw = {e: background_windows(ds, i, stride=cfg.bg_stride) for e, i in idx.items()}
    for e, i in idx.items():
        meta[("person", i)] = pw[e].meta
        meta[("background", i)] = bw[e].meta
        if len(bw[e]) == 0:
            raise ValueError(f"{ds.root}: no background windows at elevation {e:.3f}; "
                             "the dataset needs person-free background images")
    # collect every (window set, representation) request, then compute per window set in
    # one pass (shared image reads, warps and gradients)
    requests = {}   # ws.key -> (ws, elevation index, suffix, set of reps)

    def want(ws, i, suffix, rep):
        requests.setdefault(ws.key, (ws, i, suffix, {}))[3][feature_key(rep)] = rep

    for det in cfg.detectors:
        spec = detector_spec(det)
        src_rep, fine_rep = spec.source_features, spec.target_features
        for e, i in idx.items():
            for ws in (pw[e], bw[e]):
                want(ws, i, "", src_rep)
        if not spec.pretrained:                 # the recipe's sets of each trained view
            for e in sources:
                for _, a, ws in cfg.recipe.training_sets(pw[e], bw[e]):
                    if a:
                        want(ws, idx[e], a, src_rep)
        for ws in (pw[cfg.target], bw[cfg.target]):
            want(ws, et, "", fine_rep)
        for s in sources:
            if idx[s] == et:
                continue
            maps = view_maps(s, cfg.target, cfg)
            H = elevation_homography(s, cfg.target, distance=cfg.distance,
                                     framing=cfg.framing)
            for m, M in maps.items():
                key = _warp_key(s, m)
                for ws in (pw[cfg.target], bw[cfg.target]):
                    warped = ws.warped(H, key) if m == "plane" else \
                        ws.remapped(warp_field(M, H), key)
                    want(warped, et, key, src_rep)
            if cfg.synthesised and not spec.pretrained:
                Hinv = np.linalg.inv(H)
                key = f"synth{cfg.target:.6f}"
                for _, a, ws in cfg.recipe.training_sets(
                        pw[s], bw[s], warp=lambda w, k=key, M=Hinv: w.warped(M, k)):
                    want(ws, idx[s], _suffix(key, a), src_rep)
            for v in variant_names(spec, cfg):
                G[(det, s, cfg.target, v)] = variant_remap(det, maps[ADAPT_VARIANTS[v][2]], v, cfg)
    for ws, i, suffix, reps in requests.values():
        got = cache.get_many(ws, [reps[k] for k in sorted(reps)])
        for rep, X in got.items():
            feat[(rep, ws.key.split("|")[0], i, suffix)] = X
    p = ds.persons
    instances = None
    if cfg.upper_bound and "depth_path" in p.columns and (p["depth_path"] != "").all():
        instances = {(r["person_id"], r["scene_id"], int(r["instance"]),
                      int(r["elevation_index"])): r for r in p.to_dict("records")}
    return {"index": idx, "meta": meta, "feat": feat, "G": G, "instances": instances,
            "root": ds.root, "prepared_for": _preparation_key(cfg, sources)}


def _preparation_key(cfg: CrossvalConfig, sources) -> str:
    """What :func:`prepare`'s result was made for: the configuration (less ``n_jobs``)
    and the source elevations."""
    d = config_dict(cfg)
    d.pop("n_jobs")
    d["sources"] = [float(e) for e in sources]
    return json.dumps(d, sort_keys=True, default=str)


def run_crossval(ds: Dataset, cfg: CrossvalConfig, cache: FeatureCache, *,
                 progress: bool = True, data: dict | None = None,
                 models: dict | None = None) -> tuple[pd.DataFrame, list]:
    """Run all folds; returns (per-window scores, folds).

    ``data``: :func:`prepare`'s result for ``cfg`` if the caller has it (else prepared
    here). ``models``: a dict to receive the source model of every (detector, source,
    fold name) trained -- e.g. for :func:`benchmark.crops.sweep.run_sweep`, which trains the same
    models (same seeds, same windows)."""
    from joblib import Parallel, delayed
    from tqdm.auto import tqdm

    rng = np.random.default_rng(cfg.seed)
    p = ds.persons
    folds = make_folds(p["person_id"], p["scene_id"], rng=rng)
    if data is None:
        data = prepare(ds, cfg, cache)
    elif data.get("root") != ds.root or data.get("prepared_for") != _preparation_key(
            cfg, cfg.sources):
        raise ValueError("run_crossval: data was prepared for another dataset or "
                         "configuration; pass prepare(ds, cfg, cache) for this one")
    # OpenCV's detector was trained on INRIA (level views): its source elevation is 0 only
    tasks = [(det, s, fold) for det in cfg.detectors for s in cfg.sources for fold in folds
             if not (detector_spec(det).pretrained and s != 0.0)]
    seeds = [int(task_seed(cfg.seed, d, s, f)) for d, s, f in tasks]
    # detectors whose exact-geometry rows use the same remap_matrix run in one job per
    # source and fold, so its matrices are built once (exact_remaps' memo)
    jobs = {}
    for i, (d, s, f) in enumerate(tasks):
        spec = detector_spec(d)
        share = type(spec).remap_matrix if spec.exact_geometry else d
        jobs.setdefault((share, s, f.name), []).append(i)
    jobs = list(jobs.values())

    def run(members):
        memo = {}
        return [_task(*tasks[i][:2], cfg.target, tasks[i][2], cfg, data, seeds[i], memo)
                for i in members]

    it = tqdm(jobs, desc="cross-validation", disable=not progress)
    if cfg.n_jobs == 1:
        done = [run(m) for m in it]
    else:
        done = Parallel(n_jobs=cfg.n_jobs)(delayed(run)(m) for m in it)
    parts = dict(zip((i for m in jobs for i in m), (r for d in done for r in d)))
    scores = pd.concat([parts[i][0] for i in range(len(tasks))], ignore_index=True)
    if models is not None:
        for i, (d, s, f) in enumerate(tasks):
            models[(d, float(s), f.name)] = parts[i][1]
    return scores, folds


def config_dict(cfg: CrossvalConfig) -> dict:
    d = asdict(cfg)
    d["sources"] = [float(s) for s in cfg.sources]
    return d
