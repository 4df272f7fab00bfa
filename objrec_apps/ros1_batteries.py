"""The two batteries of a live patrol: the robot's from a ``sensor_msgs/BatteryState`` topic or the Kobuki's
``kobuki_msgs/SensorState``, the laptop's from another topic or from the machine objrec runs on
(``/sys/class/power_supply``, what the TurtleBot's laptop battery node read).

The robot's battery reports crossing its low threshold as the simulator's Kobuki does: an event
``robot_battery`` with ``event`` ``BATTERY_LOW`` (``BATTERY_CRITICAL`` at 5 %), once, re-armed 2 % higher; the
patrol's monitor listens for it. A first reading that is already low counts as a crossing (from an unknown
level): the monitor may have started before it came, and then only the event tells it.
``BatteryState.percentage`` is a fraction (0..1) by the message's definition; a driver that sends 0..100 instead
is recognised by a value above 1. Until a first message arrives the level is unknown (NaN): never low, never full.
"""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path
from typing import Any

from navigation.battery import kobuki_percent
from navigation.events import EventLog

from .ros1_messages import KOBUKI_CHARGED, KOBUKI_CHARGING

log = logging.getLogger(__name__)

#: sensor_msgs/BatteryState.power_supply_status values.
CHARGING, FULL = 1, 4
CRITICAL_PERCENT = 5.0
REARM_PERCENT = 2.0
FULL_PERCENT = 99.5
#: How often the laptop's battery files are read at most.
HOST_READ_PERIOD = 1.0
POWER_SUPPLY = Path("/sys/class/power_supply")


def percent_of(message: Any) -> float:
    """A BatteryState's charge in percent (NaN when the driver does not know it)."""
    value = float(message.percentage)
    if math.isnan(value):
        return value
    return value * 100.0 if value <= 1.0 else value


class TopicBattery:
    """A battery whose level arrives as BatteryState messages (:meth:`update`, on the patrol's thread)."""

    def __init__(self, low_percent: float, events: EventLog | None = None, name: str = "robot_battery") -> None:
        self.low_percent = low_percent
        self._events = events
        self._name = name
        self.percentage = math.nan
        self.voltage = math.nan
        self.charging = False
        self._full_flag = False
        self._low_fired = False
        self._critical_fired = False
        self.updates = 0

    @property
    def is_low(self) -> bool:
        return self.percentage <= self.low_percent and not self.charging

    @property
    def is_full(self) -> bool:
        return self._full_flag or self.percentage >= FULL_PERCENT

    def update(self, message: Any) -> None:
        """A sensor_msgs/BatteryState."""
        status = int(message.power_supply_status)
        self.level(percent_of(message), float(message.voltage), status == CHARGING, status == FULL)

    def update_kobuki(self, message: Any) -> None:
        """A kobuki_msgs/SensorState: the voltage in 0.1 V, turned into the Kobuki's own percentage (5 % at
        13.2 V, 100 % at 16.5 V), and the charger's state."""
        voltage = int(message.battery) / 10.0
        charger = int(message.charger)
        self.level(min(100.0, max(0.0, kobuki_percent(voltage))), voltage, charger in KOBUKI_CHARGING,
                   charger in KOBUKI_CHARGED)

    def level(self, pct: float, voltage: float, charging: bool, full: bool) -> None:
        """A new reading: the low and critical events fire once when crossed and re-arm 2 % higher."""
        if math.isnan(pct):
            return
        self.percentage = pct
        self.voltage = voltage
        self.charging = charging
        self._full_flag = full
        self.updates += 1
        if not self._low_fired and pct <= self.low_percent:
            self._low_fired = True
            self._emit("BATTERY_LOW")
        if not self._critical_fired and pct <= CRITICAL_PERCENT:
            self._critical_fired = True
            self._emit("BATTERY_CRITICAL")
        if self._low_fired and pct > self.low_percent + REARM_PERCENT:
            self._low_fired = False
        if self._critical_fired and pct > CRITICAL_PERCENT + REARM_PERCENT:
            self._critical_fired = False

    def _emit(self, event: str) -> None:
        if self._events is not None:
            voltage = None if math.isnan(self.voltage) else round(self.voltage, 3)
            self._events.emit(self._name, event=event, percentage=round(self.percentage, 2), voltage=voltage)


class NoBattery:
    """No battery reading configured: unknown level, never low (the monitor never fires), never full."""

    percentage = math.nan
    is_low = False
    is_full = False


class HostBattery:
    """The battery of the computer objrec runs on, from ``/sys/class/power_supply/*`` (Linux); a computer
    without one (a desktop, a container) is never low. Read at most once per :data:`HOST_READ_PERIOD`."""

    def __init__(self, low_percent: float, root: Path = POWER_SUPPLY) -> None:
        self.low_percent = low_percent
        self._root = root
        self._read_at = -math.inf
        self._percentage = math.nan
        self.charging = False
        self.found = self._battery_dir() is not None
        if not self.found:
            log.info("no battery under %s: the laptop battery monitor will not fire", root)

    def _battery_dir(self) -> Path | None:
        try:
            for entry in sorted(self._root.iterdir()):
                if (entry / "type").is_file() and (entry / "type").read_text().strip() == "Battery":
                    return entry
        except OSError:
            return None
        return None

    def _read(self) -> None:
        now = time.monotonic()
        if now - self._read_at < HOST_READ_PERIOD:
            return
        self._read_at = now
        where = self._battery_dir()
        if where is None:
            return
        try:
            self._percentage = float((where / "capacity").read_text().strip())
            self.charging = (where / "status").read_text().strip() in ("Charging", "Full")
        except (OSError, ValueError) as exc:
            log.debug("%s: %s", where, exc)

    @property
    def percentage(self) -> float:
        self._read()
        return self._percentage

    @property
    def is_low(self) -> bool:
        pct = self.percentage
        return not math.isnan(pct) and pct < self.low_percent and not self.charging
