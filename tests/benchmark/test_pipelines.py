"""``viewadapt demo``: its preset, its stages and the closing summary it prints."""

from __future__ import annotations

import argparse
import math

import pandas as pd
import pytest

from benchmark.crops.report import closing_summary
from generator.sampling import preset_config

Q = math.pi / 4


def _fake_results(out):
    """A results directory as `bench crossval` writes it (only the columns the summary
    reads): hog shows the effect, acf does not and its oracle is not best."""
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for det, mrs in (("hog", dict(unadapted=0.62, adapted=0.41, **{"image warping": 0.45},
                                  synthesised=0.30, oracle=0.05)),
                     ("acf", dict(unadapted=0.50, adapted=0.48, oracle=0.49))):
        for m, v in mrs.items():
            rows.append({"detector": det, "source_elevation": Q if m == "oracle" else 0.0,
                         "target_elevation": Q, "method": m, "mr_at_fppw_0.01": v,
                         "ci_low": v - 0.05, "ci_high": v + 0.05, "n_pos": 162})
    # an ablation and another source must not appear
    rows.append(dict(rows[1], method="adapted[S only]", **{"mr_at_fppw_0.01": 0.01}))
    rows.append(dict(rows[0], source_elevation=math.pi / 8, **{"mr_at_fppw_0.01": 0.2}))
    pd.DataFrame(rows).to_csv(out / "summary.csv", index=False)
    pairs = [("hog", 0.0, "adapted", "unadapted", -0.21, -0.3, -0.12),
             ("hog", 0.0, "image warping", "unadapted", -0.17, -0.25, -0.1),
             ("hog", math.pi / 8, "adapted", "unadapted", 0.5, 0.4, 0.6),
             ("acf", 0.0, "adapted", "unadapted", -0.02, -0.09, 0.05)]
    pd.DataFrame([dict(detector=d, source_elevation=s, target_elevation=Q, method_a=a,
                       method_b=b, diff=x, ci_low=lo, ci_high=hi, p_a_better=0.5)
                  for d, s, a, b, x, lo, hi in pairs]).to_csv(out / "paired_differences.csv",
                                                             index=False)
    return out


def test_closing_summary_lines(tmp_path):
    lines = closing_summary(_fake_results(tmp_path / "r"))
    assert lines == [
        "hog 0→π/4, miss rate at 10⁻² fppw (162 test positives): unadapted 0.620, adapted "
        "0.410, image warping 0.450, synthesised 0.300, oracle 0.050",
        "  oracle (trained on the target view) is best",
        "  adapted − unadapted -0.210, paired 95% interval [-0.300, -0.120]: adapted is "
        "better than unadapted",
        "acf 0→π/4, miss rate at 10⁻² fppw (162 test positives): unadapted 0.500, adapted "
        "0.480, oracle 0.490",
        "  oracle is NOT best: adapted is lower",
        "  adapted − unadapted -0.020, paired 95% interval [-0.090, +0.050]: it includes 0, "
        "so this run cannot tell adapted from unadapted",
        "not shown at this size for acf: this run shows no difference either way; more test "
        "persons and scenes (e.g. the paper-scale dataset) give narrower intervals",
    ]
    # the source elevation selects the rows; a worse adapted detector is said so
    pi8 = closing_summary(tmp_path / "r", source=math.pi / 8)
    assert pi8[0].startswith("hog π/8→π/4") and "unadapted 0.200" in pi8[0]
    assert pi8[-1].endswith("adapted is WORSE than unadapted")


def test_demo_preset_has_the_headline_elevations_and_enough_positives():
    cfg = preset_config("demo")
    assert cfg.elevations == pytest.approx((0.0, Q))
    assert cfg.n_persons * cfg.n_scenes * cfg.instances >= 150   # test positives at pi/4
    assert cfg.n_persons >= 9 and cfg.n_scenes >= 3 and cfg.frames >= 1
    from viewadapt.cli import build_parser

    a = build_parser().parse_args(["generate", "--preset", "demo", "--out", "x"])
    assert a.preset == "demo"
    assert build_parser().parse_args(["demo", "--out", "x"]).jobs == -1   # all cores


def test_demo_runs_its_stages_and_ends_with_the_summary(tmp_path, monkeypatch, capsys):
    import benchmark.pipelines as cli

    calls = []

    def fake_main(argv):
        calls.append(argv)
        if argv[:2] == ["bench", "crossval"]:
            _fake_results(tmp_path / "demo" / "results")
        return 0

    monkeypatch.setattr(cli, "main", fake_main)
    monkeypatch.setattr(cli, "blender_available", lambda: True)
    monkeypatch.setattr(cli, "demo_frames", lambda data, out, extra: calls.append(
        ["frames", str(data)] + extra) or 0)
    from benchmark.recipes import get_recipe

    args = argparse.Namespace(out=tmp_path / "demo", seed=3, jobs=2, toy=False,
                              recipe=get_recipe("elevation0"))
    assert cli._cmd_demo(args) == 0
    assert [c[:2] for c in calls] == [["generate", "--preset"], ["bench", "crossval"],
                                      ["frames", str(tmp_path / "demo" / "data")]]
    assert calls[0][2] == "demo" and "--renderer" in calls[0]
    assert all(x in calls[1] for x in cli.DEMO_CROSSVAL)
    assert all(c[c.index("--seed") + 1] == "3" and c[c.index("--jobs") + 1] == "2"
               for c in calls)
    # the stages that train get the recipe asked for; rendering trains nothing
    assert "--recipe" not in calls[0]
    assert all(c[c.index("--recipe") + 1] == "elevation0" for c in calls[1:])
    tail = capsys.readouterr().out.rstrip().splitlines()
    summary = tail[tail.index(next(t for t in tail if t.startswith("== viewadapt demo"))):]
    assert 5 <= len(summary) <= 12
    assert summary[1:-1] == closing_summary(tmp_path / "demo" / "results")
    assert "report.md" in summary[-1] and "det_" in summary[-1]
    # a failing stage stops the demo with its exit code
    calls.clear()
    monkeypatch.setattr(cli, "main", lambda argv: calls.append(argv) or
                        (2 if argv[0] == "bench" else 0))
    args.out = tmp_path / "demo2"
    assert cli._cmd_demo(args) == 2 and len(calls) == 2
