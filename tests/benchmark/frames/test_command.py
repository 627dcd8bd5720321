"""`viewadapt bench frames`, `viewadapt detect` and the frame evaluation, end to end on a
tiny set of rendered toy frames (no Blender)."""

import argparse
import json

import numpy as np
import pytest

from benchmark.recipes import DEFAULT_RECIPE
from benchmark.frames.methods import FrameRecord, evaluate_method, load_frames
from viewadapt.detect import standardize_boxes
from viewadapt.geometry import camera_from_pose
from viewadapt.io import read_calibration
from viewadapt.metrics import log_average_miss_rate
from tests.toy_frames import small_toy_frames


def _main(argv):
    """viewadapt's main with the frames commands registered (if cli.py does not yet)."""
    import viewadapt.cli as cli

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    if "detect" not in sub.choices:
        from benchmark.frames.command import register

        register(sub, cli.common_parser())
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (cli.UserError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}")
        return 2


def _calibration_file(cam, path):
    """``cam`` written as a K, R, t calibration file for `viewadapt detect`."""
    path.write_text(json.dumps({"image_size": list(cam.image_size), "K": cam.K.tolist(),
                                "R": cam.R.tolist(), "t": cam.t.tolist()}))
    return path


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return small_toy_frames(tmp_path_factory.mktemp("tf") / "data")


@pytest.fixture(scope="module")
def bench(toy, tmp_path_factory):
    out = tmp_path_factory.mktemp("bf") / "out"
    rc = _main(["bench", "frames", "--data", str(toy), "--out", str(out), "--quick",
                "--methods", "hog_adapted", "hog_warp", "acf_adapted", "opencv_native"])
    assert rc == 0
    return out


def test_frames_follow_the_contract(toy):
    frames = load_frames(toy)
    assert len(frames) == 2
    coco = json.loads((toy / "frames_coco.json").read_text())
    a = coco["annotations"][0]
    for key in ("bbox", "bbox_visible", "occlusion", "person_id", "ground_xy"):
        assert key in a
    # the ground-truth feet project where the calibration says
    f = frames[0]
    ann = [a for a in coco["annotations"] if a["image_id"] == f.image_id][0]
    feet = f.camera.project(np.r_[ann["ground_xy"], 0.0])
    x, y, w, h = ann["bbox"]
    assert x - 2 <= feet[0] <= x + w + 2 and abs(feet[1] - (y + h)) < 4


def test_bench_frames_outputs(bench):
    summary = (bench / "frames_summary.csv").read_text().splitlines()
    assert len(summary) == 5
    for name in ("det_frames.png", "det_frames.pdf", "det_curves.json",
                 "models/source_detectors.npz", "run.json"):
        assert (bench / name).is_file()
    curves = json.loads((bench / "det_curves.json").read_text())
    for m, c in curves.items():
        assert 0 < c["lamr"] <= 1
        # the stored corners give the reported log-average miss rate
        assert log_average_miss_rate(c["fppi"], c["miss_rate"]) == pytest.approx(c["lamr"])
    run = json.loads((bench / "run.json").read_text())
    assert run["seed"] == 0 and run["training"]["frame_view"] == "both"
    assert run["training"]["crops"] > 0


def test_curve_corners_keep_every_miss_rate():
    from benchmark.frames.command import curve_corners
    from viewadapt.metrics import miss_rate_at

    rng = np.random.default_rng(0)
    n = 400
    fp = np.cumsum(rng.random(n) < 0.6) / 7.0                 # FPPI, non-decreasing
    miss = 1 - np.cumsum(rng.random(n) < 0.3) / 200.0         # miss rate, non-increasing
    cf, cm = curve_corners(fp, miss)
    assert len(cf) < n / 2 and cf[-1] == fp[-1]
    ref = np.r_[np.logspace(-3, 2, 500), fp, fp - 1e-9]
    assert np.array_equal(miss_rate_at(cf, cm, ref), miss_rate_at(fp, miss, ref))
    assert log_average_miss_rate(cf, cm) == log_average_miss_rate(fp, miss)
    assert [len(a) for a in curve_corners([], [])] == [0, 0]


