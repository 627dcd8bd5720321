"""Ground truth as datasets ship it: CSV (by name or number), COCO, MOTChallenge gt.txt
(MOT15 and MOT16 columns), CAVIAR XML; image frames by file name or the number their name
ends in, a video's frames by index; ignore flags and regions; every bad file one line."""

import json

import numpy as np
import pytest

from viewadapt.io import FrameBoxes, boxes_format, read_boxes, read_ignore_regions
from viewadapt.io.bounded import MAX_INPUT_BYTES, MAX_JSON_DEPTH, json_depth

FRAMES = [f"img1/{k:06d}.jpg" for k in (1, 3, 5)]


def _write(path, text):
    path.write_text(text)
    return path


def _one_line_error(path, frames=FRAMES, **kw):
    with pytest.raises(ValueError) as exc:
        read_boxes(path, frames, **kw)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1 and str(path) in msg, msg
    return msg


# ------------------------------------------------------------------ MOTChallenge


def test_mot15_frames_by_the_number_their_name_ends_in(tmp_path):
    gt = _write(tmp_path / "gt.txt",
                "1,9,499,158,31.03,75.17,1,-4.1554,-7.3591,0\n"
                "1,15,258,219,32.9,88.7,0,-11.3,-5.6,0\n"
                "\n"
                "5,9,495,159,31,75,1,-4.27,-7.31,0\n"
                "7,9,490,160,31,75,1,-4.2,-7.3,0\n")          # frame 7 is not given
    b = read_boxes(gt, FRAMES)
    assert set(b) == {"000001.jpg", "000003.jpg", "000005.jpg"}
    assert np.allclose(b["000001.jpg"].boxes, [[499, 158, 31.03, 75.17], [258, 219, 32.9, 88.7]])
    assert b["000001.jpg"].ignore.tolist() == [False, True]          # flag 0: ignored
    assert b["000001.jpg"].occlusion.tolist() == [0, 0]
    assert len(b["000003.jpg"].boxes) == 0 and b["000003.jpg"].ignore.dtype == bool
    assert b["000005.jpg"].boxes.shape == (1, 4)
    # a video: frame k is the k-th frame (index k - 1)
    v = read_boxes(gt, None)
    assert sorted(v) == [0, 4, 6] and v[0].boxes.shape == (2, 4)
    with pytest.raises(ValueError, match="none of its frames is among the video's 3"):
        read_boxes(_write(tmp_path / "late.txt", "9,1,1,1,5,5,1,0,0,0\n"), None, n_frames=3)


def test_mot16_classes_and_visibility(tmp_path):
    lines = ["1,1,10,10,20,50,1,1,1.0",        # pedestrian: counted
             "1,2,40,10,20,50,1,1,0.2",        # barely visible: ignored
             "1,3,70,10,20,50,0,1,1.0",        # not considered: ignored
             "1,4,90,10,20,50,1,7,1.0",        # static person: ignored
             "1,5,90,10,20,50,1,8,1.0",        # distractor: ignored
             "1,6,90,10,20,50,1,2,0.9",        # person on vehicle: ignored
             "1,7,90,10,20,50,1,12,0.9",       # reflection: ignored
             "1,8,90,10,60,30,1,3,1.0",        # car: dropped
             "1,9,90,10,60,30,1,9,1.0"]        # occluder: dropped
    gt = _write(tmp_path / "gt.txt", "\n".join(lines) + "\n")
    b = read_boxes(gt, ["000001.jpg"])["000001.jpg"]
    assert len(b.boxes) == 7
    assert b.ignore.tolist() == [False, True, True, True, True, True, True]
    strict = read_boxes(gt, ["000001.jpg"], min_visibility=0.1)["000001.jpg"]
    assert strict.ignore.tolist()[:2] == [False, False]


