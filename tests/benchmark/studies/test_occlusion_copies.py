"""benchmark.studies.occlusion_copies: occluded copies of person crops."""

import numpy as np
import pytest

from benchmark.studies.occlusion_copies import MODES, occluded_copies, occlusion_copy


def _person(value, x0=24, x1=40):
    """A flat window of grey 100 with a person of ``value`` in columns x0..x1-1."""
    win = np.full((128, 64, 3), 100, np.uint8)
    mask = np.zeros((128, 64), bool)
    mask[20:124, x0:x1] = True
    win[mask] = value
    return win, mask


def test_a_neighbour_in_front_covers_only_its_silhouette_and_behind_leaves_the_person():
    me, my_mask = _person(200)
    other, other_mask = _person(30)
    front, mode = occlusion_copy(me, my_mask, other, other_mask, np.random.default_rng(0),
                                 mode="front")
    assert mode == "front"
    changed = (front != me).any(axis=2)
    assert changed.any() and np.isin(front[changed], (30, 100, 200)).mean() > 0.5
    assert not changed[:12].any()                     # above the neighbour's head: as was
    behind, _ = occlusion_copy(me, my_mask, other, other_mask, np.random.default_rng(0),
                               mode="behind")
    assert (behind[my_mask] == me[my_mask]).all()     # the person stays on top
    assert ((behind != me).any(axis=2) & ~my_mask).any()
    # the same draw puts the neighbour at the same place in both
    assert ((front != me).any(axis=2) & ~my_mask).sum() == \
        ((behind != me).any(axis=2) & ~my_mask).sum()


def test_a_pole_is_one_vertical_strip():
    me, my_mask = _person(200)
    out, _ = occlusion_copy(me, my_mask, me, my_mask, np.random.default_rng(3), mode="pole")
    cols = np.flatnonzero((out != me).any(axis=(0, 2)))
    assert 1 <= len(cols) <= 9 and cols[-1] - cols[0] == len(cols) - 1
    assert (out != me).any(axis=2)[:, cols].mean() > 0.9  # top to bottom
    with pytest.raises(ValueError, match="mode must be one of"):
        occlusion_copy(me, my_mask, me, my_mask, np.random.default_rng(0), mode="box")


def test_copies_take_their_neighbour_from_another_person_and_keep_the_modes_asked_for():
    people = [_person(v) for v in (10, 10, 250, 250, 130)]
    wins = [w for w, _ in people]
    masks = [m for _, m in people]
    ids = ["a", "a", "b", "b", "c"]
    copies, counts = occluded_copies(wins * 8, masks * 8, ids * 8, seed=1)
    assert len(copies) == 40 and sum(counts.values()) == 40 and set(counts) == set(MODES)
    again, _ = occluded_copies(wins * 8, masks * 8, ids * 8, seed=1)
    assert all((a == b).all() for a, b in zip(copies, again))
    nb, counts = occluded_copies(wins * 8, masks * 8, ids * 8, modes=("front", "behind"),
                                 seed=1)
    assert counts["pole"] == 0 and len(nb) == counts["front"] + counts["behind"] > 10
    kept = [k for k, c in enumerate(copies) if any((c == d).all() for d in nb)]
    for k, c in zip(kept, nb):                       # a neighbour of another person's value
        others = {10, 250, 130} - {int(wins[k % 5][60, 32, 0])}
        assert sum(int((c[:, :, 0] == v).sum()) for v in others) > 50
    poles, counts = occluded_copies(wins * 8, masks * 8, ids * 8, modes=("pole",), seed=1)
    assert len(poles) == counts["pole"] and counts["front"] == counts["behind"] == 0
    with pytest.raises(ValueError, match="at least two persons"):
        occluded_copies(wins[:2], masks[:2], ids[:2])


def test_a_dataset_without_depth_maps_is_one_usage_error(tmp_path, capsys):
    from benchmark.studies.occlusion_copies import main
    from tests.toy_frames import small_toy_frames

    data = small_toy_frames(tmp_path / "data")
    with pytest.raises(SystemExit) as exc:
        main(["--data", str(data), "--out", str(tmp_path / "out"), "--quick"])
    assert exc.value.code == 2 and "no depth maps" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