def test_rerun_some_methods_keeping_the_others(toy, bench, tmp_path):
    import shutil

    out = tmp_path / "again"
    shutil.copytree(bench, out)
    before = (bench / "frames_summary.csv").read_text().splitlines()
    rc = _main(["bench", "frames", "--data", str(toy), "--out", str(out), "--quick",
                "--model", str(bench / "models" / "source_detectors.npz"),
                "--methods", "acf_adapted", "--keep-other-methods"])
    assert rc == 0
    after = (out / "frames_summary.csv").read_text().splitlines()
    assert [r.split(",")[0] for r in after] == [r.split(",")[0] for r in before]
    # the kept methods are evaluated from their stored detections: same rates
    for a, b in zip(before, after):
        if not a.startswith("acf_adapted"):
            assert a.split(",")[:2] == b.split(",")[:2]
    run = json.loads((out / "run.json").read_text())
    assert run["kept_from_earlier_run"] == ["hog_adapted", "hog_warp", "opencv_native"]
    # nothing earlier to keep: a one-line error before any work
    assert _main(["bench", "frames", "--data", str(toy), "--out", str(tmp_path / "none"),
                  "--methods", "acf_adapted", "--keep-other-methods"]) == 2
    assert not (tmp_path / "none").exists()


def test_detect_cli(toy, bench, tmp_path, capsys):
    frames = load_frames(toy)
    cam = frames[0].camera
    calib = _calibration_file(cam, tmp_path / "calib.json")
    out = tmp_path / "det"
    rc = _main(["detect", "--calibration", str(calib), "--model",
                str(bench / "models" / "source_detectors.npz"), "--out", str(out),
                "--threshold", "-0.5", str(frames[0].path), str(frames[1].path)])
    assert rc == 0
    assert (out / "detections.csv").is_file() and (out / "detections_coco.json").is_file()
    assert len(list((out / "annotated").glob("*.png"))) == 2
    # optional ground truth: CSV (by file name) or COCO gives the same evaluation
    csv = tmp_path / "boxes.csv"
    csv.write_text("frame,x,y,w,h,occlusion\n" + "".join(
        f"{f.path.name},{x},{y},{w},{h},{o}\n" for f in frames[:2]
        for (x, y, w, h), o in zip(f.gt, f.occlusion)))
    coco = tmp_path / "boxes.json"
    coco.write_text(json.dumps({
        "images": [{"id": i, "file_name": str(f.path)} for i, f in enumerate(frames[:2])],
        "annotations": [{"image_id": i, "bbox": list(map(float, b)), "occlusion": float(o)}
                        for i, f in enumerate(frames[:2]) for b, o in zip(f.gt, f.occlusion)]}))
    lamr = []
    for k, boxes in enumerate((csv, coco)):
        ev_out = tmp_path / f"ev{k}"
        assert _main(["detect", "--calibration", str(calib), "--model",
                      str(bench / "models" / "source_detectors.npz"), "--out", str(ev_out),
                      "--threshold", "-0.5", "--boxes", str(boxes),
                      str(frames[0].path), str(frames[1].path)]) == 0
        ev = json.loads((ev_out / "evaluation.json").read_text())
        assert ev["n_gt"] + ev["n_gt_ignored"] == sum(len(f.gt) for f in frames[:2])
        assert ev["n_gt"] > 0
        assert 0 < ev["lamr"] <= 1 and (ev_out / "det.png").is_file()
        lamr.append(ev["lamr"])
    assert lamr[0] == lamr[1]
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("image,x,y\nf.png,1,2\n")
    assert _main(["detect", "--calibration", str(calib), "--model",
                  str(bench / "models" / "source_detectors.npz"), "--out", str(tmp_path / "b2"),
                  "--boxes", str(bad_csv), str(frames[0].path)]) == 2
    assert not (tmp_path / "b2").exists()
    # a model file that is not one (truncated, or of another layout): one line, no traceback
    junk = tmp_path / "junk.pkl"
    junk.write_bytes(b"\x80\x04not a pickle")
    assert _main(["detect", "--calibration", str(calib), "--model", str(junk),
                  "--out", str(tmp_path / "b3"), str(frames[0].path)]) == 2
    assert not (tmp_path / "b3").exists()
    # a missing frame, a frame of the wrong size: one-line errors, nothing written
    bad = tmp_path / "bad"
    assert _main(["detect", "--calibration", str(calib), "--model",
                  str(bench / "models" / "source_detectors.npz"), "--out", str(bad),
                  str(tmp_path / "nope.png")]) == 2
    import cv2

    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((50, 60, 3), np.uint8))
    assert _main(["detect", "--calibration", str(calib), "--model",
                  str(bench / "models" / "source_detectors.npz"), "--out", str(bad),
                  str(small)]) == 2
    # --upsample-below below 0 or not a number: argparse's one-line error (exit 2)
    for argv in (["detect", "--calibration", str(calib), "--model",
                  str(bench / "models" / "source_detectors.npz"), "--out", str(bad),
                  "--upsample-below", "-1", str(frames[0].path)],
                 ["bench", "frames", "--data", str(toy), "--out", str(bad), "--quick",
                  "--model", str(bench / "models" / "source_detectors.npz"),
                  "--upsample-below", "nan", "--methods", "hog_adapted"]):
        capsys.readouterr()
        with pytest.raises(SystemExit) as exc:
            _main(argv)
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert exc.value.code == 2 and "cannot read the upsampling threshold" in err, err
    assert not bad.exists()
    with pytest.raises(SystemExit):                          # argparse: usage and exit 2
        _main(["bench", "frames", "--data", str(toy), "--out", str(bad),
               "--cache-limit", "-1"])
    assert not bad.exists()