def test_mot_errors_name_the_line_and_column(tmp_path):
    cases = {
        "1,1,10,10,20,50,1,0,0,0\n1,2,3,4,5,a,1,0,0,0\n": "line 2: column h is not a number ('a')",
        "1,1,10,10,20\n": "line 1: 5 columns",
        "1,1,10,10,20,50,1,0,0,0\n1,1,10,10,20,50,1\n": "line 2: 7 columns, the lines before "
                                                         "have 10",
        "0,1,10,10,20,50,1,0,0,0\n": "line 1: column frame must be a whole number >= 1",
        "1.5,1,10,10,20,50,1,0,0,0\n": "line 1: column frame must be a whole number",
        "1,1,10,10,-20,50,1,0,0,0\n": "line 1: the box needs a positive width",
        "1,1,10,10,20,50,1,1,1.5\n": "line 1: column visibility must lie in",
        "1,1,10,nan,20,50,1,0,0,0\n": "line 1: column y is not finite",
        "": "empty",
    }
    for text, want in cases.items():
        msg = _one_line_error(_write(tmp_path / "gt.txt", text))
        assert want in msg, (text, msg)


# ------------------------------------------------------------------ CSV and COCO


def test_csv_by_name_or_number(tmp_path):
    csv = _write(tmp_path / "boxes.csv",
                 "frame,x,y,w,h,occlusion,ignore\n"
                 "img1/000001.jpg,1,2,10,30,0.25,0\n"
                 "3,5,6,10,30,,1\n"                      # a number: the image ending in 3
                 "# a comment\n"
                 "elsewhere.jpg,1,1,5,5,0,0\n")
    b = read_boxes(csv, FRAMES)
    assert np.allclose(b["000001.jpg"].boxes, [[1, 2, 10, 30]])
    assert b["000001.jpg"].occlusion.tolist() == [0.25]
    assert b["000003.jpg"].ignore.tolist() == [True] and b["000003.jpg"].occlusion[0] == 0
    assert len(b["000005.jpg"].boxes) == 0
    # a video: numbers are 0-based frame indices (as detections.csv), names are refused
    v = read_boxes(_write(tmp_path / "v.csv", "frame,x,y,w,h\n0,1,2,3,4\n2,1,2,3,4\n"), None)
    assert sorted(v) == [0, 2]
    with pytest.raises(ValueError, match="names an image, but the input is a video"):
        read_boxes(csv, None)
    # two images ending in the same number cannot be told apart
    with pytest.raises(ValueError, match="a_3.png and b_3.png both end in 3"):
        read_boxes(csv, ["a_3.png", "b_3.png"])


def test_csv_errors_are_one_line(tmp_path):
    cases = {
        "image,x,y\nf.png,1,2\n": "lacks the column(s) frame, w, h",
        "frame,x,y,w,h\n000001.jpg,1,2,x,4\n": "line 2: column w is not a number ('x')",
        "frame,x,y,w,h\n000001.jpg,1,2,3\n": "line 2: column h is empty",
        "frame,x,y,w,h,occlusion\n000001.jpg,1,2,3,4,2\n": "line 2: column occlusion must lie",
        "frame,x,y,w,h\n000001.jpg,1,2,0,4\n": "line 2: the box needs a positive width",
        "frame,x,y,w,h\nother.jpg,1,2,3,4\n": "none of its frames (other.jpg ...) is among",
    }
    for text, want in cases.items():
        msg = _one_line_error(_write(tmp_path / "b.csv", text))
        assert want in msg, (text, msg)


