"""`viewadapt detect --boxes` as real datasets need it: MOTChallenge ground truth by frame
number (image names or a video's frames), ignore flags and regions, counted and ignored
ground truth, block-bootstrap intervals; with --lens undistort the boxes are written and
scored in the input's own (distorted) pixels; image inputs record no fps.

One toy camera (benchmark.toyframes, no Blender) with six frames and a quickly trained
source model, its operators cached once for every run."""

import json
from types import SimpleNamespace

import cv2
import numpy as np
import pandas as pd
import pytest

from viewadapt.camera.distortion import Undistortion, distort_image, distort_points
from viewadapt.cli import main
from viewadapt.commands.detect import boxes_in_input_pixels
from viewadapt.detect.evaluation import (
    block_bootstrap, evaluate_detections, evaluation_rows, evaluation_summary, in_regions,
)
from viewadapt.io.boxes import FrameBoxes
from tests.toy_frames import mot_toy_clip
from tests.box_iou import iou as box_iou

N_FRAMES = 6
DIST = [-0.35, 0.0, 0.0, 0.0, 0.0]          # strong barrel: corners move ~ a quarter radius
#: an ignore region over the frame's left quarter
REGION = {"polygons": [[[-1, -1], [48, -1], [48, 145], [-1, 145]]]}


# ------------------------------------------------------------------ the protocol's pieces


def test_in_regions_even_odd():
    square = [[0, 0], [10, 0], [10, 10], [0, 10]]
    concave = [[20, 0], [30, 0], [30, 10], [25, 5], [20, 10]]           # a notch at the top
    pts = [[5, 5], [11, 5], [-1, 5], [21, 8], [25, 8], [25, 3], [28, 7]]
    assert in_regions(pts, [square]).tolist() == [True] + [False] * 6
    assert in_regions(pts, [square, concave]).tolist() == [True, False, False, True, False,
                                                           True, True]
    assert in_regions(pts, []).tolist() == [False] * 7 and in_regions(np.zeros((0, 2)),
                                                                     [square]).shape == (0,)


def test_regions_drop_detections_and_ignore_ground_truth():
    size = (200, 150)
    gt = [(np.array([[10, 20, 20, 60], [100, 20, 20, 60], [150, 20, 20, 60]]), np.zeros(3),
           size, np.array([False, False, True]))]
    dets = [np.array([[10, 20, 20, 60, 0.9],       # on the gt in the region: dropped
                      [60, 20, 20, 60, 0.8],       # false positive in the region: dropped
                      [100, 20, 20, 60, 0.7],      # hit
                      [150, 20, 20, 60, 0.6]])]    # on the ignored gt: absorbed
    region = [np.array([[0, 0], [90, 0], [90, 150], [0, 150]], float)]
    dts, gts = evaluation_rows(dets, gt, regions=region)
    assert dts[0][:, 4].tolist() == [0.7, 0.6] and gts[0][:, 4].tolist() == [1, 0, 1]
    ev = evaluate_detections(dets, gt, regions=region)
    assert (ev["n_gt"], ev["n_gt_ignored"]) == (1, 2)
    assert ev["miss_rate"][-1] == 0 and ev["fppi"][-1] == 0            # one hit, no FP
    plain = evaluate_detections(dets, gt)
    assert (plain["n_gt"], plain["n_gt_ignored"]) == (2, 1) and plain["fppi"][-1] == 1


