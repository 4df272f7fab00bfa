"""Identities across frames: objects that stay keep their id, new ones get a new one, the message carries it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from objrec3d import DetectedObject3D, DetectedObject3DArray, OrientedBox, Point, Pose
from objrec3d.tracking import IdentityTracker, min_cost_assignment
from objrec_core import Header

NAME = "thing"  # one detector: every object carries its name, so only geometry tells them apart


def cylinder(centre, radius: float, height: float, name: str = NAME) -> DetectedObject3D:
    box = OrientedBox(Pose(Point(*map(float, centre))), 2 * radius, height, 2 * radius)
    return DetectedObject3D(name, box, "cylinder", radius, 500)


def sphere(centre, radius: float, name: str = NAME) -> DetectedObject3D:
    box = OrientedBox(Pose(Point(*map(float, centre))), 2 * radius, 2 * radius, 2 * radius)
    return DetectedObject3D(name, box, "sphere", radius, 500)


def drifting_stream(seed: int) -> list[list[tuple[str, DetectedObject3D]]]:
    """20 frames of (truth label, detection), shuffled in each frame: a mug drifting 3 mm per frame, a ball
    drifting 2 mm the other way that is missed in frames 6 and 7, a can standing still, and a bottle that comes
    into view at frame 12. Centres jitter by 2 mm, radii by 1 mm, visible heights by 1 cm."""
    rng = np.random.default_rng(seed)
    frames = []
    def near(x: float, y: float, z: float) -> np.ndarray:
        return np.array([x, y, z]) + rng.normal(0.0, 0.002, 3)

    for k in range(20):
        found = [
            ("mug", cylinder(near(0.003 * k, 0.0, 0.8), 0.040 + rng.normal(0, 0.001), 0.10 + rng.normal(0, 0.01))),
            ("can", cylinder(near(-0.12, 0.0, 0.9), 0.033 + rng.normal(0, 0.001), 0.12 + rng.normal(0, 0.01))),
        ]
        if k not in (6, 7):
            found.append(("ball", sphere(near(0.15, 0.02 - 0.002 * k, 0.85), 0.03 + rng.normal(0, 0.001))))
        if k >= 12:
            found.append(("bottle", cylinder(near(0.05, -0.15, 0.8), 0.035 + rng.normal(0, 0.001),
                                             0.20 + rng.normal(0, 0.01))))
        frames.append([found[i] for i in rng.permutation(len(found))])
    return frames


def run(tracker: IdentityTracker, frames) -> list[dict[str, str]]:
    """Per frame: truth label -> the id the tracker gave that detection."""
    out = []
    for frame in frames:
        tracked = tracker.assign([obj for _, obj in frame])
        assert [o.center.tolist() for o in tracked] == [o.center.tolist() for _, o in frame]  # order and objects kept
        out.append({label: obj.id for (label, _), obj in zip(frame, tracked, strict=True)})
    return out


def test_objects_that_stay_keep_their_ids_over_20_frames_and_a_newcomer_gets_a_new_one():
    frames = drifting_stream(seed=3)
    ids = run(IdentityTracker(), frames)
    per_label: dict[str, set[str]] = {}
    for frame in ids:
        for label, given in frame.items():
            per_label.setdefault(label, set()).add(given)
    assert all(len(given) == 1 for given in per_label.values()), per_label  # nobody changed id, ball included
    assert sorted(ids[0].values()) == ["1", "2", "3"]
    assert "ball" not in ids[6] and "ball" not in ids[7] and ids[8]["ball"] == ids[0]["ball"]
    assert ids[12]["bottle"] == "4"  # the next number, never one of the others'
    # deterministic: the same frames give the same ids, whatever the seed of the noise
    assert run(IdentityTracker(), frames) == ids
    for seed in range(10):
        per_seed = run(IdentityTracker(), drifting_stream(seed))
        assert all(frame[label] == per_seed[0].get(label, per_seed[-1][label])
                   for frame in per_seed for label in frame), seed


def test_crossing_paths_of_a_large_and_a_small_object_do_not_swap_their_ids():
    # a 16 cm wide cylinder and a 4 cm wide one pass through the same place, 2 cm per frame each
    frames = [[("big", cylinder([-0.19 + 0.02 * k, 0.0, 0.9], 0.08, 0.20)),
               ("small", cylinder([0.19 - 0.02 * k, 0.0, 0.91], 0.02, 0.05))] for k in range(20)]
    centre = {label: [obj.center for f in frames for lab, obj in f if lab == label] for label in ("big", "small")}
    # the paths do cross: after the crossing each new centre lies nearer the other object's last one
    fooled = [k for k in range(1, 20)
              if np.linalg.norm(centre["small"][k] - centre["big"][k - 1])
              < np.linalg.norm(centre["small"][k] - centre["small"][k - 1])]
    assert fooled == [10]
    ids = run(IdentityTracker(), frames)
    assert all(frame == ids[0] for frame in ids) and ids[0]["big"] != ids[0]["small"]


def test_the_matching_keeps_as_many_identities_as_possible_not_the_nearest_first():
    tracker = IdentityTracker()
    a, b = tracker.assign([cylinder([0.0, 0.0, 1.0], 0.02, 0.04), cylinder([0.06, 0.0, 1.0], 0.02, 0.04)])
    # both move right: the first lands nearer b's old place, which a nearest-first match would give to b,
    # leaving a's new place out of b's reach and a without its id
    moved = tracker.assign([cylinder([0.032, 0.0, 1.0], 0.02, 0.04), cylinder([0.09, 0.0, 1.0], 0.02, 0.04)])
    assert [o.id for o in moved] == [a.id, b.id] == ["1", "2"]


def test_the_assignment_is_as_cheap_as_scipys_on_random_and_tied_matrices():
    linear_sum_assignment = pytest.importorskip("scipy.optimize").linear_sum_assignment
    rng = np.random.default_rng(1)
    for trial in range(300):
        cost = rng.uniform(0.0, 1.0, rng.integers(1, 9, 2))
        if trial % 3 == 0:
            cost = np.round(cost * 3)  # many equal costs
        pairs = min_cost_assignment(cost)
        rows, cols = zip(*pairs, strict=True)
        assert len(pairs) == min(cost.shape) == len(set(rows)) == len(set(cols))
        best_rows, best_cols = linear_sum_assignment(cost)
        assert cost[list(rows), list(cols)].sum() == pytest.approx(cost[best_rows, best_cols].sum(), abs=1e-12)


def test_an_object_unseen_for_more_than_max_missed_frames_is_forgotten():
    mug = cylinder([0.0, 0.0, 0.8], 0.04, 0.1)
    tracker = IdentityTracker(max_missed=2)
    assert tracker.assign([mug])[0].id == "1"
    for _ in range(2):
        assert tracker.assign([]) == [] and tracker.tracked == 1
    assert tracker.assign([mug])[0].id == "1"  # missed twice: still known
    for _ in range(3):
        tracker.assign([])
    assert tracker.tracked == 0
    assert tracker.assign([mug])[0].id == "2"  # missed three times: a new object
    tracker.reset()
    assert tracker.tracked == 0 and tracker.assign([mug])[0].id == "1"


@pytest.mark.parametrize(("label", "after"), [
    ("another shape at the same place", sphere([0.0, 0.0, 0.8], 0.04)),
    ("another name at the same place", cylinder([0.0, 0.0, 0.8], 0.04, 0.1, name="other")),
    ("twice the radius", cylinder([0.0, 0.0, 0.8], 0.08, 0.1)),
    ("a jump of more than its size", cylinder([0.09, 0.0, 0.8], 0.04, 0.1)),
])
def test_what_is_not_the_same_object_gets_a_new_id(label, after):
    tracker = IdentityTracker()
    tracker.assign([cylinder([0.0, 0.0, 0.8], 0.04, 0.1)])
    assert tracker.assign([after])[0].id == "2", label


def test_a_cylinder_whose_visible_height_changes_stays_the_same_object():
    tracker = IdentityTracker()
    heights = [0.10, 0.04, 0.12, 0.06]  # partly hidden now and then: the box changes, the radius does not
    assert [tracker.assign([cylinder([0.0, 0.0, 0.8], 0.04, h)])[0].id for h in heights] == ["1"] * 4


@pytest.mark.parametrize("settings", [{"max_shift": 0.0}, {"max_shift": float("inf")}, {"max_size_ratio": 0.9},
                                      {"max_missed": -1}])
def test_settings_that_cannot_work_are_refused(settings):
    with pytest.raises(ValueError, match=next(iter(settings))):
        IdentityTracker(**settings)


def test_the_json_line_carries_the_id_beside_the_name_and_reads_back():
    tracked = IdentityTracker().assign([cylinder([0.0, 0.0, 0.8], 0.04, 0.1), sphere([0.2, 0.0, 0.8], 0.03)])
    untracked = DetectedObject3D("box", OrientedBox(Pose(Point(0.0, 0.1, 1.0)), 0.1, 0.1, 0.1))
    array = DetectedObject3DArray(Header(seq=4, stamp=1.5), [*tracked, untracked])
    line = array.to_json()
    data = json.loads(line)
    assert [o["id"] for o in data["objects"]] == ["1", "2", ""]
    assert list(data["objects"][0]) == ["name", "id", "box", "shape", "radius", "inliers"]
    assert list(data["objects"][2]) == ["name", "id", "box"]  # no shape fit: the shape fields stay out
    assert DetectedObject3DArray.from_json(line).objects == array.objects
    # a line written before objects had ids reads as untracked objects
    del data["objects"][0]["id"]
    assert DetectedObject3DArray.from_dict(data).objects[0] == DetectedObject3D(**{**vars(tracked[0]), "id": ""})


def test_the_typed_ros_message_carries_the_id(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.highlevel import AnyReader

    from objrec_ros.output import open_detection_writer

    tracker = IdentityTracker()
    arrays = [DetectedObject3DArray(Header(seq=k, stamp=1_700_000_000.0 + k),
                                    tracker.assign([cylinder([0.001 * k, 0.0, 0.8], 0.04, 0.1)]))
              for k in range(3)]
    arrays[2].objects.append(sphere([0.3, 0.0, 0.8], 0.03))  # untracked: an empty id
    out = tmp_path / "tracked.mcap"
    with open_detection_writer(out, DetectedObject3DArray, "/objrec/shape") as writer:
        for array in arrays:
            writer(array)
    with AnyReader([out]) as reader:
        messages = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert [[o.id for o in m.objects] for m in messages] == [["1"], ["1"], ["1", ""]]


def test_the_shipped_shape_system_keeps_its_ids_over_20_demo_frames(project_root):
    """The demo's sphere moves about 8 cm and back over these frames; the cylinder stands still."""
    from objrec_core import build_system, open_source

    system = build_system(project_root / "params" / "shape_demo.yaml")
    with open_source("demo:frames=20", "3d") as source:
        frames = [[(o.name, o.id, float(o.box.pose.position.x)) for o in system.process(f.data).objects]
                  for f in source]
    assert [[(name, id_) for name, id_, _ in frame] for frame in frames] == [
        [("cylinder", "cylinder-1"), ("sphere", "sphere-1")]] * 20
    sphere_x = [frame[1][2] for frame in frames]
    assert max(sphere_x) - min(sphere_x) > 0.05  # it did move, and kept its id