def test_calibration_files(tmp_path):
    pytest.importorskip("yaml")
    y = tmp_path / "c.yaml"
    y.write_text("image_size: [384, 288]\nfocal: 300\nheight: 4.5\ntilt: 35\n")
    cam = read_calibration(y)
    ref = camera_from_pose(focal=300, principal_point=(191.5, 143.5), height=4.5,
                           tilt=np.radians(35), image_size=(384, 288))
    assert np.allclose(cam.P, ref.P)
    with pytest.raises(FileNotFoundError):
        read_calibration(tmp_path / "missing.yaml")
    bad = tmp_path / "b.yaml"
    bad.write_text("image_size: [384, 288]\nfocal: 300\n")
    with pytest.raises(ValueError, match="K, R, t or focal"):
        read_calibration(bad)
    with pytest.raises(FileNotFoundError, match="frames_coco"):
        load_frames(tmp_path)


def _plain_loop_det(dets, gts, thr=0.5):
    """Reference: for every threshold, greedy matching by descending score, frame by frame."""
    def iou(a, b):
        iw = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
        ih = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
        inter = max(iw, 0) * max(ih, 0)
        return inter / (a[2] * a[3] + b[2] * b[3] - inter)

    scores = sorted({d[4] for ds in dets for d in ds}, reverse=True)
    n_pos = sum(len(g) for g in gts)
    fppi, miss = [], []
    for t in scores:
        tp = fp = 0
        for ds, gs in zip(dets, gts):
            taken = [False] * len(gs)
            for d in sorted([d for d in ds if d[4] >= t], key=lambda d: -d[4]):
                best, bi = thr, -1
                for k, g in enumerate(gs):
                    if not taken[k] and iou(d, g) >= best:
                        best, bi = iou(d, g), k
                if bi >= 0:
                    taken[bi] = True
                    tp += 1
                else:
                    fp += 1
        fppi.append(fp / len(dets))
        miss.append(1 - tp / n_pos)
    return np.array(fppi), np.array(miss)


