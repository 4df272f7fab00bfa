"""Image sources (the spec grammar, files, folders, video, camera retries, errors) and the JSON shape of 2D
messages."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from objrec2d import (
    CameraSource,
    DemoSource,
    DetectedObject2D,
    DetectedObject2DArray,
    FolderSource,
    ImageFileSource,
    Polygon,
    VideoSource,
    open_source,
)
from objrec_core import Header, SourceError, source_kinds
from objrec_core import open_source as open_any_source
from strictio import InputError


def write_images(folder, count):
    folder.mkdir()
    for i in range(count):
        cv2.imwrite(str(folder / f"f{i}.png"), np.full((8, 8, 3), i * 10, np.uint8))


def test_folder_in_natural_order_and_corrupt_files_are_reported(tmp_path, caplog):
    folder = tmp_path / "imgs"
    write_images(folder, 11)
    (folder / "f5.png").write_bytes(b"not a png")
    source = open_source(str(folder))
    assert isinstance(source, FolderSource) and source.length == 11
    frames = list(source)
    assert [int(f.data[0, 0, 0]) for f in frames] == [i * 10 for i in range(11) if i != 5]
    assert "f5.png: not a readable image" in caplog.text
    assert [p.name for p in source.skipped] == ["f5.png"]


def test_single_image_and_errors(tmp_path):
    path = tmp_path / "one.png"
    cv2.imwrite(str(path), np.zeros((5, 7, 3), np.uint8))
    source = open_source(str(path))
    assert isinstance(source, ImageFileSource) and [f.data.shape for f in source] == [(5, 7, 3)]
    bad = tmp_path / "bad.jpg"
    bad.write_bytes(b"\xff\xd8garbage")
    with pytest.raises(InputError, match=r"bad\.jpg: not a readable JPEG image: no marker at byte 2"):
        open_source(str(bad))
    with pytest.raises(SourceError, match="no such file"):
        open_source(str(tmp_path / "missing.png"))
    with pytest.raises(SourceError, match="holds no images"):
        (tmp_path / "empty").mkdir()
        open_source(str(tmp_path / "empty"))
    with pytest.raises(SourceError, match=r"camera:front: option index='front' is invalid: expected int in 0\.\.1000"):
        open_source("camera:front")
    with pytest.raises(SourceError, match=r"demo:x: option seed='x' is invalid: expected int"):
        open_source("demo:x")
    with pytest.raises(SourceError, match="no source given"):
        open_source("  ")
    with pytest.raises(SourceError, match=r"camera:99999999999999999999: option index='99999999999999999999' "
                                          r"is invalid: out of range, allowed int in 0\.\.1000"):
        open_source("camera:99999999999999999999")
    unreadable = tmp_path / "unreadable"
    write_images(unreadable, 2)
    for f in unreadable.iterdir():
        f.write_bytes(b"junk")
    with pytest.raises(SourceError, match=r"unreadable: no readable image in the folder: none of its 2 images"):
        list(open_source(str(unreadable)))


def test_video_file_is_read_to_its_end(tmp_path):
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    for i in range(12):
        writer.write(np.full((48, 64, 3), i * 20, np.uint8))
    writer.release()
    source = open_source(str(path))
    assert isinstance(source, VideoSource) and source.length == 12 and source.rate == pytest.approx(10.0)
    frames = list(source)
    assert len(frames) == 12 and frames[0].data.shape == (48, 64, 3)
    assert frames[5].stamp - frames[0].stamp == pytest.approx(0.5)


@pytest.mark.realdata
def test_real_video_file_and_its_undecodable_tail(shared_data):
    # tree.avi (Cinepak) declares 444 frames; OpenCV's FFmpeg decodes the first 68. The rest must be
    # reported, not passed over as a normal end of file: an InputError, after the frames that were read.
    frames = []
    with pytest.raises(InputError, match=r"tree\.avi: truncated or corrupt: frame (\d+) of 444 cannot") as info:
        for frame in open_source(str(shared_data / "images" / "tree.avi")):
            frames.append(frame)
    assert len(frames) > 10 and frames[0].data.shape[2] == 3
    assert f"frame {len(frames)} of 444" in str(info.value)


def test_truncated_video_is_reported(tmp_path):
    path = tmp_path / "cut.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    for i in range(40):
        writer.write(np.random.default_rng(i).integers(0, 255, (48, 64, 3), dtype=np.uint8))
    writer.release()
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    frames = []
    with pytest.raises(InputError, match=r"cut\.avi: truncated or corrupt: frame (\d+) of 40 cannot be decoded; "
                                         r"\1 of 40 frames were read"):
        for frame in open_source(str(path)):
            frames.append(frame)
    assert 5 < len(frames) < 40


class FlakyCapture:
    """A camera that delivers ``good`` frames, then nothing; reopening helps ``recover`` times."""

    opened = 0

    def __init__(self, plan):
        self.plan = plan
        FlakyCapture.opened += 1

    def isOpened(self):  # noqa: N802 - OpenCV's name
        return True

    def get(self, prop):
        return 0

    def read(self):
        if self.plan:
            return self.plan.pop(0), np.zeros((4, 4, 3), np.uint8)
        return False, None

    def release(self):
        pass


def test_a_dropped_camera_is_retried_a_bounded_number_of_times():
    plans = [[True, True, False], [True, False], [False], [False], [False]]
    source = CameraSource(0, retries=3, retry_delay=0, opener=lambda _t: FlakyCapture(plans.pop(0)))
    assert source.name == "camera:0" and source.length is None and source.rate is None
    frames = []
    with pytest.raises(SourceError, match="camera:0: camera stopped delivering frames after 3 retries"):
        for frame in source:
            frames.append(frame)
    assert len(frames) == 3  # two before the drop, one after the first reopen


def test_missing_camera_is_a_clear_error():
    with pytest.raises(SourceError, match="camera:97: cannot open camera"):
        open_source("camera:97")


def test_detected_objects_serialise_with_the_ros_nesting():
    obj = DetectedObject2D("cup", Polygon.from_xy([(1, 2), (3, 2), (3, 5)]))
    array = DetectedObject2DArray(Header(seq=7, stamp=12.25, frame_id="cam"), [obj])
    data = json.loads(array.to_json())
    assert data == {
        "header": {"seq": 7, "stamp": {"secs": 12, "nsecs": 250000000}, "frame_id": "cam"},
        "objects": [
            {
                "name": "cup",
                "polygon": {
                    "points": [
                        {"x": 1.0, "y": 2.0, "z": 0.0},
                        {"x": 3.0, "y": 2.0, "z": 0.0},
                        {"x": 3.0, "y": 5.0, "z": 0.0},
                    ]
                },
            }
        ],
    }
    back = DetectedObject2DArray.from_json(array.to_json())
    assert back.objects == [obj] and back.header == array.header
    assert obj.polygon.centroid() == pytest.approx((7 / 3, 3.0))


def test_files_that_are_not_videos_are_refused(tmp_path):
    cloud = tmp_path / "scan.pcd"
    cloud.write_text("# .PCD v0.7\nFIELDS x y z\n")
    with pytest.raises(SourceError, match=r"scan\.pcd: a source of 3d data, but this pipeline works on 2d data"):
        open_source(str(cloud))
    text = tmp_path / "notes.avi"
    text.write_text("not a video at all\n" * 100)
    with pytest.raises(SourceError, match=r"notes\.avi: cannot open video file"):
        list(open_source(str(text)))
    # A text file without a video suffix is no video either: nothing reads it, and the message says so.
    notes = tmp_path / "notes.txt"
    notes.write_text("a shopping list\n")
    with pytest.raises(SourceError, match=r"notes\.txt: no 2d source reads this \(2d sources: schemes .*demo:"):
        open_source(str(notes))
    assert source_kinds(str(notes)) == []


def test_the_spec_grammar_opens_the_demo_and_the_camera_by_their_options():
    source = open_source("demo:3,frames=4")
    assert isinstance(source, DemoSource) and source.length == 4 and source.rate == 30.0
    assert source.name == "demo:3,frames=4"
    same = DemoSource(seed=3, frames=4)
    assert [f.index for f in source] == [0, 1, 2, 3]
    assert all(np.array_equal(a.data, b.data) for a, b in zip(source, same, strict=True))
    endless = open_source("demo")
    assert endless.length is None  # frames=0, the default: endless
    with pytest.raises(TypeError, match="no known length"):
        len(endless)
    with pytest.raises(SourceError, match=r"demo:seed=1,frames=-2: option frames='-2' is invalid: out of range"):
        open_source("demo:seed=1,frames=-2")
    with pytest.raises(SourceError, match=r"demo:1,2: too many values without a key \(this source takes seed\)"):
        open_source("demo:1,2")
    with pytest.raises(SourceError, match=r"camera:index=97: cannot open camera"):
        open_source("camera:index=97")
    # The kind-free opener cannot tell which demo is meant; the shortcut can.
    with pytest.raises(SourceError, match="several kinds"):
        open_any_source("demo")
