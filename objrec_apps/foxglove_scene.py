"""Point clouds and detected 3D objects as Foxglove messages (``foxglove.PointCloud``, ``foxglove.SceneUpdate``).

Kind-agnostic like the Rerun recording: the cloud comes from ``Kind.points`` (and the frame's ``colors`` where
it has them), the objects from their JSON form (``to_dict``: the ``box`` pose and sides, and a shape fit's
``shape`` and ``radius``), with ``Kind.outlines`` for the labels and for objects whose JSON has no box pose.

An object is drawn as what it is: a ``sphere`` as a sphere of its fitted radius, a ``cylinder`` as a cylinder
along the box's local y axis (the cylinder axis, docs/3d.md), anything else as its oriented box; each with a
text label above it. Every update first deletes the previous frame's entities, so nothing stale stays.
foxglove-sdk is imported by the functions only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from objrec_core import DetectedObjectArray, Kind

from .rerun_log import box_pose

#: Detected objects' colour (RGBA, 0..1): the green of the annotated pictures, half transparent.
OBJECT_RGBA = (0.0, 1.0, 0.0, 0.5)
LABEL_RGBA = (1.0, 1.0, 1.0, 1.0)
LABEL_FONT_SIZE = 14.0
#: A turn of -90 degrees about x (x, y, z, w): takes a cylinder primitive's axis (its z) onto the box's y.
_Z_TO_Y = (-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5))


def quaternion_product(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    """``a * b`` of unit quaternions (x, y, z, w): first ``b``, then ``a``."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def point_cloud_message(points: Any, colours: Any, stamp: Any, frame_id: str) -> Any:
    """A ``foxglove.PointCloud`` of the finite points: x, y, z float32 and, where given, red, green, blue,
    alpha uint8 (16 bytes a point), in ``frame_id``."""
    from foxglove.messages import (
        PackedElementField,
        PackedElementFieldNumericType,
        PointCloud,
        Pose,
        Quaternion,
        Vector3,
    )

    xyz = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    keep = np.isfinite(xyz).all(axis=1)
    f32, u8 = PackedElementFieldNumericType.Float32, PackedElementFieldNumericType.Uint8
    fields = [PackedElementField(name=n, offset=4 * i, type=f32) for i, n in enumerate("xyz")]
    rgb = None if colours is None else np.asarray(colours)
    if rgb is not None and rgb.size == xyz.size:
        rgb = rgb.reshape(-1, 3)  # an organized cloud's colours, row by row as its points
        layout = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("red", "u1"), ("green", "u1"),
                           ("blue", "u1"), ("alpha", "u1")])
        packed = np.empty(int(keep.sum()), dtype=layout)
        for i, name in enumerate("xyz"):
            packed[name] = xyz[keep, i]
        for i, name in enumerate(("red", "green", "blue")):
            packed[name] = rgb[keep, i].astype(np.uint8)
        packed["alpha"] = 255
        fields += [PackedElementField(name=n, offset=12 + i, type=u8)
                   for i, n in enumerate(("red", "green", "blue", "alpha"))]
        data, stride = packed.tobytes(), 16
    else:
        data, stride = np.ascontiguousarray(xyz[keep]).tobytes(), 12
    return PointCloud(timestamp=stamp, frame_id=frame_id,
                      pose=Pose(position=Vector3(x=0.0, y=0.0, z=0.0), orientation=Quaternion(w=1.0)),
                      point_stride=stride, fields=fields, data=data)


def _solid(kind_name: str, box: dict[str, Any], radius: float) -> tuple[str, tuple[float, ...], tuple[float, ...],
                                                                       tuple[float, float, float]]:
    """(primitive, centre, orientation x y z w, size) of one object's JSON box."""
    pose = box["pose"]
    p, q = pose["position"], pose["orientation"]
    centre = (float(p["x"]), float(p["y"]), float(p["z"]))
    rotation = (float(q["x"]), float(q["y"]), float(q["z"]), float(q["w"]))
    width, height, depth = float(box["width"]), float(box["height"]), float(box["depth"])
    if kind_name == "sphere" and radius > 0:
        return "sphere", centre, rotation, (2 * radius,) * 3
    if kind_name == "cylinder":
        across = (2 * radius, 2 * radius) if radius > 0 else (width, depth)
        return "cylinder", centre, quaternion_product(rotation, _Z_TO_Y), (*across, height)
    return "cube", centre, rotation, (width, height, depth)


