"""Generator tests that render with Blender Cycles (marker ``blender``).

They render a real micro dataset (3 persons x 2 scenes x 3 elevations, backgrounds, one
frame) once per session and check geometry against the numpy plan, the manifest,
determinism, resume after ``kill -9`` and the Dask path. The full ``tiny`` preset is a
``slow`` test.
"""

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time

import cv2
import numpy as np
import pytest

pytest.importorskip("bpy", reason="needs the generator extra: pip install -e '.[generator]'")
pytest.importorskip("anny", reason="needs the generator extra: pip install -e '.[generator]'")

from generator import pipeline  # noqa: E402
from generator.annotate import person_to_world, silhouette_box  # noqa: E402
from generator.manifest import MANIFEST_COLUMNS, read_manifest  # noqa: E402
from generator.sampling import GeneratorConfig, plan_dataset, preset_config  # noqa: E402
from generator.specs import load_roster, load_scenes  # noqa: E402
from generator.verify import verify_dataset  # noqa: E402
from viewadapt.geometry import (  # noqa: E402
    Camera, apply_homography, camera_from_pose, crop_camera,
)
from tests.paths import REPO as REPO_ROOT  # noqa: E402

pytestmark = pytest.mark.blender

#: Blender pixel placement vs Camera.project (brief: < 0.5 px at 4x supersampling).
CENTROID_PX = 0.5
#: Rendered silhouette box vs the box of the projected mesh (pixel quantisation + AA).
SILHOUETTE_PX = 1.0

MICRO = dict(preset="micro", person_ids=("p001", "p002", "p004"),
             scene_ids=("plaza", "warehouse"), instances=1, backgrounds_per_scene=1,
             frames=1, persons_per_frame=(2, 3), samples=4, background_samples=4,
             frame_samples=8)
REPO = REPO_ROOT


def _micro_config():
    return GeneratorConfig(**MICRO).validate()


@pytest.fixture(scope="module")
def micro(tmp_path_factory):
    out = tmp_path_factory.mktemp("micro") / "ds"
    res = pipeline.generate(_micro_config(), 7, out, jobs=0, progress=False)
    assert res.complete
    return out


@pytest.fixture(scope="module")
def renderer(micro):
    # the in-process renderer the micro fixture used
    return pipeline.STATE["renderer"]


def _centroid(img):
    g = img.astype(np.float64)
    if g.ndim == 3:
        g = g.sum(2)
    g = np.clip(g - 0.1 * g.max(), 0, None)          # ignore the faint noise floor
    ys, xs = np.mgrid[:g.shape[0], :g.shape[1]]
    return np.array([(g * xs).sum() / g.sum(), (g * ys).sum() / g.sum()])


# --------------------------------------------------------------------------- cameras


def _cameras():
    cams = [("crop e0", crop_camera(0.0), (64, 128)),
            ("crop pi/8", crop_camera(math.pi / 8, azimuth=1.1), (64, 128)),
            ("crop pi/4", crop_camera(math.pi / 4, azimuth=-2.0), (64, 128))]
    cams.append(("frame off-centre", camera_from_pose(
        focal=(260.0, 260.0), principal_point=(201.3, 130.7), height=4.5, tilt=0.7,
        azimuth=0.9, position_xy=(-3.0, -4.0)), (384, 288)))
    return cams


@pytest.mark.parametrize("name, cam, size", _cameras(), ids=[c[0] for c in _cameras()])
def test_blender_camera_puts_a_point_where_project_says(renderer, tmp_path, name, cam, size):
    """An emissive sphere rendered at 4x lands on Camera.project (< 0.5 px)."""
    s = 4
    w, h = size
    A = np.array([[s, 0, (s - 1) / 2], [0, s, (s - 1) / 2], [0, 0, 1.0]])   # pixel centres
    hi = Camera(A @ cam.K, cam.R, cam.t)
    # a point near the image's upper-left quarter, at the person's distance
    target = np.array([0.3 * w, 0.35 * h, 1.0])
    ray = np.linalg.solve(cam.K, target)
    depth = 10.0 if name.startswith("crop") else 6.0
    P = cam.center + cam.R.T @ (ray / ray[2] * depth)
    renderer.set_persons([])
    renderer.set_scene_visible(False)
    renderer.set_dark()
    marker = renderer.add_marker(P, 0.012 if name.startswith("crop") else 0.03)
    try:
        renderer.set_camera(hi.K, hi.R, hi.t, w * s, h * s)
        renderer.render(tmp_path / "m.png", samples=2 if w > 100 else 8, seed=0)
    finally:
        renderer.remove_marker(marker)
        renderer.set_scene_visible(True)
    img = cv2.imread(str(tmp_path / "m.png"), cv2.IMREAD_UNCHANGED)
    c_hi = _centroid(img)
    c_lo = (c_hi + 0.5) / s - 0.5
    np.testing.assert_allclose(c_lo, cam.project(P), atol=CENTROID_PX)


