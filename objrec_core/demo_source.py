"""The ``demo`` source every kind offers: a synthetic scene with ground truth, named with one grammar
(``demo``, ``demo:3``, ``demo:seed=3,frames=100``) whatever the kind.

A kind's demo source says only how frame ``index`` of the scene of ``seed`` is drawn (:meth:`DemoSceneSource.render`);
the options, the naming, the length, the rate and the time stamps are here once.
"""

from __future__ import annotations

import time
from abc import abstractmethod
from collections.abc import Iterator
from typing import Any, ClassVar

from declare.parameters import Int

from .sources import Frame, FrameSource, SourceSpec


class DemoSceneSource(FrameSource):
    """A kind's synthetic scene, endless unless ``frames`` is given; each frame carries its ground truth."""

    schemes = ("demo",)
    options = {  # noqa: RUF012 - declarations, never mutated
        "seed": Int(0, "random seed of the scene's layout and noise", min=0, max=2**31 - 1),
        "frames": Int(None, "how many frames (none: endless; 0 still means endless, deprecated)", min=1,
                      optional=True, deprecated={0: None}),
    }
    positional = ("seed",)
    #: Frames per second the scene is stamped at.
    FPS: ClassVar[float] = 30.0

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> DemoSceneSource:
        return cls(options["seed"], options["frames"] or None, name=spec.text)

    def __init__(self, seed: int = 0, frames: int | None = None, name: str | None = None) -> None:
        self.seed = seed
        self.frames = frames
        self.name = name or ("demo" if seed == 0 else f"demo:seed={seed}")

    @abstractmethod
    def render(self, index: int) -> tuple[Any, Any]:
        """Frame ``index`` of the scene: its data and its ground truth."""

    @property
    def length(self) -> int | None:
        return self.frames

    @property
    def rate(self) -> float:
        return self.FPS

    def __iter__(self) -> Iterator[Frame]:
        start = time.time()
        index = 0
        while self.frames is None or index < self.frames:
            data, truth = self.render(index)
            yield Frame(data, start + index / self.FPS, index, self.name, truth)
            index += 1
