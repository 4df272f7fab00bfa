"""Live topics over loopback against files: frames/s, latency, dropped frames and memory of a live detector.

Three processes per run, so that no side's timing is another's: a camera stand-in (a child) publishes the 2D
demo's 640x480 frames as ``sensor_msgs/Image`` (bgr8, header stamp = send time) at ``--fps`` with objrec's own
publisher; the detector (a child) runs the hsv demo system (``params/hsv_demo.yaml``) over the live source
``ros1:/camera/image_raw`` or ``ros2:/camera/image_raw`` and publishes its detections with the live publisher
(what ``objrec-detect --source ros1:/... --publish ros1:/detected_objects_2d`` composes); this process
subscribes to the detections and records, per detection, the time it arrived minus its header stamp: camera
stamp to detection received. ROS 1 runs against a real ``rosmaster`` on 127.0.0.1 at a free port (skipped,
with a line, where Debian's ROS 1 is absent); ROS 2 runs in the tests' loopback DDS configuration
(``tests/ros/live/dds_env.py``: interface ``lo``, no multicast, 127.0.0.1 the one peer) in a free domain.

The baseline, timed in the same run: the pipeline's own time per frame (``DetectionDirector.process``) on the
same frames read from PNG files. The target is latency p95 under 1.5x that time plus 5 ms, so the
table prints p95 / (1.5 x pipeline + 5 ms): under 1 meets it. With ``--slow-ms`` a second run per transport
sleeps that long per frame in the detector, so the camera outruns it: the source's counts show what it
received, processed and dropped (newest wins), and that processed + dropped (+ unreadable) equals received.
``--soak N`` runs N frames more per transport and reads the detector's resident memory at frame 1,000 and
at the end (growth in MiB; the target is none over 10,000 frames).

    python benchmarks/bench_live.py [--frames 300] [--fps 30] [--transports ros1,ros2] [--slow-ms 100]
                                    [--soak 1200]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import logging
import os
import platform
import queue
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from machine import cpu_model  # benchmarks/machine.py: scripts run with benchmarks/ on sys.path

if TYPE_CHECKING:
    from collections.abc import Iterator

    from objrec_core import Frame

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ROOT / "params" / "hsv_demo.yaml"
CAMERA_TOPIC = "/camera/image_raw"
DETECTIONS_TOPIC = "/detected_objects_2d"
#: Distinct demo frames the camera cycles through (and the baseline times): a second of video at 30 fps.
DISTINCT = 30
#: Detections left out of the latency figures: the first frames pay for first allocations and connections.
WARM_UP = 10
#: The frame at which the soak's first memory reading is taken.
SOAK_MARK = 1000
#: Seconds without a new camera message after which the detector ends its run.
QUIET_END = 3.0
#: Hang guard for a child to come up or a run to end on a loaded machine (never a timing figure).
DEADLINE = 120.0
MIB = 1024 * 1024

log = logging.getLogger("bench_live")


def _load(name: str, path: Path) -> ModuleType:
    """A module by path (the tests' environment helpers live outside any package on sys.path)."""
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # before exec: dataclasses look their module up
        spec.loader.exec_module(module)
    return sys.modules[name]


def rss_mib() -> float:
    """This process's resident memory now (VmRSS), in MiB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024 / MIB
    return float("nan")


def cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def demo_pictures(count: int) -> list[np.ndarray]:
    """The 2D demo's first ``count`` frames (640x480 BGR), as the camera sends them."""
    from objrec_core import open_source

    return [frame.data for frame in open_source(f"demo:frames={count}", "2d")]


# -- the camera stand-in (child process) ------------------------------------------------------------------
def camera(scheme: str, frames: int, fps: float) -> int:
    """Publish ``frames`` demo frames at ``fps`` once the detector subscribes; stamp each with its send time."""
    from objrec_core import Header
    from objrec_ros.encode import PictureEncoder
    from objrec_ros.live import open_transport

    pictures = demo_pictures(DISTINCT)
    with open_transport(scheme, {}, "bench_camera") as transport:
        encoder = PictureEncoder(transport.ros_version)
        # Sensor data QoS on ROS 2 (best effort), as a camera driver publishes and the live source reads.
        publisher = transport.advertise(CAMERA_TOPIC, encoder.msgtype, encoder.typestore, reliable=False)
        end = time.monotonic() + DEADLINE
        while publisher.subscribers < 1:
            if time.monotonic() > end:
                log.error("camera: no subscriber to %s within %.0f s", CAMERA_TOPIC, DEADLINE)
                return 1
            time.sleep(0.05)
        print("ready", flush=True)
        period = 1.0 / fps
        late = 0
        start = time.monotonic()
        for index in range(frames):
            due = start + index * period
            wait = due - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            elif wait < -period:
                late += 1  # this frame left more than a frame period behind its schedule
            stamp = time.time_ns()
            header = Header(seq=index, stamp=stamp / 1e9, frame_id="camera", stamp_ns=stamp)
            publisher.publish(encoder(pictures[index % len(pictures)], header))
        seconds = time.monotonic() - start
        time.sleep(1.0)  # let the last frame reach the detector before the connections close
        print("result " + json.dumps({"sent": frames, "seconds": seconds, "late": late}), flush=True)
    return 0


# -- the detector (child process) ----------------------------------------------------------------------------
def detector(scheme: str, params: Path, slow_ms: float, frames: int) -> int:
    """The hsv demo system over the live source with its detections published live, composed as objrec-detect
    composes ``--source ros1:/... --publish ros1:/...``; ends once the camera has been quiet for QUIET_END s
    and prints the source's counts, its CPU time and its resident memory along the run."""
    from objrec_apps.live_outputs import LiveDetections
    from objrec_apps.output_contract import RunEnd
    from objrec_core import DetectionDirector, build_system, open_source

    system = build_system(params)
    director = DetectionDirector(system, frame_id="camera")
    published = LiveDetections(f"{scheme}:{DETECTIONS_TOPIC}", system.object_array_type)
    # Per frame: camera stamp, frame in hand (received, deserialized, decoded), detections found (this sink
    # runs before the publisher's). Filled in up front, so the table's own pages are not memory growth.
    stamps = np.full((frames + 1, 3), -1, dtype=np.int64)
    row = [0]

    def found(_array: Any) -> None:
        if row[0] < len(stamps):
            stamps[row[0], 2] = time.time_ns()
        row[0] += 1

    director.add_sink(found)
    published.attach(director)
    if slow_ms > 0:
        director.add_sink(lambda _array: time.sleep(slow_ms / 1000.0))  # after the publisher: a slow consumer
    end = time.monotonic() + DEADLINE
    while published.publisher.subscribers < 1:  # this benchmark's listener, so no detection goes unseen
        if time.monotonic() > end:
            log.error("detector: no subscriber to %s within %.0f s", DETECTIONS_TOPIC, DEADLINE)
            return 1
        time.sleep(0.05)
    print("listened", flush=True)
    source = open_source(f"{scheme}:{CAMERA_TOPIC},timeout={DEADLINE:g}", "2d")
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())

    def watch_quiet() -> None:
        seen, since = source.received, time.monotonic()
        while not stop.wait(0.2):
            if source.received != seen:
                seen, since = source.received, time.monotonic()
            elif time.monotonic() - since > QUIET_END:
                stop.set()

    threading.Thread(target=watch_quiet, name="quiet", daemon=True).start()

    def in_hand() -> Iterator[Frame]:
        for frame in source:
            if row[0] < len(stamps):
                stamps[row[0], :2] = frame.stamp_ns, time.time_ns()
            yield frame

    source.watch_stop(stop)  # what director.run does for a source it is handed itself
    memory: list[tuple[int, float]] = []
    processed = 0
    cpu_start = cpu_seconds()
    start = last = time.monotonic()
    for _array in director.run(in_hand(), stop=stop):
        processed += 1
        last = time.monotonic()
        if processed % 100 == 0:  # SOAK_MARK among them
            memory.append((processed, rss_mib()))
    cpu = cpu_seconds() - cpu_start
    memory.append((processed, rss_mib()))
    result = {"processed": processed, "received": source.received, "dropped": source.dropped,
              "skipped": source.skipped, "seconds": last - start, "cpu_seconds": cpu,
              "published": published.count, "publish_failures": published.failures, "memory": memory,
              "stamps": stamps[: min(row[0], len(stamps))].tolist(),
              "summary": source.run_summary()}
    published.close(RunEnd())
    source.close()
    print("result " + json.dumps(result), flush=True)
    return 0