# --------------------------------------------------------------------------- the dataset


def test_micro_dataset_manifest_and_files(micro):
    df = read_manifest(micro)
    assert list(df.columns) == MANIFEST_COLUMNS
    assert (df["kind"] == "person").sum() == 3 * 2 * 3
    assert (df["kind"] == "background").sum() == 2 * 3
    assert (df["kind"] == "frame").sum() == 1
    rep = verify_dataset(micro)
    assert rep.ok, rep.summary()
    meta = json.loads((micro / "dataset.json").read_text())
    assert meta["seed"] == 7 and meta["framing"] == "plane"
    assert meta["versions"]["blender"] == "5.0.1" and meta["versions"]["anny"]
    assert meta["elevations"] == pytest.approx([0, math.pi / 8, math.pi / 4])
    persons = df[df["kind"] == "person"]
    for r in persons.itertuples():
        img = cv2.imread(str(micro / r.path))
        assert img.shape == (128, 64, 3) and img.std() > 5        # not blank
        assert r.path == f"person/{r.scene_id}/{r.person_id}_i{r.instance}_e{r.elevation_index}.png"
        assert r.box_silhouette
    # paired views: same placement, rotation and lighting at every elevation
    g = persons.groupby(["scene_id", "person_id", "instance"])
    for _, grp in g:
        assert grp["elevation_index"].tolist() == [0, 1, 2]
        for col in ("ground_x", "ground_y", "rotation", "azimuth", "sun_elevation",
                    "sun_color", "sky_strength", "seed", "gait_phase"):
            vals = grp[col].tolist()
            assert all(v == vals[0] or (isinstance(v, float) and math.isnan(v)) for v in vals), col
    bg = df[df["kind"] == "background"]
    assert set(zip(bg["width"], bg["height"])) == {(256, 256)}
    # backgrounds share the crops' focal length
    fx = {json.loads(k)[0][0] for k in df.loc[df["kind"] != "frame", "K"]}
    assert len(fx) == 1


def test_homographies_and_boxes_follow_the_mesh(micro):
    """H maps the window's feet/centre to the projected ground/aim point; the recorded box is
    the projected mesh's; at elevation 0 the plane-framed H is the identity."""
    df = read_manifest(micro)
    persons = df[df["kind"] == "person"]
    for r in persons.itertuples():
        H = np.array(json.loads(r.H_window_to_image))
        cam = Camera(np.array(json.loads(r.K)), np.array(json.loads(r.R)),
                     np.array(json.loads(r.t)))
        pts = np.array([[r.ground_x, r.ground_y, 0.0], [r.ground_x, r.ground_y, 0.875]])
        np.testing.assert_allclose(apply_homography(H, [[31.5, 111.5], [31.5, 63.5]]),
                                   cam.project(pts), atol=1e-6)
        if r.elevation_index == 0:
            np.testing.assert_allclose(H, np.eye(3), atol=1e-9)
        x, y, w, h = json.loads(r.box_silhouette)
        # the person stands on the ground point: feet within ~0.3 m of it, which moves the
        # lowest image point by up to 0.3 sin(e) f / d pixels at elevation e ...
        px_per_m = cam.K[0, 0] / 10.0 * math.sin(r.elevation)
        feet = apply_homography(H, [[31.5, 111.5]])[0]
        assert y + h == pytest.approx(feet[1], abs=2.5 + 0.3 * px_per_m)
        assert x <= feet[0] <= x + w
        # ... and the head is where a person of that stature projects (+ hair, head offset)
        head = cam.project([r.ground_x, r.ground_y, r.stature])
        assert y == pytest.approx(head[1], abs=3.0 + 0.2 * px_per_m)


