"""objrec-detect: run any parameter file headless and stream the detected objects as JSON Lines.

Exit codes: 0 done (also after Ctrl-C or SIGTERM, with everything written so far flushed); 1 a failure
while running (a source that breaks mid-stream, a full disk); 2 a user mistake (bad parameter file, option,
or a source that cannot be opened or yields not even one frame).
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from types import FrameType
from typing import IO, Any

from objrec_core import (
    DetectionDirector,
    Frame,
    FrameSource,
    JSONLinesSink,
    ParameterFileError,
    PipelineError,
    SourceError,
    UnknownModuleError,
    build_system,
    kind_plugin,
)

from .annotation_writer import AnnotationError, AnnotationWriter
from .cli import USER_ERROR, UserError, configure_logging, report

log = logging.getLogger("objrec.detect")
PROG = "objrec-detect"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Detect objects with a parameter file made by objrec-define; one JSON line per frame.",
    )
    parser.add_argument("params", metavar="PARAMS_FILE", help="parameter file (YAML) of a recognition system")
    parser.add_argument(
        "--source", "-s", required=True, help="demo, demo:SEED, camera:N, an image, a video, a folder, a cloud file"
    )
    parser.add_argument("--output", "-o", metavar="FILE", help="write the JSON lines here instead of stdout")
    parser.add_argument("--max-frames", "-n", type=int, metavar="N", help="stop after N frames")
    parser.add_argument("--frame-id", default="camera", help="frame_id written in every header (default: camera)")
    parser.add_argument(
        "--annotate", metavar="PATH", help="also write pictures: a video (.avi/.mp4) or a folder of PNGs"
    )
    parser.add_argument(
        "--annotate-view",
        choices=("objects", "debug"),
        default="objects",
        help="objects: detections drawn on the original frame; debug: the detector's own view (e.g. matches)",
    )
    parser.add_argument("--skip-empty", action="store_true", help="write no line for frames with no object")
    parser.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar (default: on a terminal)"
    )
    parser.add_argument("--verbose", "-v", action="store_true", help="log more on stderr")
    return parser


class _Stopper:
    """Turns SIGTERM into a stop request, so the loop ends between frames and flushes."""

    def __init__(self) -> None:
        self.event = threading.Event()
        self.reason = ""

    def __call__(self, signum: int, _frame: FrameType | None) -> None:
        if signum == signal.SIGINT and self.event.is_set():
            raise KeyboardInterrupt  # a second Ctrl-C: the source itself may be stuck
        self.reason = signal.Signals(signum).name
        self.event.set()


def _open(args: argparse.Namespace) -> tuple[DetectionDirector, FrameSource, Any]:
    if args.max_frames is not None and args.max_frames < 1:
        raise UserError(f"--max-frames must be at least 1, got {args.max_frames}")
    try:
        system = build_system(args.params)
    except ParameterFileError as exc:
        raise UserError(str(exc)) from None
    if not system.detectors:
        raise UserError(f"{args.params}: pipeline: has no detector, so nothing would be detected")
    try:
        plugin = kind_plugin(system.kind or "2d")
        source = plugin.open_source(args.source)
    except (SourceError, UnknownModuleError) as exc:
        raise UserError(str(exc)) from None
    return DetectionDirector(system, frame_id=args.frame_id), source, plugin


def _frames(source: FrameSource, limit: int | None, progress: bool | None) -> Iterator[Frame]:
    total = source.length
    if limit is not None:
        total = limit if total is None else min(total, limit)
    bar = None
    if total is not None and progress is not False:
        from tqdm import tqdm

        bar = tqdm(total=total, unit="frame", file=sys.stderr, disable=None if progress is None else False)
    try:
        # islice: never pull a frame past the limit (a camera could fail on it after the work was done)
        for frame in itertools.islice(source, limit):
            yield frame
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()


def _annotation(director: DetectionDirector, plugin: Any, frame: Frame, view: str) -> tuple[Any, Any]:
    if view == "debug":
        array, stages = director.process_with_stages(frame)
        debug = next((s.debug for s in stages if s.debug is not None), None)
        return array, debug if debug is not None else plugin.annotate(frame, array)
    array = director.process(frame)
    return array, plugin.annotate(frame, array)


def run(args: argparse.Namespace, stdout: IO[str]) -> int:
    director, source, plugin = _open(args)
    stopper = _Stopper()
    previous = {}
    if threading.current_thread() is threading.main_thread():
        previous = {sig: signal.signal(sig, stopper) for sig in (signal.SIGTERM, signal.SIGINT)}
    writer = None
    output = None
    frames = objects = 0
    start = time.perf_counter()
    try:
        if args.output:
            try:
                output = Path(args.output).open("w", encoding="utf-8")  # noqa: SIM115 - closed below
            except OSError as exc:
                raise UserError(f"{args.output}: cannot be written: {exc}") from None
        sink = JSONLinesSink(output or stdout, skip_empty=args.skip_empty)
        director.add_sink(sink)
        if args.annotate:
            try:
                writer = AnnotationWriter(args.annotate)
            except AnnotationError as exc:
                raise UserError(str(exc)) from None
        for frame in _frames(source, args.max_frames, args.progress):
            if writer is None:
                array = director.process(frame)
            else:
                array, picture = _annotation(director, plugin, frame, args.annotate_view)
                writer.write(picture)
            frames += 1
            objects += len(array.objects)
            if stopper.event.is_set():
                log.warning("stopped by %s after %d frames", stopper.reason, frames)
                break
    except KeyboardInterrupt:
        log.warning("interrupted after %d frames", frames)
    except BrokenPipeError:
        raise
    except (SourceError, AnnotationError) as exc:
        report(PROG, exc)
        return 2 if frames == 0 else 1  # nothing read at all: the source itself is bad
    except OSError as exc:  # the output went away: a full disk, a closed device
        report(PROG, f"writing {args.output or 'the output'}: {exc.strerror or exc}")
        return 1
    finally:
        if writer is not None:
            writer.close()
        if output is not None:
            with contextlib.suppress(OSError):  # already reported above
                output.close()
        source.close()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    seconds = time.perf_counter() - start
    fps = frames / seconds if seconds > 0 else 0.0
    print(f"{PROG}: {frames} frames, {objects} objects, {seconds:.2f} s, {fps:.1f} frames/s", file=sys.stderr)
    if writer is not None:
        print(f"{PROG}: {writer.count} annotated frames written to {args.annotate}", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    configure_logging(PROG, args.verbose)
    try:
        return run(args, sys.stdout)
    except UserError as exc:
        report(PROG, exc)
        return USER_ERROR
    except PipelineError as exc:
        report(PROG, f"{args.params}: {exc}")
        return 2
    except BrokenPipeError:  # the reader went away (e.g. `| head`): not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so the interpreter's final flush stays quiet
        return 0


if __name__ == "__main__":
    sys.exit(main())