# -- this process: the setting, the children, the listener ----------------------------------------------------
class Child:
    """A role of this script run as a child process; its stdout read line by line with deadlines."""

    def __init__(self, role: list[str], env: dict[str, str], stderr: Path) -> None:
        self.stderr = stderr
        with stderr.open("wb") as err:
            self.process = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--role", *role],
                                            env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                            stderr=err, start_new_session=True)
        self.lines: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for raw in self.process.stdout:
            self.lines.put(raw.decode("utf-8", "replace").rstrip("\n"))
        self.lines.put(None)

    def wait_for(self, prefix: str, timeout: float = DEADLINE) -> str:
        """The first stdout line starting with ``prefix``; RuntimeError with the child's stderr otherwise."""
        end = time.monotonic() + timeout
        while (left := end - time.monotonic()) > 0:
            try:
                line = self.lines.get(timeout=left)
            except queue.Empty:
                break
            if line is None:
                break
            if line.startswith(prefix):
                return line
        tail = self.stderr.read_text(errors="replace")[-3000:]
        raise RuntimeError(f"{self.stderr.stem}: no '{prefix}' line within {timeout:.0f} s "
                           f"(exit code {self.process.poll()}):\n{tail}")

    def result(self, timeout: float) -> dict[str, Any]:
        return json.loads(self.wait_for("result ", timeout)[len("result "):])

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=10)