def test_coco_crowds_categories_and_video_ids(tmp_path):
    coco = {"images": [{"id": 1, "file_name": "x/000001.jpg"}, {"id": 3, "file_name":
                                                                  "000003.jpg"}],
            "categories": [{"id": 1, "name": "person"}, {"id": 2, "name": "car"}],
            "annotations": [
                {"image_id": 1, "category_id": 1, "bbox": [1, 2, 10, 30], "occlusion": 0.1},
                {"image_id": 1, "category_id": 1, "bbox": [20, 2, 10, 30], "iscrowd": 1},
                {"image_id": 3, "category_id": 1, "bbox": [5, 5, 10, 30], "ignore": 1},
                {"image_id": 3, "category_id": 2, "bbox": [5, 5, 50, 30]}]}
    path = _write(tmp_path / "gt.json", json.dumps(coco))
    b = read_boxes(path, FRAMES)
    assert b["000001.jpg"].ignore.tolist() == [False, True]
    assert b["000001.jpg"].occlusion.tolist() == [0.1, 0.0]
    assert b["000003.jpg"].ignore.tolist() == [True]        # the car is not read
    v = read_boxes(path, None)                               # image id k: the k-th frame
    assert sorted(v) == [0, 2] and len(v[0].boxes) == 2
    bad = {"annotations": []}
    assert "needs the lists images and annotations" in _one_line_error(
        _write(tmp_path / "bad.json", json.dumps(bad)))
    coco["annotations"][0]["bbox"] = [1, 2, "w", 3]
    assert "annotations[0]: bbox w is not a number" in _one_line_error(
        _write(tmp_path / "bad.json", json.dumps(coco)))
    coco["annotations"][0] = {"image_id": 7, "category_id": 1, "bbox": [1, 2, 3, 4]}
    assert "annotations[0]: image_id 7 is not among images" in _one_line_error(
        _write(tmp_path / "bad.json", json.dumps(coco)))
    assert "not valid JSON" in _one_line_error(_write(tmp_path / "bad.json", '{"images": ['))


def test_a_file_name_in_several_folders_matches_by_its_folder(tmp_path):
    """The generator's frames_coco.json names every camera's frame_0.png: each image gets
    the boxes of its own folder, not of every frame_0.png; a name the file uses once still
    matches by name alone, wherever the image is."""
    coco = {"images": [{"id": 1, "file_name": "frames/carpark/frame_0.png"},
                       {"id": 2, "file_name": "frames/lobby/frame_0.png"},
                       {"id": 3, "file_name": "elsewhere/frame_1.png"}],
            "annotations": [{"image_id": 1, "bbox": [1, 2, 10, 30]},
                            {"image_id": 2, "bbox": [40, 2, 10, 30]},
                            {"image_id": 2, "bbox": [60, 2, 10, 30]},
                            {"image_id": 3, "bbox": [7, 2, 10, 30]}]}
    path = _write(tmp_path / "gt.json", json.dumps(coco))
    lobby = [tmp_path / "data" / "frames" / "lobby" / n for n in ("frame_0.png", "frame_1.png")]
    b = read_boxes(path, lobby)
    assert b["frame_0.png"].boxes[:, 0].tolist() == [40, 60]
    assert b["frame_1.png"].boxes[:, 0].tolist() == [7]
    carpark = read_boxes(path, ["data/frames/carpark/frame_0.png"])      # relative paths
    assert carpark["frame_0.png"].boxes[:, 0].tolist() == [1]
    msg = _one_line_error(path, ["somewhere/frame_0.png"])      # which frame_0.png?
    assert "none of its frames" in msg and "that folder" in msg
    msg = _one_line_error(path, ["a/frame_0.png", "b/frame_0.png"])
    assert "have the same file name" in msg


# ------------------------------------------------------------------ CAVIAR


CAVIAR = """<?xml version="1.0" encoding="UTF-8"?>
<dataset name="Walk1">
  <frame number="0">
    <objectlist>
      <object id="0">
        <orientation>90</orientation>
        <box h="40" w="16" xc="100" yc="80"/>
        <appearance>visible</appearance>
      </object>
      <object id="1"><box h="30" w="12" xc="50.5" yc="60"/></object>
    </objectlist>
    <grouplist/>
  </frame>
  <frame number="2"><objectlist/></frame>
</dataset>
"""


