"""The JSON files the generator and the benchmark read back from folders a user can write
(``dataset.json``, ``run.json``, part files, ``frames_coco.json``, spec files) are read
within bounds: size checked before reading, nesting before parsing; one that is out of
bounds or no JSON object is a one-line error naming it (or "not ours" where the reader's
contract says so), never a ``RecursionError`` or ``AttributeError``.

Every test builds its own small files under ``tmp_path``; nothing is rendered.
"""

from __future__ import annotations

import json

import pytest

from viewadapt.io.bounded import MAX_JSON_DEPTH

#: nested far past any bound and past Python's recursion limit
DEEP = "[" * 100_000 + "]" * 100_000


def _write(path, text: str):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


# ------------------------------------------------------------------------- generate


def test_generate_refuses_a_deep_dataset_json_in_its_own_folder(tmp_path, capsys):
    from viewadapt.cli import main
    from viewadapt.io.files import running_command, write_marker

    out = tmp_path / "ds"
    out.mkdir()
    with running_command("generate"):
        write_marker(out, "generate")
    meta = _write(out / "dataset.json", DEEP)
    assert main(["generate", "--preset", "tiny", "--quiet", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("viewadapt generate: error: ") and str(meta) in err, err
    assert "nested" in err
    assert meta.read_text() == DEEP                 # refused before anything was written


# ------------------------------------------------------------------ benchmark run.json


def test_check_results_dir_refuses_a_deep_or_non_object_run_json(tmp_path):
    from benchmark.crops.command import check_results_dir

    run = _write(tmp_path / "res" / "run.json", DEEP)
    with pytest.raises(ValueError, match="run.json: JSON nested 100000 levels deep"):
        check_results_dir(run.parent, "abc")
    run.write_text("[1]")
    with pytest.raises(ValueError, match=r"run.json is corrupt \(a JSON list"):
        check_results_dir(run.parent, "abc")
    run.write_text(json.dumps({"fingerprint": "abc", "data": "d"}))
    check_results_dir(run.parent, "abc")            # a valid one: as before
    with pytest.raises(ValueError, match="holds results of another dataset"):
        check_results_dir(run.parent, "xyz")


def test_write_report_refuses_a_deep_or_non_object_run_json(tmp_path):
    from benchmark.crops.report import write_report

    res = tmp_path / "res"
    run = _write(res / "run.json", DEEP)
    with pytest.raises(ValueError, match="run.json: JSON nested"):
        write_report(res)
    run.write_text("[1]")
    with pytest.raises(ValueError, match="run.json: expected a JSON object, got a list"):
        write_report(res)
    run.write_text(json.dumps({"data": "d", "fingerprint": "f", "sweep": [1]}))
    text = write_report(res).read_text()           # a sweep that is no object: no note
    assert "Dataset: `d` (fingerprint `f`" in text and "Warning" not in text
    run.write_text(json.dumps({"data": "d", "sweep": {"incomplete_dataset": "3 missing"}}))
    assert "3 missing" in write_report(res).read_text()


# ------------------------------------------------------------------ generator files


def test_read_part_treats_a_deep_huge_or_non_object_part_file_as_not_written(tmp_path,
                                                                              monkeypatch):
    import generator.manifest as manifest

    good = json.dumps({"unit": "person/s/p", "rows": [{"path": "a.png"}], "coco": None})
    p = _write(manifest.part_path(tmp_path, "person/s/p"), good)
    assert manifest.read_part(tmp_path, "person/s/p") == json.loads(good)
    for text in (DEEP, "[1]", '"person/s/p"'):
        p.write_text(text)
        assert manifest.read_part(tmp_path, "person/s/p") is None, text
    p.write_text(good)
    monkeypatch.setattr(manifest, "MAX_INPUT_BYTES", len(good) - 1)  # refused from its size
    assert manifest.read_part(tmp_path, "person/s/p") is None


def _frame_dataset(root, coco_text: str):
    """A dataset folder with one frame row in its manifest and ``coco_text`` as its
    ``frames_coco.json`` (no image: verify reports it missing and goes on)."""
    import pandas as pd

    root.mkdir(parents=True)
    (root / "dataset.json").write_text(json.dumps({"format": "viewadapt-multiview-v1"}))
    pd.DataFrame({"path": ["frames/s/frame_0.png"], "kind": ["frame"], "width": [4],
                  "height": [4], "depth_path": [""]}).to_parquet(root / "manifest.parquet")
    (root / "frames_coco.json").write_text(coco_text)
    return root


def test_verify_reports_a_deep_dataset_json_or_frames_coco_json_as_a_problem(tmp_path):
    from generator.verify import verify_dataset

    good = json.dumps({"images": [{"file_name": "frames/s/frame_0.png"}]})
    ds = _frame_dataset(tmp_path / "ds", good)
    rep = verify_dataset(ds, decode=False, check_plan=False)
    assert not [m for f, m in rep.problems if f == "frames_coco.json"]
    for text, what in ((DEEP, "JSON nested 100000 levels deep"), ("[1]", "list indices"),
                       ('{"images": {"a": 1}}', "string indices")):
        (ds / "frames_coco.json").write_text(text)
        rep = verify_dataset(ds, decode=False, check_plan=False)
        found = dict(rep.problems)
        assert "frames_coco.json" in found and what in found["frames_coco.json"], rep.problems
    (ds / "dataset.json").write_text(DEEP)
    rep = verify_dataset(ds, decode=False, check_plan=False)
    assert rep.problems == [("dataset.json", f"unreadable: {ds / 'dataset.json'}: JSON "
                                             f"nested 100000 levels deep, more than the "
                                             f"{MAX_JSON_DEPTH} read")]
    (ds / "dataset.json").write_text("{")           # invalid JSON: reported as before
    (problem,) = verify_dataset(ds, decode=False, check_plan=False).problems
    assert problem[0] == "dataset.json" and problem[1].startswith("unreadable JSON: ")


def test_a_deep_spec_file_is_a_spec_error_naming_it(tmp_path):
    from generator.specs import SpecError, load_roster, load_scene

    scene = _write(tmp_path / "scenes" / "deep.json", DEEP)
    with pytest.raises(SpecError, match=r"deep.json: JSON nested 100000 levels deep"):
        load_scene(scene)
    roster = _write(tmp_path / "persons.json", '{"persons": ' + DEEP + "}")
    with pytest.raises(SpecError, match=r"persons.json: JSON nested 100001 levels deep"):
        load_roster(roster)


def test_frame_sheet_refuses_a_deep_or_non_object_frames_coco_json(tmp_path):
    from generator.preview import frame_sheet

    coco = _write(tmp_path / "ds" / "frames_coco.json", DEEP)
    with pytest.raises(ValueError, match="frames_coco.json: JSON nested"):
        frame_sheet(coco.parent)
    coco.write_text("[1]")
    with pytest.raises(ValueError, match="frames_coco.json: expected a JSON object"):
        frame_sheet(coco.parent)
    coco.write_text(json.dumps({"images": [], "annotations": []}))
    assert frame_sheet(coco.parent) is None         # no frames: as before


# ------------------------------------------------------------------ benchmark.data


def test_benchmark_read_json_is_bounded_and_reads_objects_only(tmp_path):
    from benchmark.data import DatasetError, load_dataset, read_json

    good = _write(tmp_path / "run.json", json.dumps({"a": [1, {"b": 2}]}))
    assert read_json(good) == {"a": [1, {"b": 2}]}
    with pytest.raises(ValueError, match=r"run.json: 20 bytes is over the 10 bytes a JSON file"):
        read_json(good, max_bytes=10)               # from its size, before reading
    deep = _write(tmp_path / "deep.json", DEEP)
    with pytest.raises(ValueError, match="deep.json: JSON nested"):
        read_json(deep)
    ds = tmp_path / "ds"
    _write(ds / "dataset.json", "[1]")
    with pytest.raises(DatasetError, match=r"dataset.json: expected a JSON object, got a list"):
        load_dataset(ds)
    (ds / "dataset.json").write_text(DEEP)
    with pytest.raises(DatasetError, match="dataset.json: JSON nested"):
        load_dataset(ds)