class Listener:
    """Subscribes to the detections in this process and keeps each one's arrival time and bytes."""

    def __init__(self, scheme: str, params: Path) -> None:
        from objrec_core import build_system
        from objrec_ros.encode import DetectionEncoder
        from objrec_ros.live import open_transport

        self.transport = open_transport(scheme, {}, "bench_listener")
        self.encoder = DetectionEncoder(build_system(params).object_array_type, self.transport.ros_version)
        self.subscription = self.transport.subscribe(DETECTIONS_TOPIC, self.encoder.ros_type, self.encoder.typestore,
                                                     reliable=True)
        self.arrivals: list[tuple[int, bytes]] = []
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._listen, name="listener", daemon=True)
        self._thread.start()

    def _listen(self) -> None:
        while not self._done.is_set():
            message = self.subscription.next(0.2)
            if message is not None:
                self.arrivals.append((message.received_ns, message.raw))

    def close(self) -> None:
        self._done.set()
        self._thread.join(timeout=10)
        self.transport.close()

    def heard(self) -> dict[int, int]:
        """Camera stamp -> when its detections arrived here (ns), in stamp order."""
        from objrec_ros.bags import header_stamp_ns

        store, ros_type = self.encoder.typestore, self.encoder.ros_type
        read = store.deserialize_ros1 if self.transport.ros_version == 1 else store.deserialize_cdr
        return dict(sorted((header_stamp_ns(read(raw, ros_type), received), received)
                           for received, raw in self.arrivals))


