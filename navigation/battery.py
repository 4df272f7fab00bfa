"""The robot's (Kobuki) and the laptop's batteries.

The Kobuki reports a voltage and derives its percentage from it (kobuki_driver: 5 % at the "dangerous"
13.2 V, 100 % at 16.5 V, linear between), and raises BATTERY_LOW at 14.0 V and BATTERY_CRITICAL at 13.2 V
once each time the voltage crosses them. Here the voltage follows the state of charge on a straight line
chosen so that the reported percentage equals the state of charge. Defaults match the small Kobuki pack:
2200 mAh, about 3 h of driving, about 1.5 h on the dock to recharge.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from .events import EventLog

log = logging.getLogger(__name__)

KOBUKI_FULL_V = 16.5
KOBUKI_LOW_V = 14.0
KOBUKI_DANGEROUS_V = 13.2


def kobuki_percent(voltage: float) -> float:
    """The Kobuki driver's percentage for a voltage (5 % at 13.2 V, 100 % at 16.5 V), clamped to 0..100."""
    pct = 95.0 * (voltage - KOBUKI_DANGEROUS_V) / (KOBUKI_FULL_V - KOBUKI_DANGEROUS_V) + 5.0
    return max(0.0, min(100.0, pct))


def kobuki_voltage(percent: float) -> float:
    """Inverse of :func:`kobuki_percent` on its linear part."""
    return KOBUKI_DANGEROUS_V + (percent - 5.0) * (KOBUKI_FULL_V - KOBUKI_DANGEROUS_V) / 95.0


@dataclass(frozen=True)
class RobotBatteryParams:
    """Capacity, currents (from run and charge times) and the Kobuki's event thresholds (volts)."""

    capacity_mah: float = 2200.0
    runtime_h: float = 3.0
    idle_ratio: float = 0.35
    charge_time_h: float = 1.5
    low_voltage: float = KOBUKI_LOW_V
    critical_voltage: float = KOBUKI_DANGEROUS_V
    rearm_percent: float = 2.0

    @property
    def drive_current_ma(self) -> float:
        return self.capacity_mah / self.runtime_h

    @property
    def idle_current_ma(self) -> float:
        return self.drive_current_ma * self.idle_ratio

    @property
    def charge_current_ma(self) -> float:
        return self.capacity_mah / self.charge_time_h

    @property
    def low_percent(self) -> float:
        return kobuki_percent(self.low_voltage)

    @property
    def critical_percent(self) -> float:
        return kobuki_percent(self.critical_voltage)


class RobotBattery:
    """State of charge of the base; emits Kobuki power-system events on ``events``."""

    def __init__(self, events: EventLog, params: RobotBatteryParams | None = None, percent: float = 100.0) -> None:
        self.params = params or RobotBatteryParams()
        self.events = events
        self.charge = max(0.0, min(1.0, percent / 100.0))
        self.charging = False
        self._low_fired = self.percentage <= self.params.low_percent
        self._critical_fired = self.percentage <= self.params.critical_percent

    @property
    def voltage(self) -> float:
        return kobuki_voltage(100.0 * self.charge)

    @property
    def percentage(self) -> float:
        return kobuki_percent(self.voltage)

    @property
    def is_low(self) -> bool:
        return self.percentage <= self.params.low_percent

    @property
    def is_full(self) -> bool:
        return self.charge >= 1.0

    @property
    def is_empty(self) -> bool:
        return self.charge <= 0.0

    def _emit(self, name: str) -> None:
        self.events.emit("robot_battery", event=name, percentage=round(self.percentage, 2),
                         voltage=round(self.voltage, 3))

    def set_docked(self, docked: bool) -> None:
        """Start or stop charging, as plugging into or leaving the dock base does."""
        if docked == self.charging:
            return
        self.charging = docked
        self._emit("PLUGGED_TO_DOCKBASE" if docked else "UNPLUGGED")

    def update(self, dt: float, moving: bool) -> None:
        p = self.params
        was_full = self.is_full
        if self.charging:
            self.charge = min(1.0, self.charge + p.charge_current_ma * dt / 3600.0 / p.capacity_mah)
        else:
            current = p.drive_current_ma if moving else p.idle_current_ma
            self.charge = max(0.0, self.charge - current * dt / 3600.0 / p.capacity_mah)
        pct = self.percentage
        if not self._low_fired and pct <= p.low_percent:
            self._low_fired = True
            self._emit("BATTERY_LOW")
        if not self._critical_fired and pct <= p.critical_percent:
            self._critical_fired = True
            self._emit("BATTERY_CRITICAL")
        if self._low_fired and pct > p.low_percent + p.rearm_percent:
            self._low_fired = False
        if self._critical_fired and pct > p.critical_percent + p.rearm_percent:
            self._critical_fired = False
        if self.charging and self.is_full and not was_full:
            self._emit("CHARGE_COMPLETED")


@dataclass(frozen=True)
class LaptopBatteryParams:
    """A typical notebook: about 2.5 h on battery, low at 20 %, about 2 h to recharge when plugged."""

    runtime_h: float = 2.5
    charge_time_h: float = 2.0
    low_percent: float = 20.0


class LaptopBattery:
    """The notebook on the robot: a percentage and whether it is charging (plugged in)."""

    def __init__(self, events: EventLog, params: LaptopBatteryParams | None = None, percent: float = 100.0,
                 plugged: bool = False) -> None:
        self.params = params or LaptopBatteryParams()
        self.events = events
        self.percentage = max(0.0, min(100.0, percent))
        self.charging = plugged
        self._low_fired = self.is_low

    @property
    def is_low(self) -> bool:
        """Low means below the threshold and not charging, the condition the battery monitor checks."""
        return self.percentage < self.params.low_percent and not self.charging

    def update(self, dt: float) -> None:
        p = self.params
        if self.charging:
            self.percentage = min(100.0, self.percentage + 100.0 * dt / 3600.0 / p.charge_time_h)
        else:
            self.percentage = max(0.0, self.percentage - 100.0 * dt / 3600.0 / p.runtime_h)
        if self.is_low and not self._low_fired:
            self._low_fired = True
            self.events.emit("laptop_battery", event="LOW", percentage=round(self.percentage, 2),
                             charging=self.charging)
        elif not self.is_low:
            self._low_fired = False
