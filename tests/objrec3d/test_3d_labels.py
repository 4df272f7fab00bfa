"""Labels of neighbouring objects in an annotated cloud never cover each other."""

from __future__ import annotations

import numpy as np

from objrec3d.annotate import _put_label


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def test_labels_at_the_same_place_are_stacked_without_overlap_and_stay_in_the_image() -> None:
    image = np.full((480, 640, 3), 200, np.uint8)
    placed: list = []
    for text, anchor in [("object (cylinder) r=39.7mm", (320, 100)), ("object (sphere) r=59.5mm", (330, 104)),
                         ("object (plane) 1.59x1.09m", (335, 98)), ("edge", (636, 5))]:
        _put_label(image, text, anchor, placed)
    assert len(placed) == 4
    for i in range(4):
        for j in range(i):
            assert not _overlap(placed[i], placed[j]), (placed[i], placed[j])
    assert all(box[0] >= 0 and box[1] >= 0 and box[2] <= 640 and box[3] <= 480 for box in placed)
    assert (image[placed[0][1] + 2:placed[0][3] - 2, placed[0][0] + 2:placed[0][2] - 2] < 200).any()  # drawn
