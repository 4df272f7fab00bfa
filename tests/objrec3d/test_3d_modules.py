"""Filters, messages, parameter files, sources and bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from objrec3d import (
    DetectedObject3D,
    DetectedObject3DArray,
    DistanceFilter,
    OrientedBox,
    PlaneRemovalFilter,
    Point,
    PointCloud,
    Pose,
    Quaternion,
    ShapeDetector,
    VoxelFilter,
    demo_scene,
    open_source,
    write_pcd,
)
from objrec3d.shape_detector import axis_angle_degrees, box_rotation
from objrec_core import (
    DetectionDirector,
    ParameterError,
    ParameterFileError,
    RecognitionSystem,
    SourceError,
    build_system,
    get_kind,
)
from objrec_core import open_source as open_any_source


@pytest.fixture(scope="module")
def scene():
    return demo_scene(0)


def test_distance_filter_keeps_the_layout_and_the_band(scene) -> None:
    cloud, _ = scene
    out = DistanceFilter(min_distance=0.9, max_distance=1.2).filter(cloud)
    assert (out.width, out.height) == (640, 480)
    z = out.points[out.valid_mask(), 2]
    assert z.size > 10_000 and z.min() >= 0.9 and z.max() <= 1.2
    ranged = DistanceFilter(max_distance=1.2, measure="euclidean").filter(cloud)
    assert np.linalg.norm(ranged.points[ranged.valid_mask()], axis=1).max() <= 1.2
    assert cloud.count_valid() > out.count_valid()  # the input is untouched and larger


def test_plane_removal_removes_the_table_and_voxel_filter_thins(scene) -> None:
    cloud, truth = scene
    near = DistanceFilter(max_distance=2.0).filter(cloud)
    out = PlaneRemovalFilter().filter(near)
    assert out.is_organized
    pts = out.points[out.valid_mask()].astype(np.float64)
    height = pts @ truth.table_normal + truth.table_offset
    assert (np.abs(height) < 0.01).sum() < 0.01 * len(pts)  # hardly any table left
    assert out.count_valid() < 0.3 * near.count_valid()
    thin = VoxelFilter(leaf_size=0.02).filter(near)
    assert thin.is_organized and 0 < thin.count_valid() < 0.2 * near.count_valid()
    centroids = VoxelFilter(leaf_size=0.02, keep_organized=False).filter(near)
    assert not centroids.is_organized and len(centroids) == thin.count_valid()


@pytest.mark.parametrize("shape", ["cylinder", "sphere"])
def test_unorganized_clouds_use_neighbour_normals(scene, shape: str) -> None:
    cloud, truth = scene
    flat = PlaneRemovalFilter().filter(DistanceFilter(max_distance=2.0).filter(cloud)).compacted()
    found = ShapeDetector(shape=shape).detect(flat)
    want = truth.of_shape(shape)[0]
    assert len(found) == 1
    assert abs(found[0].radius - want.radius) < 0.004
    assert np.linalg.norm(found[0].center - want.center) < 0.02


@pytest.mark.parametrize(
    "data",
    [PointCloud.empty(), PointCloud(np.full((480, 640, 3), np.nan, np.float32)), np.zeros((0, 3)),
     np.full((10, 3), np.nan), np.zeros((50, 3))],
    ids=["empty", "all-nan-organized", "empty-array", "all-nan", "degenerate"],
)
def test_bad_clouds_give_empty_results_not_crashes(data) -> None:
    system = RecognitionSystem([DistanceFilter(), VoxelFilter(), PlaneRemovalFilter(), ShapeDetector(),
                                ShapeDetector("s", shape="sphere")])
    array = DetectionDirector(system).process(data)
    assert isinstance(array, DetectedObject3DArray) and array.objects == []


def test_messages_follow_the_ros_layout_and_round_trip_through_json() -> None:
    rotation = box_rotation(np.array([0.0, -0.8, -0.6]), np.array([0.1, 0.0, 1.0]))
    obj = DetectedObject3D("mug", OrientedBox(Pose(Point(0.1, 0.0, 1.0), Quaternion.from_matrix(rotation)),
                                              0.08, 0.1, 0.08), "cylinder", 0.04, 1234)
    array = DetectedObject3DArray(objects=[obj])
    line = array.to_json()
    data = json.loads(line)
    box = data["objects"][0]["box"]
    assert set(data) == {"header", "objects"} and set(data["header"]) == {"seq", "stamp", "frame_id"}
    assert set(box) == {"pose", "width", "height", "depth"}
    assert set(box["pose"]["orientation"]) == {"x", "y", "z", "w"}
    back = DetectedObject3DArray.from_json(line)
    assert back.objects[0] == obj
    q = obj.box.pose.orientation
    assert math.isclose(q.x**2 + q.y**2 + q.z**2 + q.w**2, 1.0, rel_tol=1e-9)
    np.testing.assert_allclose(q.as_matrix(), rotation, atol=1e-9)
    assert axis_angle_degrees(obj.axis, [0.0, -0.8, -0.6]) < 1e-6
    assert obj.axis @ -obj.center > 0  # the sign convention: toward the sensor


def test_shape_demo_parameter_file_finds_the_demo_objects(project_root) -> None:
    system = build_system(project_root / "params" / "shape_demo.yaml")
    assert system.kind == "3d" and [d.object_name for d in system.detectors] == ["cylinder", "sphere"]
    source = open_any_source("demo:frames=2", "3d")
    assert source.length == 2
    for frame, array in zip(source, DetectionDirector(system).run(source), strict=False):
        names = sorted(o.name for o in array.objects)
        assert names == ["cylinder", "sphere"]
        for obj in array.objects:
            want = frame.truth.of_shape(obj.shape)[0]
            assert abs(obj.radius - want.radius) < 0.003
            image = get_kind("3d").annotate(frame, array)
            assert image.shape == (480, 640, 3) and image.dtype == np.uint8
        break


def test_demo_is_deterministic_and_sources_report_bad_specs(tmp_path) -> None:
    a, ta = demo_scene(5, 2)
    b, tb = demo_scene(5, 2)
    np.testing.assert_array_equal(a.points, b.points)
    assert len(ta.shapes) == 2 and np.allclose(ta.shapes[0].center, tb.shapes[0].center)
    assert not np.array_equal(demo_scene(5, 3)[0].points, a.points, equal_nan=True)
    source = open_source("demo:seed=5,frames=3")
    frames = list(source)
    assert len(frames) == 3 == source.length and frames[2].truth is not None and source.rate == 30.0
    assert open_source("demo:5").length is None  # endless unless frames= is given, as the 2D demo
    np.testing.assert_array_equal(next(iter(open_source("demo:5"))).data.points, frames[0].data.points)
    np.testing.assert_array_equal(frames[2].data.points, a.points)
    write_pcd(tmp_path / "a.pcd", a, "binary_compressed")
    write_pcd(tmp_path / "b.pcd", b, "binary")
    (tmp_path / "notes.txt").write_text("ignored")
    folder = list(open_source(str(tmp_path)))
    assert [f.index for f in folder] == [0, 1] and folder[0].data.is_organized
    for spec, words in [("demo:frames=x", r"option frames='x' is invalid: expected int in 1\.\.inf, or none"),
                        ("demo:colour=1", r"unknown option 'colour' \(options: seed, frames, truth\)"),
                        (str(tmp_path / "none.pcd"), "no such file"),
                        (str(tmp_path / "notes.txt"), r"notes\.txt: no 3d source reads this \(3d sources: .*\.pcd"),
                        ("rgbd:a.png", "rgbd:COLOR,DEPTH"), ("rgbd:nope.png,nope2.png", "does not exist"),
                        ("realsense", "realsense")]:
        with pytest.raises(SourceError, match=words):
            open_source(spec)
    (tmp_path / "bad.pcd").write_bytes(b"garbage")
    with pytest.raises(SourceError, match=r"bad\.pcd"):
        list(open_source(str(tmp_path / "bad.pcd")))


def test_rgbd_pair_becomes_an_organized_cloud(tmp_path) -> None:
    import cv2

    depth = np.full((48, 64), 1000, np.uint16)
    depth[10:20, 10:20] = 0  # no return
    color = np.zeros((48, 64, 3), np.uint8)
    color[..., 2] = 200  # red in BGR
    cv2.imwrite(str(tmp_path / "d.png"), depth)
    cv2.imwrite(str(tmp_path / "c.png"), color)
    (tmp_path / "k.json").write_text(json.dumps({"width": 64, "height": 48, "depth_scale": 1000.0,
                                                 "intrinsic_matrix": [50, 0, 0, 0, 50, 0, 31.5, 23.5, 1]}))
    frame = next(iter(open_source(f"rgbd:{tmp_path / 'c.png'},{tmp_path / 'd.png'},{tmp_path / 'k.json'}")))
    cloud = frame.data
    assert (cloud.width, cloud.height) == (64, 48) and cloud.count_valid() == 64 * 48 - 100
    np.testing.assert_allclose(cloud.points[cloud.valid_mask(), 2], 1.0)
    assert cloud.colors[0].tolist() == [200, 0, 0]
    np.testing.assert_allclose(cloud.grid()[23, 63], [(63 - 31.5) / 50, (23 - 23.5) / 50, 1.0], atol=1e-6)


def test_normals_face_the_sensor_on_the_grid_and_by_neighbours(scene) -> None:
    from objrec3d import grid_normals, knn_normals

    cloud, truth = scene
    near = DistanceFilter(max_distance=2.0).filter(cloud)
    z = near.points[:, 2]
    table = np.flatnonzero(near.valid_mask() & (np.abs(near.points.astype(np.float64) @ truth.table_normal
                                                        + truth.table_offset) < 0.002) & (z < 1.3))
    table = table[::50]
    for normals in (grid_normals(near, table, window=3), knn_normals(near.points[table][:, :], 8)):
        ok = np.isfinite(normals[:, 0])
        assert ok.mean() > 0.8
        cos = normals[ok] @ truth.table_normal
        assert np.median(cos) > 0.99  # oriented toward the sensor, like the table normal of the truth
    dense = grid_normals(near, table, window=3)
    assert np.degrees(np.arccos(np.clip(np.median(dense[np.isfinite(dense[:, 0])] @ truth.table_normal), -1, 1))) < 2


def test_radius_limits_and_parameter_validation(scene) -> None:
    cloud, _ = scene
    prepared = PlaneRemovalFilter().filter(DistanceFilter(max_distance=2.0).filter(cloud))
    assert ShapeDetector(max_radius=0.02).detect(prepared) == []  # demo radii are 4 and 6 cm
    assert ShapeDetector(shape="sphere", min_radius=0.07, max_radius=0.2).detect(prepared) == []
    with pytest.raises(ParameterError, match="min_radius"):
        ShapeDetector(min_radius=-0.1)
    with pytest.raises(ParameterError, match="shape"):
        ShapeDetector(shape="cone")


def test_a_voxel_thinned_organized_cloud_falls_back_to_neighbour_normals(scene) -> None:
    cloud, truth = scene
    thinned = VoxelFilter(leaf_size=0.005).filter(PlaneRemovalFilter().filter(DistanceFilter(max_distance=2.0)
                                                                                .filter(cloud)))
    assert thinned.is_organized
    for shape in ("cylinder", "sphere"):
        found = ShapeDetector(shape=shape).detect(thinned)
        assert len(found) == 1 and abs(found[0].radius - truth.of_shape(shape)[0].radius) < 0.003


def test_a_minimum_radius_above_the_maximum_is_refused_naming_both_not_clamped(tmp_path) -> None:
    with pytest.raises(ParameterError) as caught:
        ShapeDetector(min_radius=0.2, max_radius=0.1)
    assert str(caught.value) == (
        "ShapeDetector: parameter min_radius=0.2 is invalid: must be at most max_radius=0.1 "
        "(no radius could be reported)"
    )
    detector = ShapeDetector(max_radius=0.05)
    with pytest.raises(ParameterError, match=r"min_radius=0\.08 is invalid: must be at most max_radius=0\.05"):
        detector.set_parameters(min_radius=0.08)
    with pytest.raises(ParameterError, match=r"min_radius=0\.01 is invalid: must be at most max_radius=0\.005"):
        detector.set_parameters(max_radius=0.005)
    assert (detector.min_radius, detector.max_radius) == (0.01, 0.05)  # nothing applied, nothing clamped
    detector.set_parameters(min_radius=0.2, max_radius=0.3)  # together: the rule sees both new values
    assert (detector.params.min_radius, detector.params.max_radius) == (0.2, 0.3)
    detector.set_parameters(min_radius=0.3)  # equal is allowed: one radius exactly
    assert ShapeDetector.parameter_spec("min_radius").slider_range == (0.0, 0.5)
    path = tmp_path / "radii.yaml"
    path.write_text("format_version: 1\nkind: 3d\npipeline:\n- type: ShapeDetector\n"
                    "  parameters: {min_radius: 0.12, max_radius: 0.04}\n")
    with pytest.raises(ParameterFileError) as file_error:
        build_system(path)
    assert file_error.value.key_path == "pipeline[0].parameters.min_radius"
    assert "must be at most max_radius=0.04" in str(file_error.value)


def test_a_minimum_distance_above_the_maximum_is_refused_and_far_ranges_are_open() -> None:
    with pytest.raises(ParameterError, match=r"min_distance=2\.0 is invalid: must be at most max_distance=1\.5 "
                                             r"\(every point would be dropped\)"):
        DistanceFilter(min_distance=2.0)
    far = DistanceFilter(min_distance=30.0, max_distance=80.0)  # a lidar's range: no arbitrary hard maximum
    assert far.max_distance == 80.0
    assert DistanceFilter.parameter_spec("max_distance").slider_range == (0.0, 10.0)
    with pytest.raises(ParameterError, match="max_distance=-1"):
        DistanceFilter(max_distance=-1.0)


def test_huge_hard_ranges_offer_sliders_people_tune_in() -> None:
    spec = ShapeDetector.parameter_spec("min_inliers")
    assert (spec.min, spec.max, spec.slider_range) == (3, 10_000_000, (3, 5000))
    ShapeDetector(min_inliers=1_000_000)  # typed values still reach the hard bound
    plane = PlaneRemovalFilter.parameter_spec("min_plane_points")
    assert (plane.max, plane.slider_range) == (10_000_000, (3, 50_000))
