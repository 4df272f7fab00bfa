"""The fast constructions of the per-frame messages make the same objects as the plain constructors: equal,
frozen, hashable, picklable (batch workers hand results between processes), and of the exact class."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import cv2
import numpy as np
import pytest

from objrec2d import BinaryDetector, DetectedObject2D, DetectedObject2DArray, Polygon
from objrec_core import DetectionDirector, Frame, Header, RecognitionSystem


def test_outlined_objects_equal_the_constructed_ones() -> None:
    hull = cv2.convexHull(np.array([[[10, 10]], [[40, 12]], [[38, 30]], [[12, 28]]], np.int32))
    made = DetectedObject2D.outlined("cup", [hull, [(0, 0), (5, 0), (5, 5)]], [True, False])
    plain = [
        DetectedObject2D("cup", Polygon.from_xy(hull.reshape(-1, 2).tolist()), True),
        DetectedObject2D("cup", Polygon.from_xy([(0, 0), (5, 0), (5, 5)]), False),
    ]
    assert made == plain
    assert [type(o) for o in made] == [DetectedObject2D, DetectedObject2D]
    assert [hash(o) for o in made] == [hash(o) for o in plain]
    assert made[0].polygon.xy() == [(float(x), float(y)) for x, y in hull.reshape(-1, 2)]
    assert [o.to_dict() for o in made] == [o.to_dict() for o in plain]
    assert pickle.loads(pickle.dumps(made)) == plain
    assert copy.deepcopy(made) == plain
    assert dataclasses.replace(made[0], name="mug").name == "mug"
    with pytest.raises(dataclasses.FrozenInstanceError):
        made[0].name = "mug"  # type: ignore[misc]
    assert not hasattr(made[0], "__dict__")


def test_outlined_subclass_uses_its_own_constructor() -> None:
    @dataclasses.dataclass(frozen=True)
    class Labelled(DetectedObject2D):
        pass

    made = Labelled.outlined("cup", [[(0, 0), (5, 0), (5, 5)]], [False])
    assert type(made[0]) is Labelled and made[0].polygon.xy() == [(0.0, 0.0), (5.0, 0.0), (5.0, 5.0)]


def test_fast_header_equals_the_constructed_one() -> None:
    header = Header.fast(7, 12.5, "camera", 12_500_000_001)
    assert header == Header(7, 12.5, "camera", 12_500_000_001)
    assert type(header) is Header and header.stamp_ns == 12_500_000_001
    assert pickle.loads(pickle.dumps(header)) == header
    assert header.to_dict()["stamp"] == {"secs": 12, "nsecs": 500_000_001}
    with pytest.raises(dataclasses.FrozenInstanceError):
        header.seq = 8  # type: ignore[misc]


def test_director_paths_give_the_same_arrays() -> None:
    """With an outcome sink the director takes the full record of the frame; without, the objects alone: the
    arrays are the same, frame for frame, and so is the JSON written from them."""
    image = np.zeros((120, 160), np.uint8)
    cv2.rectangle(image, (10, 10), (40, 50), 255, -1)
    cv2.circle(image, (120, 60), 20, 255, -1)
    cv2.rectangle(image, (0, 90), (30, 119), 255, -1)  # cut by the frame edge
    lean = DetectionDirector(RecognitionSystem([BinaryDetector()], object_name="blob"))
    heard: list[int] = []
    full = DetectionDirector(RecognitionSystem([BinaryDetector()], object_name="blob"),
                             outcome_sinks=[lambda header, outcomes: heard.append(outcomes[0].found)])
    for index in range(2):
        frame = Frame(image, stamp=1700000000.25 + index, index=index)
        a, b = lean.process(frame), full.process(frame)
        assert isinstance(a, DetectedObject2DArray) and a == b and a.to_json() == b.to_json()
        assert len(a.objects) == 3 and sorted(o.truncated for o in a.objects) == [False, False, True]
    assert heard == [3, 3] and lean.process(image).header.seq == 2
    assert lean.system.detect_objects(image) == lean.system.process(image).objects