def test_fppi_evaluation_matches_a_plain_loop():
    rng = np.random.default_rng(5)
    cam = camera_from_pose(focal=300, principal_point=(191.5, 143.5), height=4.5,
                           tilt=0.6, image_size=(384, 288))
    frames, dets = [], []
    for i in range(6):
        n = int(rng.integers(1, 5))
        h = rng.uniform(40, 80, n)
        gt = np.stack([rng.uniform(10, 300, n), rng.uniform(10, 150, n), 0.41 * h, h], 1)
        frames.append(FrameRecord(None, i, "s", cam, gt, np.zeros(n)))
        d = []
        for g in gt:
            if rng.random() < 0.7:
                d.append([*(g + rng.normal(0, 3, 4) * [1, 1, 0, 0]), rng.normal(1, 1)])
        for _ in range(int(rng.integers(0, 4))):
            hh = rng.uniform(40, 80)
            d.append([rng.uniform(0, 300), rng.uniform(0, 150), 0.41 * hh, hh,
                      rng.normal(0, 1)])
        dets.append(np.array(d).reshape(-1, 5))
    res = evaluate_method(dets, frames, min_height=0, max_occlusion=1.0)
    std = [np.c_[standardize_boxes(d[:, :4]), d[:, 4]] for d in dets]
    fppi, miss = _plain_loop_det([list(map(list, d)) for d in std],
                                 [list(map(list, standardize_boxes(f.gt))) for f in frames])
    assert np.allclose(res["fppi"], fppi) and np.allclose(res["miss_rate"], miss)


def test_json_calibration_and_bad_cameras(tmp_path):
    from viewadapt.detect import select_candidate_windows

    j = tmp_path / "c.json"
    j.write_text(json.dumps({"image_size": [384, 288], "focal": 300, "height": 4.5,
                             "tilt": 35}))
    cam = read_calibration(j)
    assert len(select_candidate_windows(cam)) > 100
    j.write_text(json.dumps({"image_size": [384, 288], "focal": 300, "height": 4.5,
                             "tilt": -30}))
    with pytest.raises(ValueError, match=r"tilt must lie in \[0, 90\) degrees.*got -30$"):
        read_calibration(j)                       # in the file's units, not radians
    j.write_text("{not json")
    with pytest.raises(ValueError, match="cannot be parsed"):
        read_calibration(j)


def test_runtime_table_end_to_end(toy, tmp_path):
    """`bench runtime`'s table on the toy set (timings are not checked, only that every
    method is timed with the operator forms the library ships)."""
    from benchmark.frames.runtime import format_table, run_runtime

    rows, info = run_runtime(toy, n_frames=1, warp_windows=8, jobs=1, quick=True,
                             cache_dir=tmp_path / "cache")
    methods = {r["method"] for r in rows}
    assert {"hog_adapted", "acf_adapted", "opencv_adapted", "hog_warp", "acf_warp",
            "opencv_warp", "hog_pyramid", "acf_pyramid", "opencv", "opencv_2x",
            "opencv_native"} <= methods
    assert all(r["seconds_per_frame"] > 0 for r in rows)
    assert all(r["how"].startswith("measured (median of ") for r in rows
               if r["method"].endswith("_adapted"))            # end to end, several passes
    assert info["candidate_windows"] > 15000                  # the CAVIAR-like camera
    assert 0 < info["hog_scored_positions"] <= info["candidate_windows"]
    assert set(info["hog_scoring_forms_ms"]) >= {
        "runs: compiled loop over distinct positions (default)",
        "sparse, one row per distinct position"}
    assert len(info["acf_scoring_forms_ms"]) == 2
    # the adapted rows' stages, each beside the copy of the bytes it moves (no time checked)
    for r in rows:
        if r["method"] in ("hog_adapted", "acf_adapted", "opencv_adapted"):
            assert [st["stage"] for st in r["stages"]] == ["features", "scoring", "nms"]
            assert all(st["bytes"] > 0 and st["floor_ms"] > 0 and st["ms"] > 0
                       for st in r["stages"])
    table = format_table(rows, info)
    assert "hog_adapted / hog_warp" in table and "## Targets" in table
    assert "opencv_adapted / opencv (2x)" in table and "384x288 frame" in table
    assert info["opencv_precompute_s"] >= 0 and "opencv_adapted >= 25 fps (1 core)" in table
    # the ACF speed-up is claimed against the faster of the two pyramids, by name
    faster = max(("acf_pyramid", "acf_pyramid_fast"),
                 key=lambda m: next(r["fps_1core"] for r in rows if r["method"] == m))
    assert info["faster_acf_pyramid"] == faster
    assert f"acf_adapted / faster ACF pyramid** ({faster}" in table
    assert "acf_adapted >= 60 fps (1 core)" in info["targets"]
    assert "| hog_adapted | features |" in table and "| acf_adapted | nms |" in table
    # the table says how its detectors were trained and why the all-cores column is empty
    assert info["training"]["frame_view"] == "both" and "frame_view=both" in table
    assert f"recipe={DEFAULT_RECIPE}" in table
    assert "All cores not measured (--jobs 1)" in table


