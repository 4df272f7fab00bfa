"""The seed's three recognition systems with sensible starting parameters: ``hsv``, ``feature``, ``shape``.

Built through the module registry by type name, so this file imports neither OpenCV nor Open3D, and a
starting value that a module no longer declares is skipped with a warning rather than stopping the app.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

from objrec_core import ParameterError, Parametrizable, RecognitionSystem, module_type

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ModulePreset:
    type_name: str
    id: str
    parameters: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class SystemPreset:
    name: str
    kind: str
    object_name: str
    description: str
    modules: tuple[ModulePreset, ...]


PRESETS: dict[str, SystemPreset] = {
    "hsv": SystemPreset(
        "hsv", "2d", "coloured_object",
        "Colour segmentation: HSV ranges, a morphological opening, then every blob is an object.",
        (
            ModulePreset("HSVFilter", "colour", {"s_min": 120, "v_min": 60}),
            ModulePreset("MorphologyFilter", "open", {"operation": "open", "kernel_size": 3}),
            ModulePreset("BinaryDetector", "blobs", {"min_contour_length": 40.0}),
        ),
    ),
    "feature": SystemPreset(
        "feature", "2d", "target",
        "Keypoint matching: drag a rectangle around a textured object to make it the target.",
        (ModulePreset("FeatureDetector", "features"),),
    ),
    "shape": SystemPreset(
        "shape", "3d", "cylinder",
        "Shapes in point clouds: keep the near range, remove the table plane, fit a cylinder.",
        (
            ModulePreset("DistanceFilter", "distance", {"min_distance": 0.0, "max_distance": 1.5}),
            ModulePreset("PlaneRemovalFilter", "table"),
            ModulePreset("ShapeDetector", "shapes", {"shape": "cylinder"}),
        ),
    ),
}


def _module(preset: ModulePreset) -> Parametrizable:
    klass = module_type(preset.type_name)
    module = klass(preset.id)
    for name, value in preset.parameters.items():
        try:
            module.set_parameters(**{name: value})
        except (ParameterError, ValueError) as exc:
            log.warning("preset %s: %s; keeping the module's default", preset.id, exc)
    return module


def build_preset(name: str) -> RecognitionSystem:
    """A new system for one of ``PRESETS``; raises KeyError for an unknown name and UnknownModuleError
    when a module type is not installed (the 3D modules need the ``3d`` extra)."""
    preset = PRESETS[name]
    modules = [_module(m) for m in preset.modules]
    return RecognitionSystem(modules, object_name=preset.object_name, kind=preset.kind,
                             description=preset.description)
