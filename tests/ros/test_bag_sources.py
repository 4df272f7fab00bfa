"""Bags and MCAP files as sources: recordings written here with rosbags (ROS 1, ROS 2 sqlite3 and MCAP, bare
MCAP), read back through ``bag:`` and plain paths, frame for frame equal to what was recorded."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest

from objrec_core import SourceError, open_source, source_kinds
from objrec_ros import RecordingError, list_topics, open_recording
from objrec_ros.decode import (
    DecodeError,
    Intrinsics,
    depth_to_points,
    image_array,
    image_to_bgr,
    pointcloud2_arrays,
)

DETECT = [sys.executable, "-m", "objrec_apps.detect"]
T0 = 1_700_000_000.0  # log time of a recording's first message, seconds
PERIOD = 0.1
#: Header stamps lag the log times (a driver stamps at capture, the recorder logs at arrival).
LAG = 0.004


def log_ns(i: int) -> int:
    return round((T0 + i * PERIOD) * 1e9)


def head_ns(i: int) -> int:
    return round((T0 + i * PERIOD - LAG) * 1e9)


def head_s(i: int) -> float:
    ns = head_ns(i)
    return ns // 10**9 + (ns % 10**9) * 1e-9


def frames_of(spec: str, kind: str) -> list:
    with open_source(spec, kind) as source:
        return list(source)


# -- images ---------------------------------------------------------------------------------------------------
def _gray(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)


def _with_alpha(image: np.ndarray, i: int) -> np.ndarray:
    alpha = np.full((*image.shape[:2], 1), 40 + i, dtype=np.uint8)
    return np.concatenate([image, alpha], axis=2)


#: topic -> (encoding, the pixels as recorded from a BGR frame, the frame objrec should give, options)
IMAGE_CASES = {
    "/bgr8": ("bgr8", lambda im, i: im, lambda im: im, {}),
    "/rgb8": ("rgb8", lambda im, i: im[..., ::-1], lambda im: im, {}),
    "/bgra8": ("bgra8", _with_alpha, lambda im: im, {}),
    "/rgba8": ("rgba8", lambda im, i: _with_alpha(im[..., ::-1], i), lambda im: im, {}),
    "/mono8": ("mono8", lambda im, i: _gray(im), _gray, {}),
    "/mono16": ("mono16", lambda im, i: _gray(im).astype(np.uint16) * 257, _gray, {}),
    "/mono16_big": ("mono16", lambda im, i: _gray(im).astype(np.uint16) * 257, _gray, {"bigendian": True}),
    "/bgr8_padded": ("bgr8", lambda im, i: im, lambda im: im, {"pad": 13}),
}


@pytest.fixture(scope="module", params=["ros1", "sqlite3", "mcap", "mcap-file"])
def image_recording(request, bagmaker, demo_images, tmp_path_factory):
    """One recording per format: the three demo frames on a topic per encoding, plus jpeg and png."""
    fmt = request.param
    maker = bagmaker.Messages(fmt)
    entries = []
    for i, image in enumerate(demo_images):
        for topic, (encoding, record, _, options) in IMAGE_CASES.items():
            message = maker.image(record(image, i), encoding, head_ns(i), f"cam{topic}", **options)
            entries.append(bagmaker.Entry(topic, bagmaker.IMAGE, log_ns(i), message))
        for fmt_name in ("jpeg", "png"):
            message = maker.compressed(image, fmt_name, head_ns(i), f"cam/{fmt_name}")
            entries.append(bagmaker.Entry(f"/{fmt_name}", bagmaker.COMPRESSED_IMAGE, log_ns(i), message))
    return fmt, bagmaker.write(tmp_path_factory.mktemp("images") / "images", fmt, maker, entries)


def test_images_of_every_encoding_read_back_pixel_for_pixel(image_recording, demo_images):
    fmt, path = image_recording
    for topic, (_, _, expected, _) in IMAGE_CASES.items():
        with open_source(f"bag:{path},topic={topic}", "2d") as source:
            assert source.length == 3
            assert source.rate == pytest.approx(1 / PERIOD, rel=1e-6)
            frames = list(source)
        assert len(frames) == 3, topic
        for i, frame in enumerate(frames):
            want = expected(demo_images[i])
            assert frame.data.dtype == np.uint8 and frame.data.shape == want.shape, (fmt, topic)
            assert np.array_equal(frame.data, want), (fmt, topic, i)
            assert frame.index == i
            assert frame.stamp == pytest.approx(head_s(i), abs=1e-6)  # the header stamp, not the log time
            assert frame.stamp_ns == head_ns(i)  # exactly
            assert frame.frame_id == f"cam{topic}"
            assert frame.source == f"bag:{path},topic={topic}"


def test_compressed_images_decode_as_opencv_wrote_them(image_recording, demo_images):
    _, path = image_recording
    png = frames_of(f"bag:{path},topic=/png", "2d")
    jpeg = frames_of(f"bag:{path},topic=/jpeg", "2d")
    for i, image in enumerate(demo_images):
        assert np.array_equal(png[i].data, image)  # lossless
        assert png[i].frame_id == "cam/png" and png[i].stamp == pytest.approx(head_s(i), abs=1e-6)
        expected = cv2.imdecode(cv2.imencode(".jpg", image)[1], cv2.IMREAD_COLOR)
        assert np.array_equal(jpeg[i].data, expected)
        assert np.abs(jpeg[i].data.astype(int) - image).mean() < 4  # and it is the picture


def test_several_image_topics_need_a_choice_that_lists_them(image_recording):
    _, path = image_recording
    with pytest.raises(SourceError) as caught:
        open_source(str(path), "2d")
    message = str(caught.value)
    assert message.startswith(f"{path}: several image topics (")
    for topic in (*IMAGE_CASES, "/jpeg", "/png"):
        assert topic in message
    assert "topic=NAME" in message and "\n" not in message


def test_image_arrays_keep_depth_encodings_and_byte_order(bagmaker):
    maker = bagmaker.Messages("mcap")
    rng = np.random.default_rng(3)
    depth16 = rng.integers(0, 65535, (7, 9), dtype=np.uint16)
    depth32 = rng.uniform(0.2, 4.0, (7, 9)).astype(np.float32)
    for pixels, encoding in ((depth16, "16UC1"), (depth32, "32FC1")):
        for bigendian in (False, True):
            for pad in (0, 6):
                message = maker.image(pixels, encoding, 0, pad=pad, bigendian=bigendian)
                decoded = image_array(message)
                assert decoded.dtype == pixels.dtype and decoded.dtype.isnative
                assert np.array_equal(decoded, pixels), (encoding, bigendian, pad)
                decoded[0, 0] = 0  # the frame owns its pixels
        with pytest.raises(DecodeError, match="depth image, not a picture"):
            image_to_bgr(maker.image(pixels, encoding, 0))
    image = rng.integers(0, 255, (4, 5, 3), dtype=np.uint8)
    supported = "bgr8, rgb8, bgra8, rgba8, mono8, mono16, 16UC1, 32FC1"
    with pytest.raises(DecodeError, match=re.escape(f"image encoding 'yuv422' is not supported ({supported}")):
        image_array(maker.image(image, "yuv422", 0))
    short = maker.image(image, "bgr8", 0)
    short.data = short.data[:-5]
    with pytest.raises(DecodeError, match=r"5 x 4 bgr8 image: 55 bytes of data, 60 needed"):
        image_array(short)
    narrow = maker.image(image, "bgr8", 0)
    narrow.step = 14
    with pytest.raises(DecodeError, match="step 14 is shorter than one row of 5 bgr8 pixels"):
        image_array(narrow)


# -- point clouds ---------------------------------------------------------------------------------------------
def _sub(cloud, step: int = 8):
    """Every ``step``-th row and column of an organized demo cloud: the layout variants need not be big."""
    points = cloud.points.reshape(cloud.height, cloud.width, 3)[::step, ::step]
    colors = cloud.colors.reshape(cloud.height, cloud.width, 3)[::step, ::step]
    return points, colors


#: topic -> (which data, PointCloud2 layout options)
CLOUD_CASES = {
    # PCL's own layout: x y z at 0/4/8, packed float rgb at 16, 32-byte points; the demo cloud whole, organized
    "/pcl": ("full", {"offsets": {"x": 0, "y": 4, "z": 8, "rgb": 16}, "point_step": 32}),
    "/unorganized": ("valid", {"order": ("z", "rgb", "x", "y"), "gap": 2, "tail": 6, "rgb": "uint32"}),
    "/rgba_rows": ("sub", {"rgb_name": "rgba", "alpha": 255, "row_pad": 20, "gap": 4}),
    "/float64": ("sub", {"xyz": "float64", "order": ("y", "x", "z"), "no_colors": True}),
}


def _cloud_message(maker, case, cloud, i):
    which, options = CLOUD_CASES[case]
    options = dict(options)
    if which == "full":
        points = cloud.points.reshape(cloud.height, cloud.width, 3)
        colors = cloud.colors.reshape(cloud.height, cloud.width, 3)
    elif which == "valid":
        keep = cloud.valid_mask()
        points, colors = cloud.points[keep], cloud.colors[keep]
    else:
        points, colors = _sub(cloud)
    if options.pop("no_colors", False):
        colors = None
    return maker.cloud(points, colors, head_ns(i), f"depth{case}", **options), points, colors


@pytest.fixture(scope="module", params=["ros1", "sqlite3", "mcap", "mcap-file"])
def cloud_recording(request, bagmaker, demo_clouds, tmp_path_factory):
    fmt = request.param
    maker = bagmaker.Messages(fmt)
    entries, expected = [], {case: [] for case in CLOUD_CASES}
    for i, cloud in enumerate(demo_clouds):
        for case in CLOUD_CASES:
            message, points, colors = _cloud_message(maker, case, cloud, i)
            entries.append(bagmaker.Entry(case, bagmaker.POINT_CLOUD2, log_ns(i), message))
            expected[case].append((points, colors))
    return fmt, bagmaker.write(tmp_path_factory.mktemp("clouds") / "clouds", fmt, maker, entries), expected


def test_point_clouds_read_back_point_for_point(cloud_recording, demo_clouds):
    from objrec3d.cloud import PointCloud

    fmt, path, expected = cloud_recording
    for case in CLOUD_CASES:
        frames = frames_of(f"bag:{path},topic={case}", "3d")
        assert len(frames) == len(demo_clouds), (fmt, case)
        for i, frame in enumerate(frames):
            cloud = frame.data
            assert isinstance(cloud, PointCloud)
            points, colors = expected[case][i]
            organized = points.ndim == 3
            assert cloud.height == (points.shape[0] if organized else 1), (fmt, case)
            assert cloud.width == (points.shape[1] if organized else points.shape[0]), (fmt, case)
            np.testing.assert_array_equal(cloud.points, points.reshape(-1, 3), err_msg=f"{fmt} {case}")
            if colors is None:
                assert cloud.colors is None
            else:
                np.testing.assert_array_equal(cloud.colors, colors.reshape(-1, 3), err_msg=f"{fmt} {case}")
            assert frame.stamp == pytest.approx(head_s(i), abs=1e-6)
            assert frame.frame_id == f"depth{case}"
    # the demo cloud itself, organized and coloured, is what the recording gives back
    from objrec_core import get_kind

    full = frames_of(f"bag:{path},topic=/pcl", "3d")
    assert all(get_kind("3d").frames_equal(f.data, c) for f, c in zip(full, demo_clouds, strict=True))


def test_big_endian_and_broken_clouds_are_refused(bagmaker):
    maker = bagmaker.Messages("mcap")
    points = np.arange(12, dtype=np.float32).reshape(4, 3)
    with pytest.raises(DecodeError, match=r"big-endian PointCloud2 data \(is_bigendian is set\) is not supported"):
        pointcloud2_arrays(maker.cloud(points, None, 0, bigendian=True))
    no_z = maker.cloud(points, None, 0, order=("x", "y"))
    with pytest.raises(DecodeError, match=r"PointCloud2 without field z \(fields: x, y\)"):
        pointcloud2_arrays(no_z)
    short = maker.cloud(points, None, 0)
    short.data = short.data[:-1]
    with pytest.raises(DecodeError, match="4 x 1 PointCloud2: 47 bytes of data, 48 needed"):
        pointcloud2_arrays(short)
    outside = maker.cloud(points, None, 0)
    outside.point_step = 8
    outside.row_step = 32
    with pytest.raises(DecodeError, match=r"field 'z' \(bytes 8..12\) lies outside the point_step of 8 bytes"):
        pointcloud2_arrays(outside)


# -- depth + CameraInfo ---------------------------------------------------------------------------------------
FX, FY, CX, CY = 525.0, 520.0, 319.5, 241.25


def _depth_mm(cloud) -> np.ndarray:
    z = cloud.points[:, 2].reshape(cloud.height, cloud.width)
    return np.where(np.isfinite(z), np.round(z * 1000.0), 0).astype(np.uint16)


@pytest.mark.parametrize("fmt", ["ros1", "mcap-file"])
def test_depth_and_camera_info_make_the_rgbd_sources_cloud(fmt, bagmaker, demo_clouds, tmp_path):
    pytest.importorskip("open3d")
    maker = bagmaker.Messages(fmt)
    entries = []
    colors = [c.colors.reshape(c.height, c.width, 3) for c in demo_clouds]
    height, width = demo_clouds[0].height, demo_clouds[0].width
    entries.append(bagmaker.Entry("/cam/depth/camera_info", bagmaker.CAMERA_INFO, log_ns(0) - 10**6,
                                  maker.camera_info(width, height, FX, FY, CX, CY, head_ns(0), "depth_optical")))
    for i, cloud in enumerate(demo_clouds):
        entries.append(bagmaker.Entry("/cam/depth/image_raw", bagmaker.IMAGE, log_ns(i),
                                      maker.image(_depth_mm(cloud), "16UC1", head_ns(i), "depth_optical")))
        # the colour image arrives a little later than the depth image it belongs with, stamped the same
        entries.append(bagmaker.Entry("/cam/rgb/image_raw", bagmaker.IMAGE, log_ns(i) + 3 * 10**7,
                                      maker.image(colors[i], "rgb8", head_ns(i), "rgb_optical")))
    path = bagmaker.write(tmp_path / "rgbd", fmt, maker, entries)
    frames = frames_of(f"bag:{path},topic=/cam/depth/image_raw,color_topic=/cam/rgb/image_raw", "3d")
    assert len(frames) == 2
    from objrec3d.sources import RGBDSource

    for i, frame in enumerate(frames):
        color_png, depth_png = tmp_path / f"color{i}.png", tmp_path / f"depth{i}.png"
        cv2.imwrite(str(color_png), colors[i][..., ::-1])
        cv2.imwrite(str(depth_png), _depth_mm(demo_clouds[i]))
        intrinsics = tmp_path / "intrinsics.json"
        intrinsics.write_text(json.dumps({"width": width, "height": height,
                                          "intrinsic_matrix": [FX, 0, 0, 0, FY, 0, CX, CY, 1]}))
        expected = RGBDSource("rgbd", str(color_png), str(depth_png), str(intrinsics)).read()
        assert (frame.data.width, frame.data.height) == (width, height)
        np.testing.assert_array_equal(frame.data.points, expected.points)
        np.testing.assert_array_equal(frame.data.colors, expected.colors)  # paired with its own colour image
        assert frame.stamp == pytest.approx(head_s(i), abs=1e-6) and frame.frame_id == "depth_optical"
    # without a colour topic: the same points, no colours; the only CameraInfo topic is found by itself
    plain = frames_of(str(path), "3d")
    assert plain[1].data.colors is None
    np.testing.assert_array_equal(plain[1].data.points, frames[1].data.points)


def test_float_depth_is_metres(bagmaker, tmp_path):
    maker = bagmaker.Messages("sqlite3")
    depth = np.array([[1.5, 0.0, np.nan], [2.0, -1.0, 0.75]], dtype=np.float32)
    entries = [bagmaker.Entry("/info", bagmaker.CAMERA_INFO, log_ns(0), maker.camera_info(3, 2, 2.0, 4.0, 1.0, 0.5,
                                                                                          head_ns(0))),
               bagmaker.Entry("/depth", bagmaker.IMAGE, log_ns(0), maker.image(depth, "32FC1", head_ns(0)))]
    path = bagmaker.write(tmp_path / "float", "sqlite3", maker, entries)
    (frame,) = frames_of(f"bag:{path}", "3d")
    points = frame.data.points.reshape(2, 3, 3)
    assert points[0, 0].tolist() == [(0 - 1.0) * 1.5 / 2.0, (0 - 0.5) * 1.5 / 4.0, 1.5]
    assert points[1, 2].tolist() == [(2 - 1.0) * 0.75 / 2.0, (1 - 0.5) * 0.75 / 4.0, 0.75]
    assert np.isnan(points[0, 1:]).all() and np.isnan(points[1, 1]).all()  # 0, NaN and negative: no return
    expected = depth_to_points(depth, Intrinsics(2.0, 4.0, 1.0, 0.5), 1.0)
    np.testing.assert_array_equal(points, expected)


# -- choosing topics ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def mixed_recording(bagmaker, tmp_path_factory):
    """A robot's recording: colour, depth and its CameraInfo, a second (compressed) camera, a PointCloud2,
    and a topic of a type no ROS distribution has, whose definition the recording lacks."""
    maker = bagmaker.Messages("sqlite3")
    rng = np.random.default_rng(1)
    image = rng.integers(0, 255, (6, 8, 3), dtype=np.uint8)
    entries = []
    for i in range(3):
        entries += [
            bagmaker.Entry("/cam/rgb", bagmaker.IMAGE, log_ns(i), maker.image(image, "bgr8", head_ns(i))),
            bagmaker.Entry("/cam/depth", bagmaker.IMAGE, log_ns(i),
                           maker.image(np.full((6, 8), 900 + i, np.uint16), "16UC1", head_ns(i))),
            bagmaker.Entry("/cam/camera_info", bagmaker.CAMERA_INFO, log_ns(i),
                           maker.camera_info(8, 6, 10.0, 10.0, 4.0, 3.0, head_ns(i))),
            bagmaker.Entry("/cam2/rgb", bagmaker.COMPRESSED_IMAGE, log_ns(i),
                           maker.compressed(image, "png", head_ns(i))),
            bagmaker.Entry("/points", bagmaker.POINT_CLOUD2, log_ns(i),
                           maker.cloud(rng.uniform(0, 1, (5, 3)), None, head_ns(i))),
            bagmaker.Entry("/blob", bagmaker.BLOB_TYPE, log_ns(i), maker.blob(i)),
        ]
    path = bagmaker.write(tmp_path_factory.mktemp("mixed") / "mixed", "sqlite3", maker, entries)
    bagmaker.drop_definition(path, bagmaker.BLOB_TYPE)
    return path


@pytest.mark.parametrize(
    ("options", "kind", "fragment"),
    [
        ("", "2d", "several image topics (/cam/rgb, /cam2/rgb); choose one with bag:"),  # depth is no picture
        (",topic=/nothing", "2d", "no topic /nothing (image topics: /cam/rgb, /cam2/rgb)"),
        (",topic=/cam/depth", "2d", "/cam/depth: message 0: 16UC1 is a depth image, not a picture"),
        (",topic=/points", "2d", "topic /points holds sensor_msgs/msg/PointCloud2, which a 2d bag source cannot "
                                 "read (sensor_msgs/Image or sensor_msgs/CompressedImage; image topics: /cam/rgb"),
        (",topic=/blob", "2d", "topic /blob holds acme_msgs/msg/Blob, which a 2d bag source cannot read"),
        ("", "3d", "several point-cloud topics (/points, /cam/depth)"),
        (",topic=/cam/rgb", "3d", "topic /cam/rgb holds bgr8 images, not depth (16UC1, mono16 or 32FC1"),
        (",topic=/points,info_topic=/cam/camera_info", "3d", "info_topic=/cam/camera_info goes with a depth image"),
        (",topic=/cam/depth,info_topic=/cam/rgb", "3d", "info_topic /cam/rgb holds sensor_msgs/msg/Image, not "
                                                         "sensor_msgs/CameraInfo"),
        (",topic=/cam/depth,color_topic=/cam2/rgb", "3d", "color_topic /cam2/rgb holds "
                                                           "sensor_msgs/msg/CompressedImage, not sensor_msgs/Image"),
        (",start=0.2,end=0.1", "2d", "end=0.1 must come after start=0.2"),
        (",start=5", "2d", "start=5 lies past the end of the recording (0.200 s)"),
        (",rate=-1", "2d", "option rate='-1' is invalid: out of range"),
        (",colour=1", "2d", "unknown option 'colour' (options: path, topic, start, end, rate)"),
    ],
)
def test_topic_choice_and_option_mistakes_are_one_line(mixed_recording, options, kind, fragment):
    with pytest.raises(SourceError) as caught:
        open_source(f"bag:{mixed_recording}{options}", kind)
    assert fragment in str(caught.value)
    assert "\n" not in str(caught.value)


def test_chosen_topics_read(mixed_recording):
    (first, *_) = frames_of(f"bag:{mixed_recording},topic=/cam2/rgb", "2d")
    assert first.data.shape == (6, 8, 3)
    clouds = frames_of(f"bag:{mixed_recording},topic=/points", "3d")
    assert [len(f.data) for f in clouds] == [5, 5, 5]
    depth = frames_of(f"bag:{mixed_recording},topic=/cam/depth", "3d")  # /cam/camera_info found by itself
    assert [float(np.nanmax(f.data.points[:, 2])) for f in depth] == pytest.approx([0.9, 0.901, 0.902])
    with open_recording(mixed_recording) as recording:
        assert [(t.name, t.msgtype, t.count) for t in recording.topics()] == [
            ("/blob", "acme_msgs/msg/Blob", 3), ("/cam/camera_info", "sensor_msgs/msg/CameraInfo", 3),
            ("/cam/depth", "sensor_msgs/msg/Image", 3), ("/cam/rgb", "sensor_msgs/msg/Image", 3),
            ("/cam2/rgb", "sensor_msgs/msg/CompressedImage", 3), ("/points", "sensor_msgs/msg/PointCloud2", 3),
        ]
        assert recording.format == "ROS 2 bag (sqlite3)" and recording.message_count == 18
        assert recording.duration == pytest.approx(0.2, abs=1e-6)
        raw = list(recording.raw_messages("/blob"))  # undecoded: no definition needed
        assert [(t, n) for t, n, _, _ in raw] == [("/blob", log_ns(i)) for i in range(3)]
        with pytest.raises(RecordingError, match="topic /blob: message type acme_msgs/msg/Blob is neither defined "
                                                 "in the recording nor a standard ROS type"):
            list(recording.messages("/blob"))


def test_list_topics_is_a_table_of_topics_types_and_counts(mixed_recording):
    lines = list_topics(mixed_recording).splitlines()
    assert lines[0].split() == ["topic", "type", "messages"]
    assert lines[1].split() == ["/blob", "acme_msgs/msg/Blob", "3"]
    assert lines[5].split() == ["/cam2/rgb", "sensor_msgs/msg/CompressedImage", "3"]
    assert lines[-1] == "ROS 2 bag (sqlite3), 6 topics, 18 messages, 0.200 s"
    assert len({line.index("sensor_msgs") for line in lines[2:7]}) == 1  # aligned columns


@pytest.mark.parametrize("fmt", ["ros1", "sqlite3", "mcap", "mcap-file"])
def test_plain_paths_choose_the_bag_source(fmt, bagmaker, tmp_path):
    from objrec2d.bag_source import ImageBagSource
    from objrec3d.bag_source import CloudBagSource

    maker = bagmaker.Messages(fmt)
    image = np.arange(24, dtype=np.uint8).reshape(2, 4, 3)
    entries = [bagmaker.Entry("/img", bagmaker.IMAGE, log_ns(0), maker.image(image, "bgr8", head_ns(0))),
               bagmaker.Entry("/pts", bagmaker.POINT_CLOUD2, log_ns(1),
                              maker.cloud(np.ones((3, 3)), None, head_ns(1), "lidar"))]
    path = bagmaker.write(tmp_path / "plain", fmt, maker, entries)
    if path.is_dir():  # a ROS 2 bag folder beats the folder-of-images source even with a picture inside
        (path / "snapshot.png").write_bytes(cv2.imencode(".png", image)[1].tobytes())
    assert source_kinds(str(path)) == ["2d", "3d"]
    with open_source(str(path), "2d") as source:
        assert isinstance(source, ImageBagSource)
        (frame,) = list(source)
        assert np.array_equal(frame.data, image)
    with open_source(str(path), "3d") as source:
        assert isinstance(source, CloudBagSource)
        (frame,) = list(source)
        assert frame.frame_id == "lidar" and len(frame.data) == 3


# -- window and pace ------------------------------------------------------------------------------------------
def test_start_end_window_rate_and_pace(bagmaker, tmp_path, monkeypatch):
    maker = bagmaker.Messages("mcap")
    entries = [bagmaker.Entry("/img", bagmaker.IMAGE, log_ns(i),
                              maker.image(np.full((2, 3), i, np.uint8), "mono8", head_ns(i), "cam"))
               for i in range(10)]
    path = bagmaker.write(tmp_path / "ten", "mcap", maker, entries)
    with open_source(f"bag:{path},start=0.25,end=0.65", "2d") as source:
        assert source.length == 4
        assert source.rate == pytest.approx(10.0)
        frames = list(source)
    assert [int(f.data[0, 0]) for f in frames] == [3, 4, 5, 6]
    assert [f.index for f in frames] == [0, 1, 2, 3]
    assert frames[0].stamp == pytest.approx(head_s(3), abs=1e-6)
    with open_recording(path) as recording:
        assert [int(m.data[0]) for _, m in recording.messages("/img", start=0.85)] == [9]
        assert [t for t, _ in recording.messages("/img", end=0.1)] == [log_ns(0)]
    started = time.monotonic()
    paced = frames_of(f"bag:{path},start=0.6,rate=2", "2d")  # 0.3 s of recording at twice the speed
    elapsed = time.monotonic() - started
    assert len(paced) == 4 and elapsed >= 0.15 - 0.01  # a lower bound: a loaded machine only adds to it
    sleeps: list[float] = []  # rate=0: as fast as read, not the recording's 0.9 s: no sleep at all (counted)
    monkeypatch.setattr(time, "sleep", sleeps.append)
    assert len(frames_of(str(path), "2d")) == 10
    monkeypatch.undo()
    assert sleeps == []
    with pytest.raises(SourceError, match=r"topic /img has no messages between 0.85 s and 0.88 s"):
        open_source(f"bag:{path},start=0.85,end=0.88", "2d")


def test_zero_header_stamps_fall_back_to_log_times_and_sources_replay(bagmaker, tmp_path):
    maker = bagmaker.Messages("ros1")
    entries = [bagmaker.Entry("/img", bagmaker.IMAGE, log_ns(i), maker.image(np.full((2, 2), i, np.uint8), "mono8",
                                                                              0, ""))
               for i in range(3)]
    path = bagmaker.write(tmp_path / "unstamped", "ros1", maker, entries)
    with open_source(str(path), "2d") as source:
        first, second = list(source), list(source)  # each iteration reads the recording again
    assert [f.stamp for f in first] == pytest.approx([log_ns(i) / 1e9 for i in range(3)], abs=1e-6)
    assert [f.frame_id for f in first] == ["", "", ""]
    assert [int(f.data[0, 0]) for f in second] == [0, 1, 2]


def test_a_message_broken_mid_recording_is_named(bagmaker, tmp_path):
    maker = bagmaker.Messages("mcap")
    image = np.zeros((2, 3, 3), np.uint8)
    entries = [bagmaker.Entry("/img", bagmaker.IMAGE, log_ns(i),
                              maker.image(image, "yuv422" if i == 2 else "bgr8", head_ns(i)))
               for i in range(4)]
    path = bagmaker.write(tmp_path / "mid", "mcap", maker, entries)
    frames = []
    with open_source(str(path), "2d") as source, pytest.raises(SourceError) as caught:  # opens: message 0 is fine
        frames.extend(source)
    assert len(frames) == 2
    assert str(caught.value) == f"{path}: /img: message 2: image encoding 'yuv422' is not supported " \
                                "(bgr8, rgb8, bgra8, rgba8, mono8, mono16, 16UC1, 32FC1, 8UC1, 8UC3, 8UC4)"


# -- broken recordings ----------------------------------------------------------------------------------------
def _small_recording(bagmaker, base, fmt):
    maker = bagmaker.Messages(fmt)
    rng = np.random.default_rng(0)
    entries = [bagmaker.Entry("/img", bagmaker.IMAGE, log_ns(i),
                              maker.image(rng.integers(0, 255, (120, 160, 3), dtype=np.uint8), "bgr8", head_ns(i)))
               for i in range(4)]
    return bagmaker.write(base, fmt, maker, entries)


@pytest.mark.parametrize(
    ("case", "fragment"),
    [
        ("missing .bag", "ROS 1 bag not found"),
        ("empty .bag", "not a readable ROS 1 bag (truncated or corrupt?): File "),
        ("truncated .bag", "not a readable ROS 1 bag (truncated or corrupt?): Bag index looks damaged"),
        ("truncated .mcap", "not a readable MCAP file (truncated or corrupt?): File end magic is invalid"),
        ("truncated mcap folder", "not a readable ROS 2 bag (mcap) (truncated or corrupt?)"),
        ("truncated sqlite3 folder", "not a readable ROS 2 bag (sqlite3) (truncated or corrupt?)"),
        ("folder without metadata", "a folder without metadata.yaml is not a ROS 2 bag"),
        ("other metadata.yaml", "metadata.yaml: not a ROS 2 bag's metadata"),
        ("text as .bag", "not a readable ROS 1 bag (truncated or corrupt?): File magic is invalid"),
        ("FIFO as .bag", "ROS 1 bag: is a FIFO (named pipe), not a regular file"),
        ("image file", "not a recording (a .bag or .mcap file, or a ROS 2 bag folder"),
    ],
)
def test_broken_recordings_give_one_clear_line(case, fragment, bagmaker, tmp_path):
    if case == "missing .bag":
        path = tmp_path / "missing.bag"
    elif case == "empty .bag":
        path = tmp_path / "empty.bag"
        path.write_bytes(b"")
    elif case == "text as .bag":
        path = tmp_path / "notes.bag"
        path.write_text("not a bag\n")
    elif case == "FIFO as .bag":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no FIFOs here")
        path = tmp_path / "pipe.bag"
        os.mkfifo(path)
    elif case == "folder without metadata":
        path = tmp_path / "folder"
        path.mkdir()
    elif case == "other metadata.yaml":
        path = tmp_path / "other"
        path.mkdir()
        (path / "metadata.yaml").write_text("name: a camera calibration\n")
    elif case == "image file":
        path = tmp_path / "picture.png"
        path.write_bytes(b"")
    else:
        fmt = {"truncated .bag": "ros1", "truncated .mcap": "mcap-file", "truncated mcap folder": "mcap",
               "truncated sqlite3 folder": "sqlite3"}[case]
        path = _small_recording(bagmaker, tmp_path / "cut", fmt)
        bagmaker.truncate(path, 0.6)
    with pytest.raises(RecordingError) as caught:
        open_recording(path)
    assert str(caught.value).startswith(f"{path}: ")
    assert fragment in str(caught.value)
    assert "\n" not in str(caught.value)
    assert "('" not in str(caught.value)  # rosbags' wrapped tuples are unwrapped
    assert isinstance(caught.value, SourceError)


# -- objrec-detect --------------------------------------------------------------------------------------------
def _detect(args, cwd):
    return subprocess.run([*DETECT, *args], capture_output=True, text=True, cwd=cwd, timeout=120)


def test_detect_on_a_bag_finds_what_the_image_files_give(bagmaker, demo_images, project_root, tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for i, image in enumerate(demo_images):
        cv2.imwrite(str(folder / f"frame{i}.png"), image)
    files = _detect(["params/hsv_demo.yaml", "--source", str(folder)], project_root)
    assert files.returncode == 0, files.stderr
    expected = [json.loads(line) for line in files.stdout.splitlines()]
    assert len(expected) == 3 and all(line["objects"] for line in expected)
    for fmt in ("ros1", "mcap-file"):
        maker = bagmaker.Messages(fmt)
        entries = [bagmaker.Entry("/camera/color/image_raw", bagmaker.IMAGE, log_ns(i),
                                  maker.image(image[..., ::-1], "rgb8", head_ns(i), "camera_color_optical_frame"))
                   for i, image in enumerate(demo_images)]
        path = bagmaker.write(tmp_path / f"demo_{fmt}", fmt, maker, entries)
        result = _detect(["params/hsv_demo.yaml", "--source", str(path)], project_root)
        assert result.returncode == 0, result.stderr
        lines = [json.loads(line) for line in result.stdout.splitlines()]
        assert [line["objects"] for line in lines] == [line["objects"] for line in expected], fmt
        for i, line in enumerate(lines):
            header = line["header"]
            assert header["frame_id"] == "camera_color_optical_frame"
            # frame stamps are float seconds: at 1.7e9 s they hold the nanoseconds to within 0.24 µs
            assert header["stamp"]["secs"] == head_ns(i) // 10**9
            assert header["stamp"]["nsecs"] == pytest.approx(head_ns(i) % 10**9, abs=300)
        assert "3 frames" in result.stderr


@pytest.fixture(scope="module")
def broken_for_detect(bagmaker, tmp_path_factory):
    """Recordings objrec-detect must refuse with one line: their paths by case."""
    root = tmp_path_factory.mktemp("broken")
    paths = {}
    paths["truncated"] = _small_recording(bagmaker, root / "truncated", "ros1")
    bagmaker.truncate(paths["truncated"], 0.5)
    maker = bagmaker.Messages("sqlite3")
    entries = [bagmaker.Entry("/blob", bagmaker.BLOB_TYPE, log_ns(i), maker.blob(i)) for i in range(2)]
    entries.append(bagmaker.Entry("/cam/info", bagmaker.CAMERA_INFO, log_ns(0),
                                  maker.camera_info(4, 3, 1.0, 1.0, 1.0, 1.0, head_ns(0))))
    paths["no usable topic"] = bagmaker.write(root / "nothing", "sqlite3", maker, entries)
    bagmaker.drop_definition(paths["no usable topic"], bagmaker.BLOB_TYPE)
    maker = bagmaker.Messages("mcap-file")
    cloud = maker.cloud(np.ones((4, 3), np.float32), None, head_ns(0), bigendian=True)
    paths["big-endian"] = bagmaker.write(root / "big", "mcap-file", maker,
                                         [bagmaker.Entry("/points", bagmaker.POINT_CLOUD2, log_ns(0), cloud)])
    return paths


@pytest.mark.parametrize(
    ("case", "params", "options", "fragment"),
    [
        ("truncated", "hsv_demo", "", "not a readable ROS 1 bag (truncated or corrupt?): Bag index looks damaged"),
        ("no usable topic", "hsv_demo", "", "no image topic (sensor_msgs/Image or sensor_msgs/CompressedImage); its "
                                            "topics: /blob (acme_msgs/msg/Blob), /cam/info"),
        ("no usable topic", "hsv_demo", ",topic=/blob", "topic /blob holds acme_msgs/msg/Blob, which a 2d bag source "
                                                        "cannot read"),
        ("big-endian", "shape_demo", "", "/points: message 0: big-endian PointCloud2 data (is_bigendian is set) is "
                                         "not supported"),
    ],
)
def test_detect_exits_2_with_one_line_on_a_bad_recording(broken_for_detect, project_root, case, params, options,
                                                        fragment):
    path = broken_for_detect[case]
    result = _detect([f"params/{params}.yaml", "--source", f"bag:{path}{options}"], project_root)
    assert result.returncode == 2, result.stderr
    assert fragment in result.stderr
    assert str(path) in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr
    assert result.stdout == ""


def test_without_rosbags_a_bag_names_the_extra_and_other_sources_do_not_notice(bagmaker, project_root, tmp_path):
    path = _small_recording(bagmaker, tmp_path / "small", "ros1")
    block = "import sys; sys.modules['rosbags'] = None\nfrom objrec_apps.detect import main\n"
    for source, code in ((str(path), 2), ("demo", 0)):
        program = block + f"raise SystemExit(main(['params/hsv_demo.yaml', '--source', {source!r}, '-n', '1']))"
        result = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, cwd=project_root,
                                timeout=120)
        assert result.returncode == code, result.stderr
        if code:
            assert result.stderr.strip() == (f"objrec-detect: error: {path}: reading ROS bags and MCAP files needs "
                                             "rosbags: install the ros extra (pip install 'objrec[ros]')")
        else:
            assert "cannot be loaded" not in result.stderr and len(result.stdout.splitlines()) == 1
