import json

import cv2
import numpy as np
import pandas as pd
import pytest

from benchmark.data import load_dataset
from benchmark.studies.derived_data import (
    derive_dataset, derive_from_source_view, scale_vertically, source_view_twins,
)
from benchmark.toydata import make_toy_dataset


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    return make_toy_dataset(tmp_path_factory.mktemp("derived") / "toy", n_persons=3,
                            n_scenes=2, n_backgrounds=1, seed=3)


def test_the_derived_dataset_replaces_what_it_is_given_and_links_the_rest(toy, tmp_path):
    out = tmp_path / "out"
    grey = np.full((128, 64, 3), 77, np.uint8)
    n = derive_dataset(toy, out, "top view grey",
                       lambda r: grey if r.kind == "person" and r.elevation_index == 2 else None)
    m = pd.read_parquet(toy / "manifest.parquet")
    replaced = (m.kind == "person") & (m.elevation_index == 2)
    assert n == replaced.sum() > 0
    for r in m.itertuples():
        p = out / r.path
        if replaced[r.Index]:
            assert not p.is_symlink() and np.array_equal(cv2.imread(str(p)), grey)
        else:
            assert p.is_symlink() and p.resolve() == (toy / r.path).resolve()
    cfg = json.loads((out / "dataset.json").read_text())
    assert cfg.pop("hybrid") == "top view grey"
    assert cfg == json.loads((toy / "dataset.json").read_text())
    pd.testing.assert_frame_equal(pd.read_parquet(out / "manifest.parquet"), m)
    assert len(load_dataset(out).manifest) == len(m)         # reads as any dataset
    with pytest.raises(FileExistsError):                     # never into an existing folder
        derive_dataset(toy, out, "again", lambda r: None)


def test_each_top_view_person_has_its_source_view_twin(toy):
    m = pd.read_parquet(toy / "manifest.parquet")
    twin = source_view_twins(toy)
    tops = 0
    for r in m.itertuples():
        z = twin(r)
        if r.kind != "person" or r.elevation_index != 2:
            assert z is None
            continue
        tops += 1
        assert (z["elevation_index"], z["kind"]) == (0, "person")
        assert (z["person_id"], z["scene_id"], z["instance"]) == (r.person_id, r.scene_id,
                                                                  r.instance)
        assert (toy / z["path"]).is_file() and z["path"] != r.path
    assert tops == ((m.kind == "person") & (m.elevation_index == 2)).sum() > 0
    with pytest.raises(ValueError, match="highest elevation is 0.7854 rad, not 0.3927"):
        source_view_twins(toy, top_elevation=np.pi / 8)


def test_top_view_persons_are_made_from_their_source_view_twins(toy, tmp_path):
    """Each pi/4 person crop becomes what ``make`` returns for its elevation-0 twin's image
    (here the twin inverted), with the twin's row and its own; the rest stays linked."""
    m = pd.read_parquet(toy / "manifest.parquet")
    seen = []

    def make(img, twin, row):
        seen.append((twin["path"], row.path))
        return 255 - img

    n = derive_from_source_view(toy, tmp_path / "out", "inverted twins", make)
    top = m[(m.kind == "person") & (m.elevation_index == 2)]
    assert n == len(top) == len(seen) > 0
    twin = source_view_twins(toy)
    for r in top.itertuples():
        z = twin(r)
        assert (z["path"], r.path) in seen
        want = 255 - cv2.imread(str(toy / z["path"]), cv2.IMREAD_UNCHANGED)
        assert np.array_equal(cv2.imread(str(tmp_path / "out" / r.path),
                                         cv2.IMREAD_UNCHANGED), want)
    assert (tmp_path / "out" / m[m.kind == "background"].path.iloc[0]).is_symlink()
    with pytest.raises(ValueError, match="highest elevation"):
        derive_from_source_view(toy, tmp_path / "no", "x", make, top_elevation=0.1)
    assert not (tmp_path / "no").exists()


def test_scaling_moves_rows_about_the_centre():
    img = np.zeros((128, 64), np.float32)
    img[31:33] = 1.0                                         # a line at row 32 (y = 31.5..32.5)
    assert np.array_equal(scale_vertically(img, 1.0), img)
    for k in (0.5, 1.5):
        out = scale_vertically(img, k)
        rows = out[:, 10]
        centre = (rows * np.arange(128)).sum() / rows.sum()
        # row 31.5 of the input (its centre) maps to 63.5 + (31.5 - 63.5) k
        assert centre == pytest.approx(63.5 + (31.5 - 63.5) * k, abs=0.05)
    with pytest.raises(ValueError, match="positive"):
        scale_vertically(img, 0.0)