def test_block_bootstrap_is_seeded_and_brackets_the_estimate():
    rng = np.random.default_rng(1)
    gts, dts = [], []
    for _ in range(60):
        g = np.c_[rng.uniform(0, 300, (4, 2)), np.full((4, 1), 20.0), np.full((4, 1), 50.0),
                  np.zeros((4, 1))]
        hit = g[rng.random(4) < 0.7, :4]
        fp = np.c_[rng.uniform(0, 300, (2, 2)), np.full((2, 1), 20.0), np.full((2, 1), 50.0)]
        d = np.r_[hit, fp]
        dts.append(np.c_[d, rng.random(len(d))])
        gts.append(g)
    a = block_bootstrap(dts, gts, block=10, draws=200, seed=3)
    assert a == block_bootstrap(dts, gts, block=10, draws=200, seed=3)
    assert a != block_bootstrap(dts, gts, block=10, draws=200, seed=4)
    from viewadapt.metrics import evaluate_frames

    lamr = evaluate_frames(dts, gts)["lamr"]
    assert a["lamr"][0] < lamr < a["lamr"][1] and a["draws_used"] == 200
    for k in ("miss_rate_at_0.1_fppi", "miss_rate_at_1_fppi"):
        assert 0 <= a[k][0] <= a[k][1] <= 1
    with pytest.raises(ValueError, match="at least 1 frame"):
        block_bootstrap(dts, gts, block=0)


def test_evaluation_summary_agrees_with_the_plain_evaluation_and_the_bootstrap():
    rng = np.random.default_rng(2)
    size = (320, 240)
    truth, dets = [], []
    for _ in range(30):
        xy = rng.uniform(0, 250, (3, 2))
        boxes = np.c_[xy, np.full((3, 1), 20.0), np.full((3, 1), 60.0)]
        truth.append(FrameBoxes(boxes, np.zeros(3), np.array([False, False, rng.random() < 0.3])))
        found = boxes[rng.random(3) < 0.6]
        fp = np.c_[rng.uniform(0, 250, (2, 2)), np.full((2, 1), 20.0), np.full((2, 1), 60.0)]
        dets.append(np.c_[np.r_[found, fp], rng.random(len(found) + 2)])
    region = [np.array([[0, 0], [60, 0], [60, 240], [0, 240]], float)]
    ev, curve = evaluation_summary(dets, truth, size, regions=region, block=5, seed=7)
    gt = [(t.boxes, t.occlusion, size, t.ignore) for t in truth]
    plain = evaluate_detections(dets, gt, regions=region)
    assert ev["lamr"] == pytest.approx(plain["lamr"]) == pytest.approx(curve["lamr"])
    assert np.allclose(curve["fppi"], plain["fppi"]) and ev["miss_rate"] == plain[
        "miss_rate"].tolist()
    assert (ev["n_gt"], ev["n_gt_ignored"]) == (plain["n_gt"], plain["n_gt_ignored"])
    ci = block_bootstrap(*evaluation_rows(dets, gt, regions=region), block=5, seed=7)
    assert ev["lamr_ci95"] == ci["lamr"] and ev["bootstrap"]["block_frames"] == 5
    with pytest.raises(ValueError, match="no ground-truth box is counted"):
        evaluation_summary([d[:0] for d in dets], [FrameBoxes.empty()] * 30, size)


def test_boxes_through_the_lens_are_undistorted_back():
    K = np.array([[130.0, 0, 95.5], [0, 130.0, 71.5], [0, 0, 1]])
    boxes = np.array([[20.0, 10, 20, 50, 0.5], [120, 60, 25, 60, -0.2]])
    assert np.allclose(boxes_in_input_pixels(boxes, K, [0.0] * 5), boxes)
    moved = boxes_in_input_pixels(boxes, K, DIST)
    und = Undistortion(K, DIST, (192, 144))
    feet = distort_points(boxes[:, :2] + boxes[:, 2:4] * [0.5, 1], K, DIST)
    for b, m, p in zip(boxes, moved, feet):       # where the lens puts the box's outline
        assert m[0] < p[0] < m[0] + m[2] and abs(p[1] - (m[1] + m[3])) < 2 and m[4] == b[4]
        back = und.undistort_points([[m[0] + m[2] / 2, m[1] + m[3]]])[0]
        assert abs(back[1] - (b[1] + b[3])) < 2
    assert boxes_in_input_pixels(np.zeros((0, 5)), K, DIST).shape == (0, 5)