def test_caviar_boxes_by_frame_number(tmp_path):
    path = _write(tmp_path / "walk1.xml", CAVIAR)
    b = read_boxes(path, ["walk1_0000.jpg", "walk1_0001.jpg", "walk1_0002.jpg"])
    assert np.allclose(b["walk1_0000.jpg"].boxes, [[92, 60, 16, 40], [44.5, 45, 12, 30]])
    assert not b["walk1_0000.jpg"].ignore.any() and len(b["walk1_0002.jpg"].boxes) == 0
    assert sorted(read_boxes(path, None)) == [0]           # 0-based frame numbers
    bad = CAVIAR.replace('xc="100"', 'xc="wide"')
    assert "frame 0, object 0: box xc is not a number ('wide')" in _one_line_error(
        _write(tmp_path / "bad.xml", bad), ["walk1_0000.jpg"])
    assert "not well-formed XML" in _one_line_error(
        _write(tmp_path / "bad.xml", CAVIAR[:-20]), ["walk1_0000.jpg"])
    assert "has no <box>" in _one_line_error(_write(tmp_path / "bad.xml", CAVIAR.replace(
        '<box h="30" w="12" xc="50.5" yc="60"/>', "")), ["walk1_0000.jpg"])


# ------------------------------------------------------------------ detection, limits


def test_format_by_name_or_content(tmp_path):
    assert boxes_format(tmp_path / "gt.txt") == "mot"
    assert boxes_format(tmp_path / "x.csv") == "csv"
    for name, text, fmt in (("a", "1,1,2,3,4,5,1,0,0,0\n", "mot"), ("b", "frame,x\n", "csv"),
                            ("c", ' {"images": []}', "coco"), ("d", "<dataset/>", "caviar")):
        assert boxes_format(_write(tmp_path / name, text)) == fmt
    b = read_boxes(_write(tmp_path / "gt_no_suffix", "3,1,1,2,5,9,1,-1,-1,-1\n"), FRAMES)
    assert b["000003.jpg"].boxes.shape == (1, 4)
    assert FrameBoxes.empty().boxes.shape == (0, 4)


def test_large_and_deep_files_are_refused_in_one_line(tmp_path):
    big = tmp_path / "gt.txt"
    with open(big, "wb") as fh:                 # sparse: no 50 MB written
        fh.truncate(MAX_INPUT_BYTES + 1)
    assert "MB is over the 50 MB" in _one_line_error(big)
    deep = "[" * 100_000 + "]" * 100_000
    path = _write(tmp_path / "deep.json", '{"images": ' + deep + "}")
    assert f"more than the {MAX_JSON_DEPTH} read" in _one_line_error(path)
    assert json_depth('{"a": "[[[[", "b": [[1], {"c": "\\"]]"}]}') == 3
    regions = _write(tmp_path / "regions.json", '{"polygons": ' + deep + "}")
    with pytest.raises(ValueError, match="nested 100001 levels"):
        read_ignore_regions(regions)
    (tmp_path / "binary.csv").write_bytes(b"frame,x\n\xff\xfe")
    assert "not a UTF-8 text file" in _one_line_error(tmp_path / "binary.csv")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        read_boxes(tmp_path / "nope.txt", FRAMES)


def test_ignore_regions(tmp_path):
    path = _write(tmp_path / "ignore.json", json.dumps(
        {"description": "walkway", "polygons": [[[0, 0], [330, 0], [330, 160], [0, 160]],
                                                [[400, 400], [500, 420], [450, 500]]]}))
    polys = read_ignore_regions(path)
    assert len(polys) == 2 and polys[0].shape == (4, 2) and polys[1].dtype == np.float64
    for bad, want in (({"polygon": []}, "expected"),
                      ({"polygons": [[[0, 0], [1, 1]]]}, r"polygons\[0\] must be a list of "
                                                         "at least 3"),
                      ({"polygons": [[[0, 0], [1, 1], [2]]]}, r"polygons\[0\]\[2\] must be"),
                      ({"polygons": [[[0, 0], [1, 1], [2, "a"]]]}, "is not a number")):
        with pytest.raises(ValueError, match=want) as exc:
            read_ignore_regions(_write(tmp_path / "bad.json", json.dumps(bad)))
        assert len(str(exc.value).splitlines()) == 1
