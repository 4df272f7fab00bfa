"""The QoS a ROS 2 user expects of a camera subscriber and a detection publisher.

ROS 2 matches a reader and a writer only when their QoS are compatible (a reliable reader never hears a
best-effort writer), so objrec uses what rclcpp's own profiles use:

- inputs (camera images, clouds): rclcpp's ``SensorDataQoS``: best effort, keep last 5, volatile. A camera
  driver publishes best effort or reliable; a best-effort reader matches both.
- outputs (detections) and reliable inputs: rclcpp's default ``QoS(10)``: reliable, keep last 10, volatile;
  a latched output is transient local with keep last 1, as ROS 2 latches.

History is never unbounded (no KEEP_ALL), and a reliable writer blocks at most ``MAX_BLOCKING`` when its
readers lag (then the sample is dropped), so publishing never stalls detection for long. Data travels as
XCDR1 (plain CDR, encapsulation ``CDR_LE``), what the ROS 2 RMW layers write and rosbags serializes.
Writers and readers carry ROS 2's ``typehash=RIHS01_...;`` user data (ROS 2 Iron and later read it to
check types) when rosbags can compute the hash.
"""

from __future__ import annotations

import logging

from cyclonedds.qos import Policy, Qos
from cyclonedds.util import duration
from rosbags.typesys.store import Typestore

log = logging.getLogger(__name__)

SENSOR_DEPTH = 5
RELIABLE_DEPTH = 10
#: The longest a reliable write waits for lagging readers before its sample is dropped.
MAX_BLOCKING = duration(milliseconds=50)


def type_hash_user_data(typestore: Typestore, msgtype: str) -> bytes | None:
    """ROS 2's user data naming an endpoint's type hash (``typehash=RIHS01_<hex>;``), or None if unknown."""
    try:
        return f"typehash={typestore.hash_rihs01(msgtype)};".encode()
    except Exception as exc:  # rosbags raises its own errors for types it cannot describe
        log.debug("no RIHS01 hash for %s: %s", msgtype, exc)
        return None


def reader_qos(reliable: bool, user_data: bytes | None = None) -> Qos:
    """A subscription's QoS: sensor data (best effort, keep last 5) or reliable (keep last 10)."""
    policies = [
        Policy.Reliability.Reliable(max_blocking_time=MAX_BLOCKING) if reliable else Policy.Reliability.BestEffort,
        Policy.History.KeepLast(RELIABLE_DEPTH if reliable else SENSOR_DEPTH),
        Policy.Durability.Volatile,
        Policy.DataRepresentation(use_cdrv0_representation=True, use_xcdrv2_representation=True),
    ]
    if user_data:
        policies.append(Policy.Userdata(user_data))
    return Qos(*policies)


def writer_qos(reliable: bool, latch: bool, user_data: bytes | None = None) -> Qos:
    """A publisher's QoS: reliable keep last 10 (latched: transient local, keep last 1), or best effort."""
    policies = [
        Policy.Reliability.Reliable(max_blocking_time=MAX_BLOCKING) if reliable else Policy.Reliability.BestEffort,
        Policy.History.KeepLast(1 if latch else RELIABLE_DEPTH),
        Policy.Durability.TransientLocal if latch else Policy.Durability.Volatile,
        Policy.DataRepresentation(use_cdrv0_representation=True),
    ]
    if user_data:
        policies.append(Policy.Userdata(user_data))
    return Qos(*policies)