# ------------------------------------------------------------------ the command


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """Six toy frames: as MOTChallenge's img1/000001.png..., as an mp4, their gt.txt (the
    last box of each frame flagged 0), a calibration and a model."""
    clip = mot_toy_clip(tmp_path_factory.mktemp("real_formats"), n_frames=N_FRAMES,
                        flag_last=True)
    root, frames, cam = clip.root, clip.frames, clip.cam
    video = root / "clip.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 10.0,
                             cam.image_size)
    for f in frames:
        writer.write(cv2.imread(str(f.path)))
    writer.release()
    regions = root / "ignore.json"
    regions.write_text(json.dumps(REGION))
    return SimpleNamespace(**vars(clip), video=video, regions=regions)


def _detect(toy, out, *argv, calibration=None, capsys=None):
    """``detect`` with the adapted operator alone (``--stage off``): these tests are about
    the evaluation and its pixels, and the quickly trained toy model scores only a few
    windows above 0 once the stage rescores them."""
    rc = main(["detect", "--calibration", str(calibration or toy.calibration), "--model",
               str(toy.model), "--cache", str(toy.cache), "--threshold", "-0.5", "--quiet",
               "--stage", "off", "--annotate", "none", "--out", str(out),
               *[str(a) for a in argv]])
    assert rc == 0
    return out


def test_mot_ground_truth_with_ignore_regions(toy, tmp_path, capsys):
    out = _detect(toy, tmp_path / "mot", "--boxes", toy.gt, "--ignore", toy.regions, toy.img1)
    printed = capsys.readouterr().out
    ev = json.loads((out / "evaluation.json").read_text())
    want = {"lamr", "lamr_ci95", "miss_rate_at_0.1_fppi", "miss_rate_at_0.1_fppi_ci95",
            "miss_rate_at_1_fppi", "miss_rate_at_1_fppi_ci95", "n_gt", "n_gt_ignored",
            "n_frames", "fppi", "miss_rate", "bootstrap", "boxes", "ignore_regions"}
    assert want <= set(ev) and ev["n_frames"] == N_FRAMES
    n_boxes = sum(len(f.gt) for f in toy.frames)
    assert ev["n_gt"] + ev["n_gt_ignored"] == n_boxes and ev["n_gt"] > 0
    # counted: not flagged 0, not in the region, and the Caltech rules
    from viewadapt.detect.evaluation import ground_truth_rows

    counted = 0
    for f in toy.frames:
        rows = ground_truth_rows(f.gt, f.occlusion * 0, f.camera.image_size)
        keep = rows[:, 4] == 0
        keep[-1] = False
        keep &= f.gt[:, 0] + f.gt[:, 2] / 2 > 48
        counted += int(keep.sum())
    assert ev["n_gt"] == counted
    for k in ("lamr", "miss_rate_at_0.1_fppi", "miss_rate_at_1_fppi"):
        lo, hi = ev[f"{k}_ci95"]
        assert 0 <= lo <= ev[k] <= hi <= 1, k
    # six frames: blocks of half the frames (not the default 10, which would leave one)
    assert ev["bootstrap"]["block_frames"] == 3 and ev["bootstrap"]["draws"] == 1000
    assert f"against {ev['n_gt']} counted boxes" in printed
    assert f"({ev['n_gt_ignored']} ignored)" in printed and (out / "det.png").is_file()
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["input"]["fps"] is None and meta["calibration_import"] is None
    # the same ground truth as a CSV by file name, without the region: more counted
    csv = tmp_path / "gt.csv"
    csv.write_text("frame,x,y,w,h,ignore\n" + "".join(
        f"{k:06d}.png,{x},{y},{w},{h},{int(j == len(f.gt) - 1)}\n"
        for k, f in enumerate(toy.frames, 1) for j, (x, y, w, h) in enumerate(f.gt)))
    ev_csv = json.loads((_detect(toy, tmp_path / "csv", "--boxes", csv, "--bootstrap-block",
                                 2, toy.img1) / "evaluation.json").read_text())
    assert ev_csv["n_gt"] > ev["n_gt"] and ev_csv["bootstrap"]["block_frames"] == 2
    assert ev_csv["n_gt"] + ev_csv["n_gt_ignored"] == n_boxes


