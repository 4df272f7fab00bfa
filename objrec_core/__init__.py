"""objrec_core: the framework every recognition system is built on.

Declared parameters and rules (:class:`Parametrizable`), filters and detectors, the pipeline
(:class:`RecognitionSystem`), parameter files (:class:`ParameterStorage`), the registry of module types,
data kinds (:class:`Kind`) and source types (:class:`FrameSource`), and the two directors. It imports no
OpenCV, Open3D or Qt, and names no data kind: kinds, modules and sources are plug-ins.
"""

from declare.parameters import Bool, Choice, Float, Int, Parameter, ParameterError, Str
from declare.rules import Check, Ordered, Rule

from .directors import (
    AnnotationSink,
    DefinitionDirector,
    DetectionDirector,
    Progress,
    RunStats,
    SelectionResult,
    StageResults,
    StageView,
)
from .kinds import FrameKindError, Kind, Outline
from .messages import DetectedObjectArray, Header
from .modules import Detections, Detector, Filter, Rect, SelectionRefused, detection_reason
from .observer import Change, Observer, Subject
from .parametrizable import Parametrizable
from .registry import (
    UnknownModuleError,
    get_kind,
    kind_names,
    module_type,
    module_type_names,
    module_types,
    open_source,
    register_kind,
    register_module,
    register_source,
    source_entries,
    source_kinds,
    source_schemes,
    source_types,
    source_usage,
)
from .schema import FORMAT_VERSION, ParameterFileError
from .sinks import JSONLinesSink
from .source_declaration import DeclaredSource
from .sources import Frame, FrameSource, SourceError, SourceSpec
from .storage import Opened, ParameterStorage, build_system, peek_kind
from .system import PipelineError, PipelineResult, RecognitionSystem, Stage

__all__ = [
    "FORMAT_VERSION",
    "AnnotationSink",
    "Bool",
    "Change",
    "Check",
    "Choice",
    "DeclaredSource",
    "DefinitionDirector",
    "DetectedObjectArray",
    "DetectionDirector",
    "Detections",
    "Detector",
    "Filter",
    "Float",
    "Frame",
    "FrameKindError",
    "FrameSource",
    "Header",
    "Int",
    "JSONLinesSink",
    "Kind",
    "Observer",
    "Opened",
    "Ordered",
    "Outline",
    "Parameter",
    "ParameterError",
    "ParameterFileError",
    "ParameterStorage",
    "Parametrizable",
    "PipelineError",
    "PipelineResult",
    "Progress",
    "RecognitionSystem",
    "Rect",
    "Rule",
    "RunStats",
    "SelectionRefused",
    "SelectionResult",
    "SourceError",
    "SourceSpec",
    "Stage",
    "StageResults",
    "StageView",
    "Str",
    "Subject",
    "UnknownModuleError",
    "build_system",
    "detection_reason",
    "get_kind",
    "kind_names",
    "module_type",
    "module_type_names",
    "module_types",
    "open_source",
    "peek_kind",
    "register_kind",
    "register_module",
    "register_source",
    "source_entries",
    "source_kinds",
    "source_schemes",
    "source_types",
    "source_usage",
]