def test_frame_view_copies_change_the_svm_and_the_separation_script_runs(toy, bench, capsys):
    from benchmark.data import load_dataset
    from benchmark.frames.methods import train_source_detectors
    from viewadapt.io import SourceDetectors
    from benchmark.studies.frameview_separation import main as separation_main

    crops_only = train_source_detectors(load_dataset(toy), quick=True, frame_view="none")
    with_copies = SourceDetectors.load(bench / "models" / "source_detectors.npz")
    assert not np.allclose(crops_only.hog_weights, with_copies.hog_weights)
    # the default copies both detectors' crops: the trees differ from the crops-only ones
    assert not (crops_only.acf.feature_.shape == with_copies.acf.feature_.shape
                and np.array_equal(crops_only.acf.feature_, with_copies.acf.feature_)
                and np.array_equal(crops_only.acf.threshold_, with_copies.acf.threshold_))
    # "acf" copies the trees' crops alone: its SVM is the crops-only one, its trees the default's
    acf_only = train_source_detectors(load_dataset(toy), quick=True, frame_view="acf")
    assert np.array_equal(acf_only.hog_weights, crops_only.hog_weights)
    assert np.array_equal(acf_only.acf.threshold_, with_copies.acf.threshold_)
    # acf=False: the same SVM, no trees
    hog_alone = train_source_detectors(load_dataset(toy), quick=True, frame_view="none",
                                       acf=False)
    assert hog_alone.acf is None
    assert np.array_equal(hog_alone.hog_weights, crops_only.hog_weights)
    assert hog_alone.hog_bias == crops_only.hog_bias
    with pytest.raises(ValueError, match="frame_view must be one of"):
        train_source_detectors(load_dataset(toy), quick=True, frame_view="yes")
    assert separation_main(["--data", str(toy), "--model",
                            str(bench / "models" / "source_detectors.npz"),
                            "--scales", "0.4,0.8"]) == 0
    rows = [r for r in capsys.readouterr().out.splitlines() if r.startswith("| 0.")]
    assert len(rows) == 2
    assert all(np.isfinite(float(v)) for r in rows for v in r.split("|")[3:5])


