"""The two kinds of pipeline module: filters transform a frame, detectors find objects in it."""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, ClassVar

from .messages import DetectedObjectArray
from .observer import Change
from .parametrizable import Parametrizable


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in image pixels (a user's area selection)."""

    x: int
    y: int
    width: int
    height: int

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"a selection needs a positive size, got {self.width}x{self.height}")

    @classmethod
    def from_corners(cls, x0: float, y0: float, x1: float, y1: float) -> Rect:
        """From two opposite corners in any order (a mouse drag can go any way)."""
        left, right = sorted((round(x0), round(x1)))
        top, bottom = sorted((round(y0), round(y1)))
        return cls(left, top, right - left, bottom - top)


class SelectionRefused(ValueError):
    """A detector could not use an area selection; the message is the reason to show the user."""


class Detections(list):  # type: ignore[type-arg]
    """The objects a detector found in one frame, with why it found none (``reason``) and, for views,
    anything else it learnt on the way (``details``: matches, a fit).

    The reason travels with the objects instead of being read back from the detector after ``detect``, so a
    detector keeps no per-frame state and one instance may serve several threads at once, each getting its
    own frame's reason. It is a list, so code that wants only the objects uses it as one. A non-empty result
    has no reason: ``reason`` is None whenever objects were found.
    """

    __slots__ = ("details", "reason")

    def __init__(self, objects: Iterable[Any] = (), reason: str | None = None, details: Any = None) -> None:
        list.__init__(self, objects)  # not super(): one per detector and frame, and the lookup costs as much
        self.reason: str | None = None if self else reason
        self.details: Any = details

    def __repr__(self) -> str:
        return f"Detections({list.__repr__(self)}, reason={self.reason!r})"

    def __reduce__(self) -> tuple[Any, ...]:  # pickled whole (batch workers hand results between processes)
        return (type(self), (list(self), self.reason, self.details))


def detection_reason(detector: Any, objects: list[Any]) -> str | None:
    """Why ``detector`` found nothing in the frame that gave ``objects``: None when it found something; the
    result's own ``reason`` for a ``Detections``; for a plug-in written before results carried reasons (a
    plain list), the ``last_reason`` it may still keep itself."""
    if objects:
        return None
    if isinstance(objects, Detections):
        return objects.reason
    return getattr(detector, "last_reason", None)


class Filter(Parametrizable):
    """Turns one frame into another (an image into a mask, a cloud into a smaller cloud)."""

    @abstractmethod
    def filter(self, frame: Any) -> Any: ...


class Detector(Parametrizable):
    """Finds objects in a frame.

    ``object_name`` is not a tunable parameter but part of the recognition system's definition: every
    object this detector reports carries it. ``object_array_type`` is the message type its results go in.
    """

    object_array_type: ClassVar[type[DetectedObjectArray]] = DetectedObjectArray

    def __init__(self, id: str | None = None, *, object_name: str | None = None, **parameters: Any) -> None:
        super().__init__(id, **parameters)
        #: The name given to this detector alone; None means "the system's object name".
        self.own_object_name = object_name
        #: Set by the RecognitionSystem that holds this detector.
        self.system_object_name = "object"

    @property
    def object_name(self) -> str:
        """The name every object found by this detector carries."""
        return self.own_object_name if self.own_object_name is not None else self.system_object_name

    @object_name.setter
    def object_name(self, name: str | None) -> None:
        """A name of this detector's own (None: the system's); observers hear of the change."""
        if name != self.own_object_name:
            old, self.own_object_name = self.own_object_name, name
            self.notify([Change(self, "object_name", old, name)])

    @abstractmethod
    def detect(self, frame: Any) -> list[Any]:
        """Return the objects found in the frame, each named ``self.object_name``: a ``Detections`` whose
        ``reason`` says, when it holds none, why ("too few matches: 6 of 10 needed"), in words a user can act
        on. A plain list is accepted too (a detector that gives no reasons). Keep no per-frame state: the
        GUI's thread and a worker, or two workers, may call ``detect`` on one instance at once."""

    def ready(self) -> str | None:
        """None when this detector can detect; else why not, in words a user can act on ("no target: select
        one in objrec-define first"). Unlike a frame's reason this is about the detector's configuration (a
        target, a model file), so it holds until the user changes it. A headless run refuses to start with a
        detector that is not ready; the GUI runs anyway, since that is where the user makes it ready."""
        return None

    def process_area_selection(self, rect: Rect, frame: Any) -> None:
        """A user selected ``rect`` in ``frame`` (as this detector sees it). Default: ignored.

        Raise SelectionRefused with a reason the GUI can show when the selection cannot be used.
        """
        return None

    def render_debug(self, frame: Any, objects: list[Any]) -> Any | None:
        """An extra view of how this detector sees the frame (keypoints, matches), or None."""
        return None