def test_a_video_takes_its_ground_truth_by_frame_index(toy, tmp_path):
    out = _detect(toy, tmp_path / "video", "--boxes", toy.gt, toy.video)
    ev = json.loads((out / "evaluation.json").read_text())
    folder = json.loads((_detect(toy, tmp_path / "folder", "--boxes", toy.gt, toy.img1)
                         / "evaluation.json").read_text())
    assert (ev["n_gt"], ev["n_gt_ignored"]) == (folder["n_gt"], folder["n_gt_ignored"])
    assert abs(ev["lamr"] - folder["lamr"]) < 0.2          # up to the video's compression
    assert json.loads((out / "metadata.json").read_text())["input"]["fps"] == \
        pytest.approx(10.0)
    # a selection: frames 1, 3, 5 of the video are MOT frames 2, 4, 6
    sel = json.loads((_detect(toy, tmp_path / "sel", "--boxes", toy.gt, "--start", 1,
                              "--every", 2, toy.video) / "evaluation.json").read_text())
    n = sum(len(toy.frames[i].gt) for i in (1, 3, 5))
    assert sel["n_frames"] == 3 and sel["n_gt"] + sel["n_gt_ignored"] == n


def _distorted_boxes(boxes, K):
    """Ground-truth boxes of the pinhole frame in the distorted frame: 8 points of each
    box's outline through OpenCV's lens model (cv2.projectPoints), their bounding box."""
    b = np.asarray(boxes, float).reshape(-1, 4)
    u = np.array([0, 0.5, 1, 1, 1, 0.5, 0, 0])
    v = np.array([0, 0, 0, 0.5, 1, 1, 1, 0.5])
    px = np.stack([b[:, :1] + u * b[:, 2:3], b[:, 1:2] + v * b[:, 3:4]], -1).reshape(-1, 2)
    xy = (px - K[:2, 2]) / np.diag(K)[:2]
    q = cv2.projectPoints(np.c_[xy, np.ones(len(xy))], np.zeros(3), np.zeros(3), K,
                          np.array(DIST))[0].reshape(-1, 8, 2)
    return np.c_[q.min(1), q.max(1) - q.min(1)]