@dataclass
class LiveRun:
    """One run of camera, detector and listener on one transport."""

    scheme: str
    camera: dict[str, Any]
    detector: dict[str, Any]
    detections: int
    listener_dropped: int
    heard: dict[int, int] = field(repr=False)

    def legs_ms(self) -> dict[str, list[float]]:
        """Per frame heard, the warm-up left out, in ms: ``total`` camera stamp -> detections received here;
        ``in`` stamp -> frame in the detector's hand (encoding, the wire, deserializing, decoding, waiting
        for the loop); ``detect`` in hand -> detections found (the pipeline, as the baseline times it);
        ``out`` found -> received here (encoding, publishing, the wire back)."""
        legs: dict[str, list[float]] = {"total": [], "in": [], "detect": [], "out": []}
        inside = {stamp: (taken, sent) for stamp, taken, sent in self.detector["stamps"]}
        for stamp, heard in list(self.heard.items())[WARM_UP:]:
            legs["total"].append((heard - stamp) / 1e6)
            if stamp in inside:
                taken, sent = inside[stamp]
                legs["in"].append((taken - stamp) / 1e6)
                legs["detect"].append((sent - taken) / 1e6)
                legs["out"].append((heard - sent) / 1e6)
        return legs

    @property
    def latencies(self) -> list[float]:
        return self.legs_ms()["total"]

    @property
    def rate(self) -> float:
        seconds = self.detector["seconds"]
        return (self.detector["processed"] - 1) / seconds if seconds > 0 else 0.0

    def percentile(self, q: float) -> float:
        return float(np.percentile(self.latencies, q)) if self.latencies else float("nan")

    @property
    def balanced(self) -> bool:
        d = self.detector
        return d["processed"] + d["dropped"] + d["skipped"] == d["received"]

    def memory_growth(self) -> tuple[float, float] | None:
        """(MiB at frame SOAK_MARK, MiB at the end), when the run got that far."""
        memory = dict((frame, mib) for frame, mib in self.detector["memory"])
        if SOAK_MARK not in memory:
            return None
        return memory[SOAK_MARK], self.detector["memory"][-1][1]


def run_live(scheme: str, env: dict[str, str], params: Path, frames: int, fps: float, slow_ms: float,
             work: Path, label: str) -> LiveRun:
    """Camera and detector as children, the listener here; the figures of one run."""
    listener = Listener(scheme, params)
    children: list[Child] = []
    try:
        detect = Child(["detector", scheme, str(params), str(slow_ms), str(frames)], env,
                       work / f"{label}-detector.stderr")
        children.append(detect)
        detect.wait_for("listened")
        cam = Child(["camera", scheme, str(frames), str(fps)], env, work / f"{label}-camera.stderr")
        children.append(cam)
        cam.wait_for("ready")
        camera_result = cam.result(timeout=frames / fps * 3 + DEADLINE)
        detector_result = detect.result(timeout=DEADLINE)
        time.sleep(0.5)  # the last detection on its way
    finally:
        for child in children:
            child.stop()
        listener.close()
    return LiveRun(scheme, camera_result, detector_result, len(listener.arrivals), listener.subscription.dropped,
                   listener.heard())


# -- the baseline: the same frames from files -----------------------------------------------------------------
@dataclass
class Baseline:
    pipeline_ms: float  # mean over the frames of each frame's median DetectionDirector.process time
    files_rate: float  # frames/s reading the PNG files and processing them, best of the repeats


def baseline(params: Path, folder: Path, repeats: int = 5) -> Baseline:
    from objrec_core import DetectionDirector, build_system, open_source

    for index, picture in enumerate(demo_pictures(DISTINCT)):
        cv2.imwrite(str(folder / f"{index:05d}.png"), picture)
    director = DetectionDirector(build_system(params), frame_id="camera")
    frames = list(open_source(str(folder), "2d"))
    times = np.empty((repeats, len(frames)))
    for repeat in range(repeats):
        for index, frame in enumerate(frames):
            start = time.perf_counter()
            director.process(frame)
            times[repeat, index] = time.perf_counter() - start
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        count = sum(1 for _ in director.run(open_source(str(folder), "2d")))
        rates.append(count / (time.perf_counter() - start))
    return Baseline(float(np.median(times, axis=0).mean() * 1000), max(rates))