def test_rendered_silhouette_matches_projected_mesh(micro, renderer, tmp_path):
    """Render a crop's person alone (transparent film): the alpha box is the mesh box."""
    config = _micro_config()
    plan = plan_dataset(config, 7, scenes=load_scenes(), persons=load_roster())
    body = pipeline.STATE["body"]
    unit = next(u for u in plan.units if u.kind == "person" and u.scene_id == "plaza")
    s = unit.samples[0]
    person = plan.persons[s.person_id]
    mesh = body.build(person, s.pose, s.gait_phase, s.pose_jitter)
    renderer.load_scene(pipeline.scene_layout(plan.scenes["plaza"]))
    renderer.set_persons([(mesh, person, s.ground_xy, s.rotation)])
    renderer.set_lighting(s.lighting)
    renderer.set_scene_visible(False)
    pts = person_to_world(mesh.all_points(), s.ground_xy, s.rotation)
    try:
        for e, cam in enumerate(s.cameras):
            renderer.set_camera(cam.K, cam.R, cam.t, 64, 128, supersample=1)
            renderer.render(tmp_path / f"a{e}.png", samples=4, seed=1, transparent=True)
            a = cv2.imread(str(tmp_path / f"a{e}.png"), cv2.IMREAD_UNCHANGED)[..., 3]
            ys, xs = np.nonzero(a > 127)
            rendered = [xs.min() - 0.5, ys.min() - 0.5, xs.max() + 0.5, ys.max() + 0.5]
            x, y, w, h = silhouette_box(pts, cam, 64, 128)
            np.testing.assert_allclose(rendered, [x, y, x + w, y + h], atol=SILHOUETTE_PX)
    finally:
        renderer.set_scene_visible(True)


def test_frames_coco_has_calibration_and_boxes(micro):
    coco = json.loads((micro / "frames_coco.json").read_text())
    assert len(coco["images"]) == 1
    im = coco["images"][0]
    cam = Camera(np.array(im["K"]), np.array(im["R"]), np.array(im["t"]))
    assert (im["width"], im["height"]) == (384, 288)
    anns = coco["annotations"]
    assert 2 <= len(anns) <= 3
    for a in anns:
        assert a["image_id"] == im["id"] and a["category_id"] == 1
        x, y, w, h = a["bbox"]
        feet = cam.project(a["ground_position"])
        assert x - 2 <= feet[0] <= x + w + 2 and y + h - 8 <= feet[1] <= y + h + 2
        assert 0.0 <= a["occlusion"] <= 1.0
        if a["bbox_visible"] is not None:
            vx, vy, vw, vh = a["bbox_visible"]
            assert vx >= x - 1.5 and vy >= y - 1.5 and vx + vw <= x + w + 1.5
        H = np.array(a["H_window_to_image"])
        np.testing.assert_allclose(apply_homography(H, [[31.5, 111.5]])[0], feet, atol=1e-6)


def test_same_seed_same_pixels(micro, tmp_path):
    """Re-rendering a unit in a fresh directory reproduces the pixels and the rows."""
    config = _micro_config()
    plan = plan_dataset(config, 7, scenes=load_scenes(), persons=load_roster())
    unit = next(u for u in plan.units if u.kind == "person" and u.scene_id == "warehouse")
    out = tmp_path / "again"
    pipeline.run_unit({"unit": unit, "scene": plan.scenes[unit.scene_id],
                       "persons": {p: plan.persons[p] for p in pipeline.unit_person_ids(unit)},
                       "config": config, "out": str(out)})
    for rel in pipeline.unit_paths(unit):
        a = cv2.imread(str(micro / rel))
        b = cv2.imread(str(out / rel))
        assert np.array_equal(a, b), rel
    from generator.manifest import read_part

    assert read_part(out, unit.uid)["rows"] == read_part(micro, unit.uid)["rows"]