def test_undistorted_detection_is_scored_in_the_input_pixels(toy, tmp_path):
    """Distorted frames, their ground truth in the distorted pixels: --lens undistort
    writes (and scores) boxes that line up with it -- the boxes found on the undistorted
    frame, mapped back through the lens -- and annotates the input frames."""
    folder = tmp_path / "distorted"
    folder.mkdir()
    rows = []
    for k, f in enumerate(toy.frames, 1):
        cv2.imwrite(str(folder / f"{k:06d}.png"),
                    distort_image(cv2.imread(str(f.path)), toy.cam.K, DIST))
        rows += [f"{k:06d}.png,{x},{y},{w},{h}\n"
                 for x, y, w, h in _distorted_boxes(f.gt, toy.cam.K)]
    gt = tmp_path / "distorted_gt.csv"
    gt.write_text("frame,x,y,w,h\n" + "".join(rows))
    calib = tmp_path / "cam_dist.json"
    calib.write_text(json.dumps({**json.loads(toy.calibration.read_text()), "dist": DIST}))
    out = _detect(toy, tmp_path / "und", "--lens", "undistort", "--boxes", gt,
                  "--annotate", "frames", folder, calibration=calib)
    ev = json.loads((out / "evaluation.json").read_text())
    dets = pd.read_csv(out / "detections.csv")
    truth = pd.read_csv(gt)
    # the boxes written are those found on the pinhole frames, seen through the lens ...
    ref = pd.read_csv(_detect(toy, tmp_path / "pinhole", toy.img1) / "detections.csv")
    ref_iou = []
    for name, r in ref[ref.score > 0].groupby("source"):
        b = dets[dets.source == name][["x", "y", "w", "h"]].to_numpy()
        seen = _distorted_boxes(r[["x", "y", "w", "h"]].to_numpy(), toy.cam.K)
        ref_iou += list(box_iou(seen, b).max(1)) if len(b) else [0.0] * len(r)
    ref_iou = np.array(ref_iou)
    assert len(ref_iou) >= 10 and (ref_iou > 0.5).all() and ref_iou.mean() > 0.85, ref_iou
    # ... so they find the distorted ground truth at least as often as the pinhole boxes
    # find theirs, and line up with it better than the same boxes in the undistorted
    # frame's pixels (what was written before)
    und = Undistortion(toy.cam.K, DIST, toy.cam.image_size)
    found, found_pinhole, iou_written, iou_undistorted = 0, 0, [], []
    for k, f in enumerate(toy.frames, 1):
        name = f"{k:06d}.png"
        t = truth[truth.frame == name][["x", "y", "w", "h"]].to_numpy()
        b = dets[(dets.source == name) & (dets.score > 0)][["x", "y", "w", "h"]].to_numpy()
        r = ref[(ref.source == name) & (ref.score > 0)][["x", "y", "w", "h"]].to_numpy()
        if len(b):
            found += int((box_iou(t, b).max(1) > 0.5).sum())
            lo = und.undistort_points(b[:, :2])
            hi = und.undistort_points(b[:, :2] + b[:, 2:])
            iou_written += list(box_iou(t, b).max(1))
            iou_undistorted += list(box_iou(t, np.c_[lo, hi - lo]).max(1))
        if len(r):
            found_pinhole += int((box_iou(f.gt, r).max(1) > 0.5).sum())
    assert found_pinhole >= 8 and found >= found_pinhole - 1, (found, found_pinhole)
    assert np.mean(iou_written) > np.mean(iou_undistorted) + 0.03
    # ... and score as they do
    dts = [dets[dets.source == f"{k:06d}.png"][["x", "y", "w", "h", "score"]].to_numpy()
           for k in range(1, N_FRAMES + 1)]
    tr = [(truth[truth.frame == f"{k:06d}.png"][["x", "y", "w", "h"]].to_numpy(),
           np.zeros((truth.frame == f"{k:06d}.png").sum()), toy.cam.image_size)
          for k in range(1, N_FRAMES + 1)]
    assert evaluate_detections(dts, tr)["lamr"] == pytest.approx(ev["lamr"])
    meta = json.loads((out / "metadata.json").read_text())
    assert "input frames' pixels" in meta["undistortion"]["method"]
    # the annotated frames are the input's (distorted) frames
    shown = cv2.imread(str(out / "annotated" / "00000_000001.png")).astype(int)
    given = cv2.imread(str(folder / "000001.png")).astype(int)
    assert np.mean(np.all(shown == given, axis=2)) > 0.8