def object_solids(kind: Kind, objects: DetectedObjectArray) -> list[tuple[str, str, tuple[float, ...],
                                                                          tuple[float, ...], tuple[float, ...]]]:
    """(label, primitive, centre, orientation, size) per object that can be drawn in 3D."""
    outlines = kind.outlines(objects)
    labels = [o.label for o in outlines] if len(outlines) == len(objects.objects) else None
    solids = []
    for i, obj in enumerate(objects.objects):
        to_dict = getattr(obj, "to_dict", None)
        data = to_dict() if callable(to_dict) else {}
        box = data.get("box") if isinstance(data, dict) else None
        if not (isinstance(box, dict) and isinstance(box.get("pose"), dict)):
            solids = []
            break
        label = labels[i] if labels else str(data.get("name", ""))
        solids.append((label, *_solid(str(data.get("shape", "")), box, float(data.get("radius", 0.0)))))
    else:
        return solids
    # objects of a kind whose JSON has no box pose: their outline boxes, as the Rerun recording draws them
    for outline in outlines:
        corners = None if outline.box is None else np.asarray(outline.box, dtype=np.float64)
        if corners is None or corners.size != 24 or not np.isfinite(corners).all():
            continue
        centre, half, rotation = box_pose(corners)
        solids.append((outline.label, "cube", tuple(centre), tuple(rotation), tuple(2 * half)))
    return solids


def scene_update(kind: Kind, objects: DetectedObjectArray, stamp: Any, frame_id: str) -> Any:
    """A ``foxglove.SceneUpdate`` replacing the previous objects with this frame's (ids ``object/<i>``)."""
    from foxglove.messages import (
        Color,
        CubePrimitive,
        CylinderPrimitive,
        Pose,
        Quaternion,
        SceneEntity,
        SceneEntityDeletion,
        SceneEntityDeletionType,
        SceneUpdate,
        SpherePrimitive,
        TextPrimitive,
        Vector3,
    )

    colour, text_colour = (Color(**dict(zip("rgba", c, strict=True))) for c in (OBJECT_RGBA, LABEL_RGBA))
    entities = []
    for i, (label, primitive, centre, rotation, size) in enumerate(object_solids(kind, objects)):
        pose = Pose(position=Vector3(x=centre[0], y=centre[1], z=centre[2]),
                    orientation=Quaternion(x=rotation[0], y=rotation[1], z=rotation[2], w=rotation[3]))
        extent = Vector3(x=size[0], y=size[1], z=size[2])
        shapes: dict[str, Any] = {}
        if primitive == "sphere":
            shapes["spheres"] = [SpherePrimitive(pose=pose, size=extent, color=colour)]
        elif primitive == "cylinder":
            shapes["cylinders"] = [CylinderPrimitive(pose=pose, size=extent, bottom_scale=1.0, top_scale=1.0,
                                                     color=colour)]
        else:
            shapes["cubes"] = [CubePrimitive(pose=pose, size=extent, color=colour)]
        above = Pose(position=Vector3(x=centre[0], y=centre[1] - max(size) / 2 - 0.02, z=centre[2]),
                     orientation=Quaternion(w=1.0))  # y points down in a camera's optical frame
        shapes["texts"] = [TextPrimitive(pose=above, billboard=True, font_size=LABEL_FONT_SIZE, scale_invariant=True,
                                         color=text_colour, text=label)]
        entities.append(SceneEntity(timestamp=stamp, frame_id=frame_id, id=f"object/{i}", **shapes))
    return SceneUpdate(deletions=[SceneEntityDeletion(timestamp=stamp, type=SceneEntityDeletionType.All)],
                       entities=entities)