def test_seed_study(toy, tmp_path):
    """--seeds N: one training per seed, per-seed rates, the targets on the seed means."""
    from benchmark.data import load_dataset
    from benchmark.frames.methods import train_source_detectors
    from viewadapt.io import SourceDetectors

    out = tmp_path / "seeds"
    assert _main(["bench", "frames", "--data", str(toy), "--out", str(out), "--quick",
                  "--seeds", "2", "--methods", "hog_adapted", "hog_warp",
                  "opencv_native"]) == 0
    rows = [r.split(",") for r in (out / "seeds.csv").read_text().splitlines()[1:]]
    assert [(r[0], r[1]) for r in rows] == [("0", "hog_adapted"), ("0", "hog_warp"),
                                           ("0", "opencv_native"), ("1", "hog_adapted"),
                                           ("1", "hog_warp")]     # OpenCV trains nothing
    first = {r[0]: r[1] for r in (line.split(",") for line in
                                  (out / "frames_summary.csv").read_text().splitlines()[1:])}
    assert {r[1]: r[2] for r in rows if r[0] == "0"} == first    # the main table is seed 0's
    # the second seed's detectors are those trained with that seed
    m1 = SourceDetectors.load(out / "models" / "source_detectors_seed1.npz")
    ref = train_source_detectors(load_dataset(toy), seed=1, quick=True)
    assert m1.fingerprint() == ref.fingerprint()
    assert m1.fingerprint() != SourceDetectors.load(
        out / "models" / "source_detectors.npz").fingerprint()
    lamr = {(r[0], r[1]): float(r[2]) for r in rows}
    mean = np.mean([lamr["0", "hog_adapted"], lamr["1", "hog_adapted"]])
    summary = (out / "frames_summary.md").read_text()
    assert f"hog_adapted mean LAMR {mean:.3f}" in summary
    assert (out / "seeds.md").is_file() and (out / "seeds.png").is_file()
    assert json.loads((out / "run.json").read_text())["seeds"] == [0, 1]
    # bad combinations: one-line errors, nothing written
    for extra in (["--seeds", "0"],
                  ["--seeds", "2", "--model", str(out / "models" / "source_detectors.npz")]):
        assert _main(["bench", "frames", "--data", str(toy), "--out", str(tmp_path / "bad"),
                      "--quick", "--methods", "hog_adapted", *extra]) == 2
        assert not (tmp_path / "bad").exists()


def test_seed_tables_and_targets():
    from benchmark.frames.report import accuracy_targets, seed_gaps, seed_summary
    from benchmark.frames.spec import FrameMethod

    ad, wp, cv = map(FrameMethod.parse, ("hog_adapted", "hog_warp", "opencv"))
    per_seed = {3: {ad: 0.62, wp: 0.60, cv: 0.8}, 4: {ad: 0.66, wp: 0.60}}
    assert np.allclose(seed_gaps(per_seed)["hog"], [0.02, 0.06])
    results = {m: {"lamr": v} for m, v in per_seed[3].items()}
    # seed 3 alone meets the 0.03 bar, the mean (gap 0.04) does not
    assert "met" in accuracy_targets(results)[-1] and "NOT" not in accuracy_targets(results)[-1]
    line = accuracy_targets(results, per_seed)[-1]
    assert "mean LAMR 0.640" in line and "NOT met (met at 1 of 2 seeds" in line
    table = "\n".join(seed_summary(per_seed))
    assert "| hog_adapted | 0.620 | 0.660 | 0.640 | 0.028 | 0.620 - 0.660 |" in table
    assert "| opencv | 0.800 | - | 0.800 | - | 0.800 - 0.800 |" in table
    assert "| hog | +0.020 | +0.060 | +0.040 | 0.028 | +0.020 - +0.060 |" in table