# -- the transports' settings ------------------------------------------------------------------------------
class Ros1Setting:
    """A real rosmaster on 127.0.0.1 at a free port (the tests' ros1_env helpers)."""

    def __init__(self, work: Path) -> None:
        self.env_module = _load("objrec_bench_ros1_env", ROOT / "tests" / "ros" / "live" / "ros1_env.py")
        self.missing = self.env_module.ros1_missing()
        self.master = None
        self.work = work

    def __enter__(self) -> dict[str, str]:
        self.master = self.env_module.start_master(self.work / "ros_home")
        values = {"ROS_MASTER_URI": self.master.uri, "ROS_IP": "127.0.0.1"}
        os.environ.update(values)
        os.environ.pop("ROS_HOSTNAME", None)
        return dict(os.environ)

    def __exit__(self, *_exc: object) -> None:
        if self.master is not None:
            self.env_module.stop_master(self.master)


class Ros2Setting:
    """DDS on loopback in a free domain (the tests' dds_env helpers)."""

    def __init__(self, work: Path) -> None:
        self.env_module = _load("objrec_tests_dds_env", ROOT / "tests" / "ros" / "live" / "dds_env.py")
        installed = importlib.util.find_spec("cyclonedds") is not None
        self.missing = None if installed else "the ros2 extra (cyclonedds) is not installed"
        self.setting = None

    def __enter__(self) -> dict[str, str]:
        self.setting = self.env_module.make_env()
        for name in ("CYCLONEDDS_URI", "ROS_DOMAIN_ID", "ROS_LOCALHOST_ONLY", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
            os.environ[name] = self.setting.env[name]
        return dict(self.setting.env)

    def __exit__(self, *_exc: object) -> None:
        if self.setting is not None:
            self.env_module.release(self.setting.domain)


SETTINGS = {"ros1": Ros1Setting, "ros2": Ros2Setting}


# -- the report ------------------------------------------------------------------------------------------------
def load_average() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def print_latency(run: LiveRun, base: Baseline) -> None:
    target = 1.5 * base.pipeline_ms + 5.0
    p50, p95 = run.percentile(50), run.percentile(95)
    d, c = run.detector, run.camera
    cpu = d["cpu_seconds"] / max(1, d["processed"]) * 1000
    print(f"  {run.scheme:<5} {run.rate:7.1f} frames/s  latency p50 {p50:6.2f} ms  p95 {p95:6.2f} ms  "
          f"p95 / target {p95 / target:5.2f}  dropped {d['dropped']}  "
          f"(sent {c['sent']}, {c['late']} late; received {d['received']}, processed {d['processed']}; "
          f"{d['published']} published, {run.detections} heard, listener dropped {run.listener_dropped}; "
          f"detector CPU {cpu:.2f} ms/frame)", flush=True)
    legs = run.legs_ms()
    parts = [f"{name} p50 {np.percentile(values, 50):.2f} / p95 {np.percentile(values, 95):.2f} ms"
             for name, values in legs.items() if name != "total" and values]
    print(f"        legs: {'; '.join(parts)}", flush=True)


def print_slow(run: LiveRun, slow_ms: float) -> None:
    d = run.detector
    verdict = "equals" if run.balanced else "DOES NOT equal"
    print(f"  {run.scheme:<5} +{slow_ms:g} ms/frame: sent {run.camera['sent']}, received {d['received']}, "
          f"processed {d['processed']} ({run.rate:.1f} frames/s), dropped {d['dropped']}, unreadable {d['skipped']}: "
          f"processed + dropped + unreadable {verdict} received", flush=True)


def print_soak(run: LiveRun, frames: int) -> None:
    growth = run.memory_growth()
    d = run.detector
    if growth is None:
        print(f"  {run.scheme:<5} {frames} frames sent, {d['processed']} processed: fewer than {SOAK_MARK} frames, "
              "no growth figure", flush=True)
        return
    at_mark, at_end = growth
    peak = max(mib for frame, mib in d["memory"] if frame >= SOAK_MARK)
    print(f"  {run.scheme:<5} {d['processed']} frames processed ({d['dropped']} dropped, {run.rate:.1f} frames/s): "
          f"RSS {at_mark:.1f} MiB at frame {SOAK_MARK}, {at_end:.1f} MiB at the end: "
          f"growth {at_end - at_mark:+.2f} MiB "
          f"(peak after frame {SOAK_MARK}: {peak:.1f} MiB)", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300, help="frames the camera sends per latency run")
    parser.add_argument("--fps", type=float, default=30.0, help="the camera's rate")
    parser.add_argument("--transports", default="ros1,ros2", help="comma-separated: ros1, ros2")
    parser.add_argument("--slow-ms", type=float, default=100.0,
                        help="the slow pipeline's sleep per frame (0: no slow run)")
    parser.add_argument("--soak", type=int, default=1200, help="frames of the memory run per transport (0: none)")
    parser.add_argument("--params", type=Path, default=PARAMS)
    parser.add_argument("--role", nargs="+", help=argparse.SUPPRESS)  # a child: camera or detector
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    if args.role:
        role, scheme, *rest = args.role
        if role == "camera":
            return camera(scheme, int(rest[0]), float(rest[1]))
        return detector(scheme, Path(rest[0]), float(rest[1]), int(rest[2]))
    schemes = [s.strip() for s in args.transports.split(",") if s.strip()]
    unknown = [s for s in schemes if s not in SETTINGS]
    if unknown:
        parser.error(f"--transports: {', '.join(unknown)}: choose from ros1, ros2")
    if args.frames <= WARM_UP:
        parser.error(f"--frames {args.frames}: more than the {WARM_UP} warm-up frames")
    if not 0 < args.fps <= 1000 or args.slow_ms < 0 or args.soak < 0:
        parser.error(f"--fps {args.fps:g} (0 < fps <= 1000), --slow-ms {args.slow_ms:g} and --soak {args.soak} "
                     "(not negative)")

    print(f"machine: {cpu_model()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"OpenCV {cv2.__version__}; load average {load_average()} at the start", flush=True)
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        folder = work / "png"
        folder.mkdir()
        base = baseline(args.params, folder)
        target = 1.5 * base.pipeline_ms + 5.0
        print(f"\nbaseline, the same {DISTINCT} frames from PNG files: pipeline {base.pipeline_ms:.3f} ms/frame "
              f"(DetectionDirector.process, median of 5 per frame), read + process {base.files_rate:.1f} frames/s; "
              f"latency target p95 < 1.5 x {base.pipeline_ms:.3f} + 5 = {target:.2f} ms", flush=True)
        failed = 0
        for scheme in schemes:
            setting = SETTINGS[scheme](work)
            if setting.missing:
                print(f"\n{scheme}: skipped: {setting.missing}", flush=True)
                continue
            try:
                with setting as env:
                    measure(scheme, env, args, base, work)
            except (RuntimeError, AssertionError) as exc:  # a child that failed, a master that did not start
                print(f"{scheme}: failed: {exc}", flush=True)
                failed += 1
    print(f"\nload average {load_average()} at the end", flush=True)
    return 1 if failed else 0


def measure(scheme: str, env: dict[str, str], args: argparse.Namespace, base: Baseline, work: Path) -> None:
    """The latency run, the slow run and the soak of one transport, each printed as it ends."""
    print(f"\n{scheme}: {args.frames} frames of 640x480 bgr8 at {args.fps:g} fps", flush=True)
    latency = run_live(scheme, env, args.params, args.frames, args.fps, 0.0, work, f"{scheme}-latency")
    print_latency(latency, base)
    if args.slow_ms > 0:
        slow = run_live(scheme, env, args.params, args.frames, args.fps, args.slow_ms, work, f"{scheme}-slow")
        print_slow(slow, args.slow_ms)
    if args.soak > 0:
        soak = run_live(scheme, env, args.params, args.soak, args.fps, 0.0, work, f"{scheme}-soak")
        print_soak(soak, args.soak)
        print_latency(soak, base)


if __name__ == "__main__":
    sys.exit(main())