def test_a_tsai_calibration_runs_like_its_json(toy, tmp_path):
    """The toy camera written as a Tsai XML (no lens) finds the same boxes."""
    from scipy.spatial.transform import Rotation

    K, cam = toy.cam.K, toy.cam
    rx, ry, rz = Rotation.from_matrix(cam.R).as_euler("xyz")
    tx, ty, tz = cam.t * 1000
    xml = tmp_path / "toy.xml"
    xml.write_text(
        f'<Camera><Geometry width="{cam.image_size[0]}" height="{cam.image_size[1]}" '
        f'dpx="0.01" dpy="0.01"/><Intrinsic focal="{K[1, 1] * 0.01!r}" kappa1="0" '
        f'cx="{K[0, 2]!r}" cy="{K[1, 2]!r}" sx="{K[0, 0] / K[1, 1]!r}"/>'
        f'<Extrinsic tx="{tx!r}" ty="{ty!r}" tz="{tz!r}" rx="{rx!r}" ry="{ry!r}" '
        f'rz="{rz!r}"/></Camera>')
    a = pd.read_csv(_detect(toy, tmp_path / "tsai", toy.img1, calibration=xml)
                    / "detections.csv")
    b = pd.read_csv(_detect(toy, tmp_path / "json", toy.img1) / "detections.csv")
    assert len(a) == len(b) > 0
    assert np.allclose(a[["x", "y", "w", "h", "score"]], b[["x", "y", "w", "h", "score"]],
                       atol=0.02)
    meta = json.loads((tmp_path / "tsai" / "metadata.json").read_text())
    assert meta["calibration_import"]["format"] == "PETS 2009 / Tsai XML"


def test_bad_evaluation_input_is_one_line(toy, tmp_path, capfd):
    bad_gt = tmp_path / "gt.txt"
    bad_gt.write_text("1,1,10,10,20,50,1,-1,-1,-1\n2,1,10,10,20,a,1,-1,-1,-1\n")
    cases = {
        "a bad gt line": (["--boxes", bad_gt], "gt.txt line 2: column h is not a number "
                                               "('a')"),
        "--ignore alone": (["--ignore", toy.regions], "--ignore needs --boxes"),
        "--bootstrap-block 0": (["--boxes", toy.gt, "--bootstrap-block", 0],
                                "--bootstrap-block must be at least 1"),
        "a bad region": (["--boxes", toy.gt, "--ignore", bad_gt], "not valid JSON"),
    }
    for case, (argv, want) in cases.items():
        out = tmp_path / "out"
        capfd.readouterr()
        rc = main(["detect", "--calibration", str(toy.calibration), "--model", str(toy.model),
                   "--out", str(out), *[str(a) for a in argv], str(toy.img1)])
        err = capfd.readouterr().err.strip()
        assert rc == 2 and len(err.splitlines()) == 1, (case, err)
        assert err.startswith("viewadapt detect: error: ") and want in err, (case, err)
        assert not out.exists(), case


def test_frame_outcome_labels_hits_misses_and_ignored():
    from viewadapt.detect.evaluation import frame_outcome

    gt = (np.array([[10.0, 10, 20, 50], [100, 10, 20, 50], [60, 80, 20, 50]]), np.zeros(3),
          (192, 144), np.array([False, False, True]))
    dets = np.array([[10.0, 11, 20, 50, 2.0],     # on person 0: a hit
                     [150, 60, 20, 50, 1.0],      # on nothing: a false positive
                     [61, 80, 20, 50, 0.5],       # on the ignored box
                     [5, 20, 20, 50, 0.8],        # bottom-centre in the region
                     [100, 10, 20, 50, -3.0]])    # on person 1 but below the threshold
    region = [np.array([[-1, -1], [16, -1], [16, 145], [-1, 145]], float)]
    labels, status = frame_outcome(dets, gt, threshold=0.0, regions=region)
    assert labels.tolist() == [1, 0, -1, -1, -2]
    assert status.tolist() == [1, 0, -1]
    labels, status = frame_outcome(dets, gt, threshold=-5.0)
    assert labels.tolist()[4] == 1 and status.tolist() == [1, 1, -1]


def _pixels(folder, colour):
    return sum(int(np.all(cv2.imread(str(p)) == colour, axis=2).sum())
               for p in sorted(folder.glob("*.png")))