def test_silhouette_framing_fits_the_person(micro, tmp_path):
    """framing="silhouette": the box is 96 px tall and centred; H still maps the plane."""
    config = GeneratorConfig(**dict(MICRO, framing="silhouette")).validate()
    plan = plan_dataset(config, 7, scenes=load_scenes(), persons=load_roster())
    unit = next(u for u in plan.units if u.kind == "person")
    out = tmp_path / "sil"
    pipeline.run_unit({"unit": unit, "scene": plan.scenes[unit.scene_id],
                       "persons": {p: plan.persons[p] for p in pipeline.unit_person_ids(unit)},
                       "config": config, "out": str(out)})
    from generator.manifest import read_part

    for row in read_part(out, unit.uid)["rows"]:
        assert row["framing"] == "silhouette"
        x, y, w, h = json.loads(row["box_silhouette"])
        assert h == pytest.approx(96.0, abs=1e-6) and y == pytest.approx(15.5, abs=1e-6)
        cam = Camera(np.array(json.loads(row["K"])), np.array(json.loads(row["R"])),
                     np.array(json.loads(row["t"])))
        H = np.array(json.loads(row["H_window_to_image"]))
        np.testing.assert_allclose(apply_homography(H, [[31.5, 111.5]])[0],
                                   cam.project([row["ground_x"], row["ground_y"], 0.0]),
                                   atol=1e-6)
        assert cv2.imread(str(out / row["path"])).shape == (128, 64, 3)


def test_resume_after_kill_9(micro, tmp_path):
    """Kill a running `generate` (and its worker) with SIGKILL; a rerun completes the
    dataset with the same manifest and pixels as an uninterrupted run."""
    out = tmp_path / "killed"
    code = textwrap.dedent(f"""
        from generator.pipeline import generate
        from generator.sampling import GeneratorConfig
        if __name__ == "__main__":
            generate(GeneratorConfig(**{MICRO!r}), 7, {str(out)!r}, jobs=1, progress=False)
    """)
    script = tmp_path / "gen.py"
    script.write_text(code)
    proc = subprocess.Popen([sys.executable, str(script)], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO)
    try:
        deadline = time.time() + 120
        while time.time() < deadline:
            n = len(list((out / "person").rglob("*.png"))) if (out / "person").is_dir() else 0
            if n >= 4:
                break
            if proc.poll() is not None:
                pytest.fail("generate finished before it could be killed")
            time.sleep(0.05)
        else:
            pytest.fail("no images appeared within 120 s")
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert not (out / "manifest.parquet").exists() or len(read_manifest(out)) < 25
    res = pipeline.generate(_micro_config(), 7, out, jobs=0, progress=False)
    assert res.complete and res.n_kept >= 4
    rep = verify_dataset(out)
    assert rep.ok, rep.summary()
    a, b = read_manifest(micro), read_manifest(out)
    assert a.equals(b)
    for rel in a["path"]:
        assert np.array_equal(cv2.imread(str(micro / rel)), cv2.imread(str(out / rel))), rel
    # a second rerun renders nothing
    res = pipeline.generate(_micro_config(), 7, out, jobs=0, progress=False)
    assert res.n_rendered == 0 and res.n_units_run == 0


def test_dask_local_cluster_renders_a_shard(micro, tmp_path):
    distributed = pytest.importorskip("distributed")
    out = tmp_path / "dask"
    cluster = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=None)
    try:
        res = pipeline.generate(_micro_config(), 7, out, shard=(3, 9),
                                scheduler=cluster.scheduler_address, progress=False,
                                threads=2)
    finally:
        cluster.close()
    assert res.n_units_run == 1 and res.n_rendered == 3 and not res.complete
    df = read_manifest(out)
    assert len(df) == 3
    for rel in df["path"]:
        assert np.array_equal(cv2.imread(str(micro / rel)), cv2.imread(str(out / rel))), rel


@pytest.mark.slow
def test_tiny_preset_renders_completely(tmp_path):
    # its time (target <= 3 min) is measured by `python -m generator.bench --preset tiny`
    res = pipeline.generate(preset_config("tiny"), 0, tmp_path / "tiny", jobs=1,
                            progress=False)
    assert res.complete and res.n_images == 64
    assert verify_dataset(tmp_path / "tiny").ok
