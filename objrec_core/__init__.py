"""objrec_core: the framework every recognition system is built on.

Declared parameters (:class:`Parametrizable`), filters and detectors, the pipeline
(:class:`RecognitionSystem`), parameter files (:class:`ParameterStorage`), the module registry and the two
directors. It imports no OpenCV, Open3D or Qt.
"""

from .directors import DefinitionDirector, DetectionDirector, SelectionResult, StageResults, StageView
from .messages import DetectedObjectArray, Header
from .modules import Detector, Filter, Rect, SelectionRefused
from .observer import Observer, Subject
from .parameters import Bool, Choice, Float, Int, Parameter, ParameterError, Str
from .parametrizable import Parametrizable
from .registry import (
    UnknownModuleError,
    kind_plugin,
    module_type,
    module_type_names,
    module_types,
    register_module,
)
from .sinks import JSONLinesSink
from .sources import Frame, FrameSource, SourceError
from .storage import FORMAT_VERSION, ParameterFileError, ParameterStorage, build_system
from .system import PipelineError, PipelineResult, RecognitionSystem, Stage

__all__ = [
    "FORMAT_VERSION",
    "Bool",
    "Choice",
    "DefinitionDirector",
    "DetectedObjectArray",
    "DetectionDirector",
    "Detector",
    "Filter",
    "Float",
    "Frame",
    "FrameSource",
    "Header",
    "Int",
    "JSONLinesSink",
    "Observer",
    "Parameter",
    "ParameterError",
    "ParameterFileError",
    "ParameterStorage",
    "Parametrizable",
    "PipelineError",
    "PipelineResult",
    "RecognitionSystem",
    "Rect",
    "SelectionRefused",
    "SelectionResult",
    "SourceError",
    "Stage",
    "StageResults",
    "StageView",
    "Str",
    "Subject",
    "UnknownModuleError",
    "build_system",
    "kind_plugin",
    "module_type",
    "module_type_names",
    "module_types",
    "register_module",
]