def test_annotated_frames_at_an_operating_point(toy, tmp_path, capfd):
    from viewadapt.io.outputs import DETECTION_COLOURS

    red = DETECTION_COLOURS[0]
    everything = _detect(toy, tmp_path / "all", "--boxes", toy.gt, "--annotate", "frames",
                         "--annotate-threshold=-1e9", toy.img1)
    assert _pixels(everything / "annotated", red) > 0          # false positives drawn
    none = _detect(toy, tmp_path / "none", "--boxes", toy.gt, "--annotate", "frames",
                   "--annotate-threshold", "1e9", toy.img1)
    assert _pixels(none / "annotated", red) == 0 == _pixels(none / "annotated",
                                                            DETECTION_COLOURS[1])
    at = _detect(toy, tmp_path / "fppi", "--boxes", toy.gt, "--annotate", "frames",
                 "--annotate-fppi", "0", toy.img1)
    ev = json.loads((at / "evaluation.json").read_text())
    # false positives exist (red above), so 0 FPPI cuts some of the detections away
    assert ev["annotate_threshold"] > pd.read_csv(at / "detections.csv")["score"].min()
    assert _pixels(at / "annotated", red) == 0                 # no false positive at 0 FPPI
    assert len(list((at / "annotated").glob("*.png"))) == N_FRAMES
    # the detections themselves do not depend on the operating point
    assert (at / "detections.csv").read_text() == (everything / "detections.csv").read_text()
    rc = main(["detect", "--calibration", str(toy.calibration), "--model", str(toy.model),
               "--quiet", "--annotate-fppi", "0.1", "--out", str(tmp_path / "bad"),
               str(toy.img1)])
    assert rc == 2 and "--annotate-fppi" in capfd.readouterr().err


_DAIMLER_LAYOUT = ((48, 96), (16, 16), (8, 8), (8, 8), 9)


@pytest.mark.parametrize("detector, layout, other", [("opencv", (), _DAIMLER_LAYOUT),
                                                     ("daimler", _DAIMLER_LAYOUT, ())])
def test_detect_adapts_a_hog_file_saved_by_opencv(toy, tmp_path, capfd, detector, layout,
                                                   other):
    """--detector opencv (daimler) --model takes a 64x128 (48x96, no gamma) HOGDescriptor
    file; the worker processes of --jobs read it too (the same detections); a file of the
    other layout is one line."""
    stock = {"opencv": cv2.HOGDescriptor_getDefaultPeopleDetector,
             "daimler": cv2.HOGDescriptor_getDaimlerPeopleDetector}
    hog = cv2.HOGDescriptor(*layout)
    v = np.asarray(stock[detector](), np.float32).ravel()
    hog.setSVMDetector(np.r_[v[:-1] * 1.1, v[-1] + 0.5].astype(np.float32))
    path = tmp_path / "mine.yml"
    hog.save(str(path))

    def run(out, *argv):
        return main(["detect", "--calibration", str(toy.calibration), "--detector", detector,
                     "--cache", str(toy.cache), "--threshold=-2", "--quiet", "--annotate",
                     "none", "--out", str(out), *argv, str(toy.img1)])

    assert run(tmp_path / "one", "--model", str(path)) == 0
    assert run(tmp_path / "two", "--model", str(path), "--jobs", "2") == 0
    assert run(tmp_path / "stock") == 0
    one = (tmp_path / "one" / "detections.csv").read_text()
    assert one == (tmp_path / "two" / "detections.csv").read_text()
    assert one != (tmp_path / "stock" / "detections.csv").read_text()
    meta = json.loads((tmp_path / "one" / "metadata.json").read_text())
    assert meta["model"] == str(path) and meta["model_training"] is None
    assert meta["detector"] == f"{detector}_adapted"
    wrong = cv2.HOGDescriptor(*other)
    wrong.setSVMDetector(stock["daimler" if other else "opencv"]())
    wrong.save(str(tmp_path / "wrong.yml"))
    capfd.readouterr()
    assert run(tmp_path / "bad", "--model", str(tmp_path / "wrong.yml")) == 2
    err = capfd.readouterr().err.strip()
    assert "winSize" in err and len(err.splitlines()) == 1 and not (tmp_path / "bad").exists()
