"""Definition GUI benchmark: frames displayed per second and the delay from a parameter change to its
first displayed frame, for the HSV system on the demo source at 640x480 with all stage views on screen;
the 3D view's renderers; and the first result of a parameter change on the real mug scan.

    QT_QPA_PLATFORM=offscreen .venv/bin/python benchmarks/bench_gui.py [--seconds 8] [--only-2d | --only-3d]

Targets: at least 25 frames displayed per second; a parameter change on screen in under
100 ms. A frame counts as displayed when every stage view has painted it. The offscreen platform paints into
memory with the same raster engine a desktop uses, without the compositor.

The 3D view (at least 30 frames/s turning a 307,200-point cloud at 800x600 on a 2-core machine
without a GPU) is measured with both renderers, whole and with the level of detail used while the camera
moves: the software renderer in this process (offscreen) and, in children under ``xvfb-run -a`` (X11 with
Mesa, as a laptop without a GPU), the software renderer, the OpenGL view, and the one the window chooses
there (render_path.py). ``--view3d-only gl|software|chosen`` is the child's mode.

The 3D latency (a first result within 200 ms of a parameter change) is measured with the shipped
shape system on PCL's mug scan (/work/shared/data/clouds/table_scene_mug_stereo_textured.pcd; skipped when
absent): the time to the coarse preview on screen and to the full result.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path
from PySide6.QtCore import QEventLoop, QSettings, QTimer
from PySide6.QtWidgets import QApplication

from objrec2d import DemoSource
from objrec_apps.define import starting_system
from objrec_apps.gui import DefinitionGUI
from objrec_core import Frame, FrameSource

SIZE = (1600, 1000)  # room for four 640x480 views at about 0.75 scale
#: The real scan (PCL's tutorial data; /work/shared/data/README.md), not shipped with objrec.
MUG = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "clouds" / "table_scene_mug_stereo_textured.pcd"


class PrerenderedDemo(FrameSource):
    """The demo's first frames rendered once and replayed: the GUI without the demo's own drawing cost
    (about 15 ms a frame on this kind of machine, which a camera does not have)."""

    name = "demo (pre-rendered)"
    kind = "2d"

    def __init__(self, count: int = 90) -> None:
        self.frames = [frame for _, frame in zip(range(count), DemoSource(), strict=False)]

    def __iter__(self) -> Iterator[Frame]:
        index = 0
        while True:
            frame = self.frames[index % len(self.frames)]
            yield Frame(frame.data, time.time(), index, self.name, frame.truth)
            index += 1


def wait_for(app: QApplication, condition: Callable[[], bool], timeout: float = 10.0) -> None:
    """Run the event loop (idle between events, as the real app is) until ``condition`` holds; it is
    checked every millisecond. A busy ``processEvents`` loop would hold the GIL and slow the worker."""
    if condition():
        return
    loop = QEventLoop()
    timer = QTimer()
    timer.setInterval(1)
    deadline = time.perf_counter() + timeout

    def check() -> None:
        if condition() or time.perf_counter() > deadline:
            loop.quit()

    timer.timeout.connect(check)
    timer.start()
    loop.exec()
    timer.stop()
    if not condition():
        raise TimeoutError("timed out")


def run_for(app: QApplication, seconds: float) -> None:
    loop = QEventLoop()
    QTimer.singleShot(round(seconds * 1000), loop.quit)
    loop.exec()


def open_window(source: object, fps_limit: float | None, settings: QSettings) -> DefinitionGUI:
    gui = DefinitionGUI(starting_system("hsv"), source=source, settings=settings, fps_limit=fps_limit,
                        view_mode="grid")
    gui.resize(*SIZE)
    gui.show()
    return gui


def displayed_rate(app: QApplication, gui: DefinitionGUI, seconds: float) -> dict[str, float]:
    """Frames painted by every stage view per second, with processing and dropping figures.

    A frame counts when, at the moment the next one arrives, every view has painted it.
    """
    wait_for(app, lambda: gui.last_results is not None and len(gui.stage_views.views) == 4)
    views = list(gui.stage_views.views.values())
    previous: list = [None]
    complete = [0]

    def arrived(shown: object) -> None:
        if previous[0] is not None and all(v.painted_tag is previous[0] for v in views):
            complete[0] += 1
        previous[0] = shown.results  # type: ignore[attr-defined]

    processed, dropped = gui.worker.processed, gui.worker.dropped
    gui.frameShown.connect(arrived)
    start = time.perf_counter()
    run_for(app, seconds)
    elapsed = time.perf_counter() - start
    gui.frameShown.disconnect(arrived)
    scale = min(v.image_rect().width() / v.image_size()[0] for v in views)
    return {
        "displayed_fps": complete[0] / elapsed,
        "processed_fps": (gui.worker.processed - processed) / elapsed,
        "dropped": gui.worker.dropped - dropped,
        "views": len(views),
        "scale": scale,
    }


def change_delays(app: QApplication, gui: DefinitionGUI, changes: int, paused: bool) -> list[float]:
    """Seconds from a slider move to the first frame, made with the new value, painted in every view."""
    wait_for(app, lambda: gui.last_results is not None)
    gui.set_paused(paused)
    editor = gui.panels.panel("colour").editors["s_min"]
    views = list(gui.stage_views.views.values())
    delays = []
    for i in range(changes):
        # Let a little time pass, so changes fall at different moments of the frame cycle.
        run_for(app, 0.05 + 0.037 * (i % 7))
        start = time.perf_counter()
        editor.slider.setValue(100 + (i % 2) * 40 + i)  # the throttle sends the first move at once
        generation = gui.worker.generation
        wait_for(app, lambda g=generation: gui.last_shown_generation >= g
             and all(v.painted_tag is gui.last_results for v in views))
        delays.append(time.perf_counter() - start)
    return delays


def source_rate(seconds: float) -> float:
    """Frames per second the demo source itself delivers: the ceiling of the live-demo figures."""
    count, start = 0, time.perf_counter()
    for _ in DemoSource():
        count += 1
        if time.perf_counter() - start > seconds:
            break
    return count / (time.perf_counter() - start)


def cloud_render_ms(point_size: int, repeats: int = 15) -> float:
    """Median milliseconds to render a 640x480 organized cloud (307,200 points) into an 800x600 view."""
    from objrec_apps.gui.cloud_render import CloudScene, OrbitCamera, render

    v, u = np.mgrid[0:480, 0:640].astype(np.float32)
    z = 1.0 + 0.5 * (v / 480) + 0.05 * np.sin(u / 20)
    points = np.stack([(u - 320) / 525 * z, (v - 240) / 525 * z, z], axis=-1).reshape(-1, 3)
    near = points.copy()
    near[points[:, 2] > 1.3] = np.nan
    scene = CloudScene.from_layers([("original", points), ("near", near)])
    camera = OrbitCamera()
    camera.fit(scene.bounds(), 800 / 600)
    times = []
    for i in range(repeats):
        camera.rotate(0.02, 0.01 * (-1) ** i)  # turning, as while the user drags
        start = time.perf_counter()
        render(scene, camera, 800, 600, point_size=point_size)
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1000


def turning_scene() -> object:
    """A 640x480 organized cloud (307,200 points) with a filter layer, as a 3D pipeline shows it."""
    from objrec_apps.gui.cloud_render import CloudScene

    v, u = np.mgrid[0:480, 0:640].astype(np.float32)
    z = 1.0 + 0.5 * (v / 480) + 0.05 * np.sin(u / 20)
    points = np.stack([(u - 320) / 525 * z, (v - 240) / 525 * z, z], axis=-1).reshape(-1, 3)
    near = points.copy()
    near[points[:, 2] > 1.3] = np.nan
    return CloudScene.from_layers([("original", points), ("near", near)])


def view3d_fps(app: QApplication, renderer: str, seconds: float, moving: bool = True) -> dict[str, float | str]:
    """Frames per second the 3D view draws at 800x600 while the cloud turns a little every frame (as during a
    drag), with the grid, legend and the frame-rate label's own figure. Each frame is a new view: the next
    turn is asked for once the previous frame is drawn (OpenGL: swapped; software: painted). ``renderer``:
    ``gl``, ``software`` or ``chosen`` (what the window would pick here, render_path.py). ``moving`` marks each
    turn as a drag step, so a large cloud is thinned (level of detail); without it every frame is whole."""
    from objrec_apps.gui.cloud_view import CloudView
    from objrec_apps.gui.gl_cloud_view import GLCloudView, gl_available, make_cloud_view

    if renderer == "gl" and not gl_available():
        return {"error": f"no OpenGL on the {app.platformName()} platform"}
    view = make_cloud_view() if renderer == "chosen" else GLCloudView() if renderer == "gl" else CloudView()
    use_gl = view.uses_opengl
    view.resize(800, 600)
    view.show()
    view.set_scene(turning_scene())  # type: ignore[arg-type]

    def turn() -> None:
        if moving:
            view.start_moving()
        view.camera.rotate(0.02, 0.0)
        if use_gl:
            view.update()
        else:
            view.repaint()

    timer = None
    if use_gl:
        view.frameSwapped.connect(lambda: QTimer.singleShot(0, turn))  # type: ignore[attr-defined]
        turn()
    else:
        timer = QTimer()
        timer.setInterval(0)
        timer.timeout.connect(turn)
        timer.start()
    run_for(app, 1.0)  # warm up (shader compilation, first upload)
    drawn, thinned, start = view.frames_drawn, view.thinned_frames, time.perf_counter()
    run_for(app, seconds)
    elapsed = time.perf_counter() - start
    frames = view.frames_drawn - drawn
    label = view.frames_per_second()
    if timer is not None:
        timer.stop()
    view.close()
    return {"fps": frames / elapsed, "label_fps": label, "frame_ms": view.frame_ms,
            "thinned": (view.thinned_frames - thinned) / max(frames, 1),
            "renderer": view.render_path.name, "reason": view.render_path.reason,
            "gl_renderer": view.render_path.renderer}


def view3d_xvfb_child(renderer: str, seconds: float, moving: bool) -> dict[str, float | str]:
    """A 3D figure from a child process under ``xvfb-run -a`` (X11 with Mesa, as on a laptop without a GPU):
    the OpenGL view, the software view as a desktop shows it, or the one the window chooses."""
    if shutil.which("xvfb-run") is None:
        return {"error": "xvfb-run is not installed"}
    env = {**os.environ, "QT_QPA_PLATFORM": "xcb"}
    env.pop("OBJREC_RENDERER", None)
    env.pop("OBJREC_GL", None)
    command = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", sys.executable, __file__, "--view3d-only", renderer,
               "--seconds", str(seconds)] + ([] if moving else ["--whole"])
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=120 + 2 * seconds)
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        return {"error": (done.stderr.strip().splitlines() or ["no output"])[-1]}
    return json.loads(lines[-1])


def print_view3d(label: str, figures: dict[str, float | str]) -> None:
    if "error" in figures:
        print(f"  3D view turning, {label:44s} not measured: {figures['error']}")
        return
    fps = float(figures["fps"])
    thinned = float(figures.get("thinned", 0.0))
    detail = f"{thinned:.0%} of frames thinned while turning" if thinned else "every frame whole"
    print(f"  3D view turning, {label:44s} {fps:6.1f} frames/s drawn, 307,200 points at 800x600 ({detail}; "
          f"label read {float(figures['label_fps']):.1f}; last frame {float(figures['frame_ms']):.1f} ms); "
          f">= 30: {'met' if fps >= 30 else 'NOT met'}")


def mug_latency(app: QApplication, settings: QSettings, changes: int) -> dict[str, list[float]] | str:
    """Seconds from a parameter change on the real mug scan (the shipped shape system, the scan's one frame on
    screen) to the first result of the new values on screen (the coarse preview) and to the full result."""
    if not MUG.is_file():
        return f"the mug scan is not at {MUG}"
    gui = DefinitionGUI(starting_system("shape"), source=str(MUG), settings=settings)
    gui.resize(1280, 800)
    gui.show()
    shown: list[tuple[float, int, int]] = []
    gui.frameShown.connect(lambda s: shown.append((time.perf_counter(), s.generation, s.preview_step)))
    wait_for(app, lambda: any(not step for _, _, step in shown), timeout=120)
    cylinder = gui.system.module("cylinder")
    first, full, steps = [], [], []
    for i in range(changes):
        run_for(app, 0.2 + 0.05 * (i % 5))
        start = time.perf_counter()
        cylinder.set_parameters(min_radius=0.02 + 0.001 * (i % 7) + (0.0005 if i % 2 else 0.0))
        generation = gui.worker.generation
        wait_for(app, lambda g=generation: any(gen == g and not step for _, gen, step in shown), timeout=120)
        mine = [(t, step) for t, gen, step in shown if gen == generation]
        first.append(mine[0][0] - start)
        full.append(mine[-1][0] - start)
        steps.append(float(mine[0][1]))
    gui.changes.forget()
    gui.close()
    app.processEvents()
    return {"first": first, "full": full, "steps": steps}


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=8.0, help="length of each frame-rate run")
    parser.add_argument("--changes", type=int, default=30, help="parameter changes per latency run")
    parser.add_argument("--view3d-only", choices=("gl", "software", "chosen"),
                        help="only the 3D view's frame rate, printed as JSON (the xvfb-run child's mode)")
    parser.add_argument("--whole", action="store_true", help="with --view3d-only: every frame whole (no level "
                        "of detail while turning)")
    parser.add_argument("--only-3d", action="store_true", help="only the 3D figures (both paths, the chosen one, "
                        "the mug scan's first-result latency)")
    parser.add_argument("--only-2d", action="store_true", help="only the 2D figures (frame rates and change "
                        "delays of the HSV system; no 3D view, no xvfb-run children, no mug scan)")
    parser.add_argument("--mug-changes", type=int, default=12, help="parameter changes on the mug scan")
    args = parser.parse_args()
    app = QApplication.instance() or QApplication(sys.argv[:1])
    if args.view3d_only:
        print(json.dumps(view3d_fps(app, args.view3d_only, args.seconds, moving=not args.whole)))
        return 0
    print_machine()
    if args.only_3d:
        print_3d(app, args)
        return 0
    folder = tempfile.TemporaryDirectory()
    settings = QSettings(str(Path(folder.name) / "settings.ini"), QSettings.Format.IniFormat)

    print("objrec-define benchmark: HSV system (HSVFilter, MorphologyFilter, BinaryDetector), 640x480, "
          "4 stage views in a grid")
    baseline = source_rate(2.0)
    print(f"  the demo source alone (drawing its frames, no GUI): {baseline:.1f} frames/s")
    runs = [
        ("live demo, flat out", "demo", None),
        ("live demo, 30 fps source rate (default)", "demo", 30.0),
        ("pre-rendered demo, flat out", PrerenderedDemo(), None),
    ]
    figures = {}
    for label, source, limit in runs:
        gui = open_window(source, limit, settings)
        result = displayed_rate(app, gui, args.seconds)
        figures[label] = result
        print(f"  {label:42s} {result['displayed_fps']:6.1f} frames/s displayed in all {result['views']} views, "
              f"{result['processed_fps']:6.1f} processed, {result['dropped']} dropped "
              f"(views at {result['scale']:.2f}x)" + (f"; {result['displayed_fps'] / baseline:.2f}x the demo source "
                                                      "alone" if source == "demo" else ""))
        gui.changes.forget()  # the benchmark's changes: close without asking
        gui.close()
        app.processEvents()

    gui = open_window("demo", 30.0, settings)
    running = change_delays(app, gui, args.changes, paused=False)
    paused = change_delays(app, gui, args.changes, paused=True)
    gui.changes.forget()
    gui.close()
    for label, delays in (("running at 30 fps", running), ("paused", paused)):
        print(f"  parameter change -> displayed, {label:18s} median {statistics.median(delays) * 1000:5.1f} ms, "
              f"95th percentile {percentile(delays, 0.95) * 1000:5.1f} ms, max {max(delays) * 1000:5.1f} ms "
              f"({len(delays)} changes)")
    if not args.only_2d:
        print_3d(app, args, settings)
    fps = figures["live demo, flat out"]["displayed_fps"]
    ceiling = figures["pre-rendered demo, flat out"]["displayed_fps"]
    worst = max(percentile(running, 0.95), percentile(paused, 0.95))
    print(f"  target: >= 25 frames/s displayed: {'met' if fps >= 25 else 'NOT met'} ({fps:.1f} on the live demo, "
          f"{ceiling:.1f} on pre-rendered frames, the GUI's own ceiling); "
          f"< 100 ms from change to display (95th percentile): {'met' if worst < 0.1 else 'NOT met'} "
          f"({worst * 1000:.0f} ms)")
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"  load average at the end: {load}")
    folder.cleanup()
    return 0


def print_machine() -> None:
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores, load average {load} at the start (other work slows "
          "every figure; a figure from another processor is not comparable)")


def print_3d(app: QApplication, args: argparse.Namespace, settings: QSettings | None = None) -> None:
    """The 3D figures: the renderers turning 307,200 points (offscreen, and under xvfb-run as a desktop without
    a GPU shows them), which one the window chooses there, and the mug scan's first-result latency."""
    if settings is None:
        folder = tempfile.mkdtemp()
        settings = QSettings(str(Path(folder) / "settings.ini"), QSettings.Format.IniFormat)
    print(f"  3D view, 307,200-point cloud into 800x600: {cloud_render_ms(1):.1f} ms a frame at point size 1, "
          f"{cloud_render_ms(2):.1f} ms at point size 2 (median while turning, whole cloud)")
    print_view3d("software, offscreen, whole cloud", view3d_fps(app, "software", args.seconds, moving=False))
    print_view3d("software, offscreen, level of detail", view3d_fps(app, "software", args.seconds))
    for label, renderer, moving in (("software, xvfb-run, whole cloud", "software", False),
                                    ("software, xvfb-run, level of detail", "software", True),
                                    ("OpenGL (Mesa), xvfb-run, whole cloud", "gl", False),
                                    ("OpenGL (Mesa), xvfb-run, level of detail", "gl", True)):
        print_view3d(label, view3d_xvfb_child(renderer, args.seconds, moving))
    chosen = view3d_xvfb_child("chosen", args.seconds, True)
    print_view3d("chosen under xvfb-run (as objrec-define)", chosen)
    if "error" not in chosen:
        print(f"    chosen: the {chosen['renderer']}: {chosen['reason']}")
    latency = mug_latency(app, settings, args.mug_changes)
    if isinstance(latency, str):
        print(f"  3D parameter change -> first result on the mug scan: not measured: {latency}")
        return
    first, full = latency["first"], latency["full"]
    step = statistics.median(latency["steps"])
    print(f"  3D parameter change -> first result on screen, mug scan, shape system: median "
          f"{statistics.median(first) * 1000:5.0f} ms, 95th percentile {percentile(first, 0.95) * 1000:5.0f} ms, "
          f"max {max(first) * 1000:5.0f} ms (a preview on 1/{step * step:.0f} of the points; {len(first)} changes); "
          f"< 200 ms: {'met' if percentile(first, 0.95) < 0.2 else 'NOT met'} (95th percentile)")
    print(f"  3D parameter change -> full result on screen, mug scan, shape system: median "
          f"{statistics.median(full) * 1000:5.0f} ms, 95th percentile {percentile(full, 0.95) * 1000:5.0f} ms, "
          f"max {max(full) * 1000:5.0f} ms")


if __name__ == "__main__":
    sys.exit(main())
