"""The whole pipeline on a set rendered with Blender (marker ``blender``).

One module-scoped render of the ``tiny`` preset (6 persons x 3 scenes x 3 elevations,
backgrounds, two calibrated frames; low sample counts), then what a user runs on it:
cross-validation, sweep and report, and full-frame detection with the adapted
detectors. The planar toy data of ``test_benchmark.py`` and
``test_fullframe_bench.py`` checks the numbers; this checks that rendered data flows
through every step.
"""

import json

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("bpy", reason="needs the generator extra: pip install -e '.[generator]'")
pytest.importorskip("anny", reason="needs the generator extra: pip install -e '.[generator]'")

from benchmark.frames.methods import load_frames  # noqa: E402
from generator import pipeline  # noqa: E402
from generator.manifest import read_manifest  # noqa: E402
from generator.sampling import preset_config  # noqa: E402
from viewadapt.cli import main  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    out = tmp_path_factory.mktemp("rendered") / "tiny"
    cfg = preset_config("tiny", samples=4, background_samples=4, frame_samples=8, frames=2)
    res = pipeline.generate(cfg, 3, out, jobs=0, progress=False)
    assert res.complete
    return out


@pytest.fixture(scope="module")
def results(rendered, tmp_path_factory):
    out = tmp_path_factory.mktemp("results") / "res"
    assert main(["bench", "crossval", "--data", str(rendered), "--out", str(out), "--quick",
                 "--detectors", "hog", "acf"]) == 0
    assert main(["bench", "sweep", "--data", str(rendered), "--out", str(out), "--quick",
                 "--step", str(np.pi / 36), "--sigma", "0.1"]) == 0
    return out


def test_crossval_folds_are_disjoint_on_the_rendered_manifest(rendered, results):
    man = read_manifest(rendered)
    persons = set(man.loc[man["kind"] == "person", "person_id"])
    scenes = set(man.loc[man["kind"] == "person", "scene_id"])
    folds = json.loads((results / "folds.json").read_text())
    assert len(folds) == 9
    for f in folds:
        assert not set(f["train_persons"]) & set(f["test_persons"])
        assert not set(f["train_scenes"]) & set(f["test_scenes"])
        assert set(f["train_persons"]) | set(f["test_persons"]) == persons
        assert set(f["train_scenes"]) | set(f["test_scenes"]) == scenes
    # every scored test window comes from its fold's test persons and test scenes
    scores = pd.read_parquet(results / "scores.parquet")
    by_fold = {f["fold"]: f for f in folds}
    for fold, rows in scores.groupby("fold"):
        f = by_fold[fold]
        assert set(rows["scene_id"]) <= set(f["test_scenes"])
        pos = rows[rows["label"] == 1]
        assert len(pos) and set(pos["person_id"]) <= set(f["test_persons"])


def test_crossval_outputs_schema_and_figures(results):
    s = pd.read_csv(results / "summary.csv")
    for col in ("detector", "source_elevation", "target_elevation", "method",
                "mr_at_fppw_0.01", "mr_at_fppw_0.01_std", "lamr"):
        assert col in s.columns
    assert set(s["detector"]) == {"hog", "acf"}
    assert {"unadapted", "adapted", "image warping", "synthesised", "oracle",
            "adapted[body]", "image warping[body]", "exact geometry",
            "exact geometry[paper eq.3]"} <= set(s["method"])
    assert "exact geometry" not in set(s.loc[s["detector"] == "acf", "method"])
    assert s["mr_at_fppw_0.01"].between(0, 1).all()
    sw = pd.read_csv(results / "sweep_summary.csv")
    assert {"adapted", "adapted[paper eq.3]", "adapted[S only]", "adapted[body]"} <= \
        set(sw["method"])
    assert set(sw.loc[sw["method"] == "adapted[body]", "object_model"]) == {"body"}
    assert set(sw.loc[sw["method"] == "adapted[paper eq.3]", "rule"]) == {"paper"}
    for name in ("det_hog.png", "det_hog.pdf", "det_acf.png", "det_acf.pdf", "sweep.png",
                 "sweep.pdf", "score_shift.png", "remap_illustration.png", "report.md",
                 "summary.md", "paired_differences.csv", "sweep_summary.csv", "run.json"):
        assert (results / name).is_file() and (results / name).stat().st_size > 0, name
    report = (results / "report.md").read_text()
    assert "sweep.png" in report and "crossing" in report


