"""Extending a finished dataset by more frames or more background views (the rendering
side: ``tests/test_reliability.py``)."""

import pytest

from generator.resume import check_resumable
from generator.sampling import plan_dataset, preset_config
from generator.specs import load_roster, load_scenes


def _meta(seed=0, **config):
    return {"format": "viewadapt-dataset", "seed": seed,
            "config": preset_config("tiny", **config).to_dict()}


def test_more_background_views_extend_the_plan_and_keep_the_first():
    scenes, roster = load_scenes(), load_roster()
    few = plan_dataset(preset_config("tiny"), 0, scenes=scenes, persons=roster)
    more = plan_dataset(preset_config("tiny", backgrounds_per_scene=4), 0, scenes=scenes,
                        persons=roster)
    bgs = {u.uid: u.samples for u in more.units if u.kind == "background"}
    n_few = few.config.backgrounds_per_scene
    for u in few.units:
        if u.kind == "background":
            assert len(bgs[u.uid]) == 4
            for a, b in zip(u.samples, bgs[u.uid][:n_few]):
                assert (a.seed, a.ground_xy, a.azimuth, a.lighting) == \
                       (b.seed, b.ground_xy, b.azimuth, b.lighting)
    # the persons do not depend on the number of background views
    persons = lambda p: [(s.seed, s.ground_xy, s.rotation) for u in p.units
                         if u.kind == "person" for s in u.samples]
    assert persons(few) == persons(more)


def test_growing_frames_or_backgrounds_extends_and_shrinking_is_refused(tmp_path):
    old = _meta(backgrounds_per_scene=2, frames=3)
    assert check_resumable(old, _meta(backgrounds_per_scene=2, frames=3), tmp_path) is False
    assert check_resumable(old, _meta(backgrounds_per_scene=5, frames=3), tmp_path) is True
    assert check_resumable(old, _meta(backgrounds_per_scene=5, frames=4), tmp_path) is True
    with pytest.raises(ValueError, match=r"2 background views per scene; --backgrounds 1 "
                                         r"would leave background views out"):
        check_resumable(old, _meta(backgrounds_per_scene=1, frames=3), tmp_path)
    with pytest.raises(ValueError, match=r"3 frames; --frames 2 would leave frames out "
                                         r"\(frames can only be added\)"):
        check_resumable(old, _meta(backgrounds_per_scene=4, frames=2), tmp_path)
    # growing them beside another change is no extension
    with pytest.raises(ValueError, match=r"--instances 1 \(this run: 2\)"):
        check_resumable(old, _meta(backgrounds_per_scene=4, frames=3, instances=2), tmp_path)
    with pytest.raises(ValueError, match=r"--seed 0 \(this run: 1\)"):
        check_resumable(old, _meta(seed=1, backgrounds_per_scene=4, frames=3), tmp_path)


def test_the_cli_sets_background_views_and_refuses_zero(tmp_path, monkeypatch):
    import argparse

    from generator import cli, pipeline
    from viewadapt.cli import common_parser

    seen = {}

    def fake_generate(config, seed, out, **kw):
        seen["config"] = config
        raise SystemExit(0)

    monkeypatch.setattr(pipeline, "generate", fake_generate)
    p = argparse.ArgumentParser(prog="viewadapt")
    cli.register(p.add_subparsers(dest="command"), common_parser())
    args = p.parse_args(["generate", "--out", str(tmp_path / "o"), "--preset", "paper",
                         "--backgrounds", "28"])
    with pytest.raises(SystemExit):
        args.func(args)
    assert seen["config"].backgrounds_per_scene == 28 and seen["config"].n_scenes == 13
    args = p.parse_args(["generate", "--out", str(tmp_path / "o"), "--backgrounds", "0"])
    with pytest.raises(ValueError, match="--backgrounds must be at least 1"):
        args.func(args)
