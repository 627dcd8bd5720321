"""viewadapt.boxes: boxes through a point mapping (mapped_boxes), and their IoU (box_iou)."""

import numpy as np

from viewadapt.boxes import mapped_boxes


def test_affine_mappings_move_boxes_exactly_and_keep_scores():
    d = np.array([[10.0, 20.0, 4.0, 8.0, 0.7], [0.0, 0.0, 1.0, 2.0, -1.5]])
    assert np.array_equal(mapped_boxes(d, lambda p: p), d)
    # x -> 2x + 1, y -> 3 - y (a flip): the bounding box of the mapped outline
    got = mapped_boxes(d, lambda p: np.c_[2 * p[:, 0] + 1, 3 - p[:, 1]])
    np.testing.assert_allclose(got, [[21, -25, 8, 8, 0.7], [1, 1, 2, 2, -1.5]])


def test_a_curved_mapping_takes_the_outline_bounding_box_and_empty_stays_empty():
    # a mapping that bulges the edge midpoints: the box grows to hold them
    def bulge(p):
        q = p.copy()
        q[:, 1] -= 1.0 * np.isclose(p[:, 0], 5.0)      # the top and bottom midpoints (x = 5)
        return q

    got = mapped_boxes([[0.0, 0.0, 10.0, 4.0, 1.0]], bulge)
    np.testing.assert_allclose(got, [[0, -1, 10, 5, 1.0]])
    assert mapped_boxes(np.zeros((0, 5)), bulge).shape == (0, 5)


def test_iou_of_boxes():
    from viewadapt.boxes import box_iou

    a = np.array([[0, 0, 10, 10], [20, 20, 5, 5]], float)
    b = np.array([[5, 0, 10, 10], [0, 0, 10, 10], [3, 3, 0, 4]], float)
    assert np.allclose(box_iou(a, b), [[50 / 150, 1.0, 0.0], [0.0, 0.0, 0.0]])
    assert box_iou(np.zeros((0, 4)), b).shape == (0, 3)