def test_demo_frames_stage(toy, tmp_path):
    """The demo's last stage: bench frames, then detect through a calibration file written
    in the documented format, on every frame of the first frame's camera."""
    from benchmark.pipelines import demo_frames

    assert demo_frames(toy, tmp_path, ["--seed", "0"]) == 0
    assert (tmp_path / "frames" / "det_frames.png").is_file()
    frames = load_frames(toy)
    cam = read_calibration(tmp_path / "frames" / "camera.json")
    assert cam.to_dict() == frames[0].camera.to_dict()
    same = [f for f in frames if f.camera.to_dict() == cam.to_dict()]
    assert len(list((tmp_path / "detections" / "annotated").glob("*.png"))) == len(same) > 0
    # scored against the boxes of exactly those frames (not of every scene's frame_0.png)
    coco = json.loads((toy / "frames_coco.json").read_text())
    mine = {im["id"] for im in coco["images"]
            if any(str(f.path).endswith(im["file_name"]) for f in same)}
    ev = json.loads((tmp_path / "detections" / "evaluation.json").read_text())
    assert ev["n_gt"] + ev["n_gt_ignored"] == sum(a["image_id"] in mine
                                                  for a in coco["annotations"]) > 0
    assert ev["annotate_threshold"] is not None


def test_bench_frames_one_row_per_rule_and_object_model(toy, bench, tmp_path):
    import pandas as pd

    out = tmp_path / "rules"
    rc = _main(["bench", "frames", "--data", str(toy), "--out", str(out), "--quick",
                "--model", str(bench / "models" / "source_detectors.npz"), "--max-frames", "1",
                "--methods", "hog_adapted", "opencv_native", "--rules", "covariant", "none",
                "--object-models", "plane", "body"])
    assert rc == 0
    table = pd.read_csv(out / "frames_summary.csv", keep_default_na=False)
    assert list(table["method"]) == ["hog_adapted", "hog_adapted[S only]", "hog_adapted[body]",
                                     "hog_adapted[body, S only]", "opencv_native"]
    assert list(table["rule"]) == ["covariant", "none", "covariant", "none", ""]
    assert list(table["object_model"]) == ["plane", "plane", "body", "body", ""]
    dets = json.loads((out / "detections.json").read_text())
    # each variant is its own detector: not all the same detections
    assert len({json.dumps(d) for m, d in dets.items() if m.startswith("hog")}) > 1
    assert "hog_adapted[body]" in (out / "frames_summary.md").read_text()


def test_detect_takes_the_rule_and_the_object_model(toy, bench, tmp_path):
    import pandas as pd

    frames = load_frames(toy)
    cam = frames[0].camera
    calib = _calibration_file(cam, tmp_path / "calib.json")
    rows = {}
    for model in ("plane", "body"):
        out = tmp_path / model
        assert _main(["detect", "--calibration", str(calib), "--model",
                      str(bench / "models" / "source_detectors.npz"), "--out", str(out),
                      "--threshold", "-0.5", "--rule", "paper", "--object-model", model,
                      str(frames[0].path)]) == 0
        meta = json.loads((out / "metadata.json").read_text())
        assert (meta["rule"], meta["object_model"]) == ("paper", model)
        rows[model] = pd.read_csv(out / "detections.csv")
    assert not rows["plane"].equals(rows["body"])
    with pytest.raises(SystemExit):                          # argparse: usage and exit 2
        _main(["detect", "--calibration", str(calib), "--model",
               str(bench / "models" / "source_detectors.npz"), "--out",
               str(tmp_path / "bad"), "--object-model", "cube", str(frames[0].path)])


def test_the_recipe_changes_the_training_and_is_recorded(toy):
    from benchmark.data import load_dataset
    from benchmark.frames.methods import train_source_detectors
    from benchmark.recipes import recipe_from_record

    ds = load_dataset(toy)
    plain = train_source_detectors(ds, quick=True, frame_view="none", recipe="elevation0")
    rotated = train_source_detectors(ds, quick=True, frame_view="none", recipe="rotated")
    assert recipe_from_record(plain.training["recipe"]).name == "elevation0"
    assert recipe_from_record(rotated.training["recipe"]).name == "rotated"
    assert rotated.training["background_windows"] == 5 * plain.training["background_windows"]
    assert not np.allclose(plain.hog_weights, rotated.hog_weights)
    with pytest.raises(ValueError, match="unknown recipe 'mirrored'; choose one of"):
        train_source_detectors(ds, quick=True, recipe="mirrored")
