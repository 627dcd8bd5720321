"""``benchmark.studies.sweep_geometry``: how far the plane's geometry misaligns the person under a
wrong elevation estimate, checked on maps whose answer is known."""

import numpy as np
import pytest

from benchmark.studies.sweep_geometry import (main, misalignment, misalignment_crossing,
                                              person_points)
from viewadapt.geometry import WINDOW_FEET, WINDOW_HEAD, elevation_homography


def _vertical_scale(k, about_y):
    """A pure vertical scaling by ``k`` that keeps the row ``about_y`` in place."""
    return np.array([[1.0, 0, 0], [0, k, (1 - k) * about_y], [0, 0, 1]])


def test_the_identity_is_not_misaligned_and_a_vertical_scale_is_its_log():
    assert misalignment(np.eye(3), "scale") == pytest.approx(0, abs=1e-12)
    assert misalignment(np.eye(3), "displacement") == pytest.approx(0, abs=1e-12)
    P = person_points()
    assert P[:, 1].min() == pytest.approx(WINDOW_HEAD[1])
    assert P[:, 1].max() == pytest.approx(WINDOW_FEET[1])
    for k in (0.7, 1.0 / 0.7, 1.3):
        H = _vertical_scale(k, WINDOW_FEET[1])
        # a stretch and a squash by the same factor count alike
        assert misalignment(H, "scale") == pytest.approx(abs(np.log(k)))
        want = np.mean(np.abs((k - 1) * (P[:, 1] - WINDOW_FEET[1])))
        assert misalignment(H, "displacement") == pytest.approx(want)
    with pytest.raises(ValueError, match="unknown measure 'area'"):
        misalignment(np.eye(3), "area")


def test_the_crossing_is_where_the_wrong_estimate_misaligns_as_much_as_none():
    truth = np.pi / 4
    for measure in ("scale", "displacement"):
        e = misalignment_crossing(truth, measure=measure)
        assert truth < e < np.pi / 2
        H = elevation_homography(0.0, truth)
        unadapted = misalignment(H, measure)

        def adapted(est):
            return misalignment(np.linalg.inv(elevation_homography(0.0, est)) @ H, measure)

        assert adapted(truth) == pytest.approx(0, abs=1e-9)    # the right estimate: none
        assert adapted(e) >= unadapted > adapted(e - 1e-3)
    # the steeper the truth, the more the unadapted detector is misaligned, and the crossing
    # moves further above it
    lo = misalignment_crossing(np.pi / 8) - np.pi / 8
    hi = misalignment_crossing(np.pi / 4) - np.pi / 4
    assert 0 < lo < hi
    with pytest.raises(ValueError, match="need 0 <= source < truth"):
        misalignment_crossing(0.0)


def test_the_study_prints_a_row_per_truth_and_refuses_a_bad_one(capsys):
    assert main(["--truths", "0.5", "0.785"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 4 and out[2].startswith("| 0.500 |") and out[3].startswith("| 0.785 |")
    cross = misalignment_crossing(0.785, measure="scale") - 0.785
    assert f"+{cross:.3f} |" in out[3]
    with pytest.raises(SystemExit) as exc:
        main(["--truths", "0"])
    err = capsys.readouterr()
    assert exc.value.code == 2 and not err.out
    assert err.err.strip().splitlines() == [
        "python -m benchmark.studies.sweep_geometry: error: need 0 <= source < truth < pi/2, "
        "got source 0.0, truth 0.0"]