@pytest.fixture(scope="module")
def frames_bench(rendered, tmp_path_factory):
    out = tmp_path_factory.mktemp("frames") / "bench"
    assert main(["bench", "frames", "--data", str(rendered), "--out", str(out), "--quick",
                 "--methods", "hog_adapted", "acf_adapted", "hog_pyramid"]) == 0
    return out


def test_bench_frames_on_rendered_frames(rendered, frames_bench):
    s = pd.read_csv(frames_bench / "frames_summary.csv")
    assert len(s) == 3
    for name in ("det_frames.png", "det_frames.pdf", "det_curves.json",
                 "models/source_detectors.npz"):
        assert (frames_bench / name).is_file(), name
    curves = json.loads((frames_bench / "det_curves.json").read_text())
    assert set(curves) == {"hog_adapted", "acf_adapted", "hog_pyramid"}
    assert all(0 < c["lamr"] <= 1 for c in curves.values())


def test_detect_on_rendered_frames_with_a_yaml_calibration(rendered, frames_bench, tmp_path):
    frames = load_frames(rendered)
    assert len(frames) == 2
    f = frames[0]
    cam = f.camera
    calib = tmp_path / "camera.yaml"
    calib.write_text("image_size: [%d, %d]\nK: %s\nR: %s\nt: %s\n" % (
        *cam.image_size, cam.K.tolist(), cam.R.tolist(), cam.t.tolist()))
    out = tmp_path / "det"
    rc = main(["detect", "--calibration", str(calib), "--model",
               str(frames_bench / "models" / "source_detectors.npz"), "--out", str(out),
               "--threshold", "-1", str(f.path)])
    assert rc == 0
    det = pd.read_csv(out / "detections.csv")
    assert len(det) > 0
    w, h = cam.image_size
    # boxes of windows selected inside the image (the person box may reach the border)
    assert (det["x"] + det["w"] > 0).all() and (det["x"] < w).all()
    assert (det["y"] + det["h"] > 0).all() and (det["y"] < h).all()
    assert len(list((out / "annotated").glob("*.png"))) == 1


def test_depth_maps_agree_with_projected_body_vertices(rendered):
    """The projection check on a rendered set: body vertices the source crop sees land,
    through the stored depth maps, where the recorded target camera projects them."""
    from benchmark.data import manifest_camera
    from generator.annotate import person_to_world
    from generator.body import BodyModel
    from generator.manifest import read_depth
    from generator.sampling import GeneratorConfig, plan_dataset
    from generator.specs import load_roster, load_scenes
    from viewadapt.mapping import GridMapping
    from viewadapt.surface import project_with_depth, view_correspondence

    man = read_manifest(rendered)
    meta = json.loads((rendered / "dataset.json").read_text())
    plan = plan_dataset(GeneratorConfig.from_dict(meta["config"]), meta["seed"],
                        scenes=load_scenes(), persons=load_roster())
    unit = next(u for u in plan.units if u.kind == "person")
    s = unit.samples[0]
    mesh = BodyModel().build(plan.persons[s.person_id], s.pose, s.gait_phase, s.pose_jitter)
    verts = person_to_world(mesh.vertices, s.ground_xy, s.rotation)
    rows = man[(man["person_id"] == s.person_id) & (man["scene_id"] == s.scene_id)
               & (man["instance"] == s.instance)].sort_values("elevation_index")
    src, tgt = rows.iloc[0], rows.iloc[-1]
    ds_ = read_depth(rendered / src["depth_path"])
    dt_ = read_depth(rendered / tgt["depth_path"])
    cs, ct = manifest_camera(src), manifest_camera(tgt)
    uv, vis = view_correspondence(ds_, cs, dt_, ct)
    ps, zs = project_with_depth(verts, cs)
    pt, _ = project_with_depth(verts, ct)
    d = np.asarray(ds_, float)
    seen = np.abs(GridMapping(np.stack([d, d], -1))(ps)[:, 0] - zs) < 3e-3
    q = GridMapping(np.where(vis[..., None], uv, np.nan))(ps)
    ok = seen & np.isfinite(q).all(1)
    assert ok.sum() > 200
    err = np.linalg.norm(q[ok] - pt[ok], axis=1)
    assert err.max() <= 0.5, (np.median(err), err.max())
