"""The kinds' live sources on ROS 2 over DDS (loopback only, a domain id of the test's own): frames equal what
the bag source reads from the same messages, and ``--list-topics ros2:`` lists what is published."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from objrec_core import open_source

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")


from tests.ros.live import dds_env as dds  # one shared instance: it remembers the domain ids handed out

dds_env = dds.dds_env  # the fixture, used by name

STAMP = 1_700_000_000_000_000_000


class Repeater:
    """Publishes one message (CDR bytes) every 0.1 s on a topic until closed: a camera that keeps sending, so
    a subscriber that joins late (DDS discovery takes a moment) still gets it."""

    def __init__(self, options: dict[str, str], topic: str, msgtype: str, store: Any, raw: bytes) -> None:
        from objrec_ros.live import open_transport

        self.transport = open_transport("ros2", options, "test_camera")
        self.publisher = self.transport.advertise(topic, msgtype, store, reliable=False)
        self.raw = raw
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stop.wait(0.1):
            self.publisher.publish(self.raw)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(60)
        self.transport.close()


@pytest.fixture
def repeaters() -> Iterator[list[Repeater]]:
    made: list[Repeater] = []
    yield made
    for repeater in made:
        repeater.close()


def test_a_pointcloud2_topic_gives_the_frames_the_bag_source_reads(dds_env, repeaters, tmp_path,
                                                                   bagmaker, demo_clouds):
    maker = bagmaker.Messages("mcap")
    cloud = demo_clouds[0]
    message = maker.cloud(cloud.points.reshape(cloud.height, cloud.width, 3), cloud.colors, STAMP, "depth")
    bag = bagmaker.write(tmp_path / "clouds", "mcap", maker,
                         [bagmaker.Entry("/camera/depth/points", bagmaker.POINT_CLOUD2, STAMP, message)])
    with open_source(str(bag), "3d") as source:
        recorded = next(iter(source))
    raw = bytes(maker.serialize(message, bagmaker.POINT_CLOUD2))
    repeaters.append(Repeater(dds_env.options, "/camera/depth/points", bagmaker.POINT_CLOUD2, maker.store, raw))
    with open_source(f"ros2:/camera/depth/points,domain={dds_env.domain},timeout=60", "3d") as source:
        live = next(iter(source))
    assert np.array_equal(live.data.points, recorded.data.points, equal_nan=True)
    assert np.array_equal(live.data.colors, recorded.data.colors)
    assert (live.stamp_ns, live.frame_id) == (recorded.stamp_ns, recorded.frame_id) == (STAMP, "depth")


def test_list_topics_of_a_ros2_domain(dds_env, repeaters, bagmaker, demo_images):
    from objrec_ros.live.listing import list_live_topics

    maker = bagmaker.Messages("mcap")
    raw = bytes(maker.serialize(maker.image(demo_images[0][:4, :4], "bgr8", STAMP), bagmaker.IMAGE))
    repeaters.append(Repeater(dds_env.options, "/camera/color/image_raw", bagmaker.IMAGE, maker.store, raw))
    text = list_live_topics(f"ros2:,domain={dds_env.domain},timeout=5")
    rows = [line.split() for line in text.splitlines()]
    assert rows[0] == ["topic", "type"]
    assert ["/camera/color/image_raw", "sensor_msgs/msg/Image"] in rows
    assert text.splitlines()[-1].startswith(f"ros2 (domain={dds_env.domain}): ")
