"""Every study's command reports a user's mistake as one line on stderr, named by its program
(``python -m benchmark.studies.NAME: error: ...``), exits 2, and writes nothing."""

from __future__ import annotations

import importlib

import pytest

#: study -> arguments naming inputs that do not exist (each study's own checks refuse them)
BAD_INPUTS = {
    "average_models": ["{d}/nope0.npz", "{d}/nope1.npz", "--out", "{d}/o.npz"],
    "cascade_threshold": ["--data", "{d}/nope", "--out", "{d}/o"],
    "contributions": ["--data", "{d}/nope", "--out", "{d}/o"],
    "distortion_study": ["--data", "{d}/nope", "--out", "{d}/o"],
    "footage_memory": ["--data", "{d}/nope"],
    "footage_pitch": ["{d}/nope", "--calibration", "{d}/nope.xml", "--boxes", "{d}/nope.txt",
                      "--out", "{d}/o"],
    "footage_speed": ["--data", "{d}/nope"],
    "frames_intervals": ["{d}/nope", "--data", "{d}/nope"],
    "frames_vs_crops": ["--data", "{d}/nope", "--out", "{d}/o", "--quiet"],
    "frameview_separation": ["--data", "{d}/nope", "--model", "{d}/nope.npz"],
    "negatives": ["--data", "{d}/nope", "--out", "{d}/o"],
    "sweep_decomposition": ["--data", "{d}/nope", "--out", "{d}/o"],
    "sweep_intervals": ["{d}/nope"],
}


@pytest.mark.parametrize("study", sorted(BAD_INPUTS))
def test_a_study_reports_bad_input_as_one_line_on_stderr(study, tmp_path, capsys):
    main = importlib.import_module(f"benchmark.studies.{study}").main
    argv = [a.format(d=tmp_path) for a in BAD_INPUTS[study]]
    assert main(argv) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in cap.err, cap.err
    assert lines[0].startswith(f"python -m benchmark.studies.{study}: error: "), lines[0]
    assert "nope" in lines[0]                      # it names what is wrong
    assert sorted(p.name for p in tmp_path.iterdir()) == []
