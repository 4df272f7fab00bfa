"""The signal kind's source: synthetic waves (``wave:seed=N,frames=N,...``) or a ``.sig`` file.

A ``.sig`` file is text with one frame per line, its samples separated by commas or spaces; ``#`` starts a
comment. The synthetic wave is Gaussian bumps on a noisy zero line; each frame's ``truth`` lists where the
bumps are and how high, so tests can compare detections with it.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from objrec_core import Float, Frame, FrameSource, Int, SourceError, SourceSpec

#: Bump shape and spacing: bumps sit on slots SPACING samples apart (jittered by up to JITTER), so two
#: bumps are at least SPACING - 2 * JITTER samples apart and never merge.
WIDTH = 3.0  # standard deviation in samples
SPACING = 24
JITTER = 4
RATE = 10.0  # frames per second the synthetic wave pretends to be sampled at
MAX_FILE_BYTES = 64 * 1024 * 1024


def read_signal_file(path: Path) -> list[np.ndarray]:
    """The frames of a ``.sig`` file; SourceError names the file, the line and the problem."""
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise SourceError(f"{path}: {size} bytes, more than a signal file may hold ({MAX_FILE_BYTES})")
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SourceError(f"{path}: cannot be read: {exc}") from None
    frames = []
    for number, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        try:
            samples = np.array([float(v) for v in re.split(r"[,\s]+", line) if v], dtype=np.float64)
        except ValueError as exc:
            raise SourceError(f"{path}: line {number}: {exc}") from None
        frames.append(samples)
    if not frames:
        raise SourceError(f"{path}: holds no samples")
    return frames


def wave(seed: int, index: int, length: int, peaks: int, noise: float) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """Frame ``index`` of the synthetic wave of ``seed``, and where its bumps are."""
    rng = np.random.default_rng([seed, index])
    slots = np.arange(SPACING // 2 + JITTER, length - SPACING // 2 - JITTER, SPACING)
    chosen = np.sort(rng.choice(slots, size=min(peaks, slots.size), replace=False))
    positions = chosen + rng.integers(-JITTER, JITTER + 1, size=chosen.size)
    heights = rng.uniform(1.0, 3.0, size=chosen.size)
    t = np.arange(length, dtype=np.float64)
    signal = noise * rng.standard_normal(length)
    for position, height in zip(positions, heights, strict=True):
        signal += height * np.exp(-0.5 * ((t - position) / WIDTH) ** 2)
    truth = [{"position": int(p), "height": float(h)} for p, h in zip(positions, heights, strict=True)]
    return signal, truth


class WaveSource(FrameSource):
    """Synthetic bumps on a noisy line (endless unless ``frames`` is given), or the frames of a ``.sig`` file."""

    kind = "signal"
    schemes = ("wave",)
    extensions = (".sig",)
    options = {  # noqa: RUF012 - declarations, never mutated
        "seed": Int(0, "random seed of the bumps and the noise", min=0, max=2**31 - 1),
        "frames": Int(None, "how many frames (none: endless)", min=1, optional=True),
        "length": Int(256, "samples per frame", min=16, max=1_000_000),
        "peaks": Int(3, "bumps per frame (fewer where the frame is too short for them)", min=0, max=1000),
        "noise": Float(0.02, "standard deviation of the noise", min=0.0, max=100.0),
    }
    positional = ("seed",)
    summary = "wave[:seed=N,frames=N,length=N,peaks=N,noise=X], bumps on a noisy line with ground truth"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> WaveSource:
        if spec.path is not None:
            return cls(name=spec.text, recorded=read_signal_file(spec.path))
        return cls(name=spec.text, seed=options["seed"], frames=options["frames"],
                   length=options["length"], peaks=options["peaks"], noise=options["noise"])

    def __init__(self, name: str = "wave", *, seed: int = 0, frames: int | None = None, length: int = 256,
                 peaks: int = 3, noise: float = 0.02, recorded: list[np.ndarray] | None = None) -> None:
        self.name = name
        self.seed, self.frames, self.samples, self.peaks, self.noise = seed, frames, length, peaks, noise
        self.recorded = recorded

    @property
    def length(self) -> int | None:
        return len(self.recorded) if self.recorded is not None else self.frames

    @property
    def rate(self) -> float | None:
        return None if self.recorded is not None else RATE

    def __iter__(self) -> Iterator[Frame]:
        start = time.time()
        if self.recorded is not None:
            for index, samples in enumerate(self.recorded):
                yield Frame(samples.copy(), start, index, self.name, frame_id="signal")
            return
        index = 0
        while self.frames is None or index < self.frames:
            samples, truth = wave(self.seed, index, self.samples, self.peaks, self.noise)
            yield Frame(samples, start + index / RATE, index, self.name, truth, frame_id="signal")
            index += 1
