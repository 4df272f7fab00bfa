"""Kobuki and laptop batteries: percentages, run and charge times, events fired once per crossing."""

from __future__ import annotations

import pytest

from navigation.battery import (
    LaptopBattery,
    LaptopBatteryParams,
    RobotBattery,
    RobotBatteryParams,
    kobuki_percent,
    kobuki_voltage,
)
from navigation.events import EventLog


def _log() -> EventLog:
    return EventLog(lambda: 0.0)


def _kinds(log: EventLog) -> list[str]:
    return [e["event"] for e in log.events]


def test_kobuki_percentage_from_voltage():
    assert kobuki_percent(16.5) == 100.0
    assert kobuki_percent(13.2) == 5.0
    assert kobuki_percent(14.0) == pytest.approx(95 * 0.8 / 3.3 + 5)  # 28.03 %
    assert kobuki_percent(17.0) == 100.0 and kobuki_percent(12.0) == 0.0
    assert kobuki_voltage(kobuki_percent(15.1)) == pytest.approx(15.1)
    params = RobotBatteryParams()
    assert params.low_percent == pytest.approx(28.03, abs=0.01)
    assert params.critical_percent == pytest.approx(5.0)


def test_percentage_equals_state_of_charge():
    battery = RobotBattery(_log(), percent=63.0)
    assert battery.percentage == pytest.approx(63.0)
    assert battery.voltage == pytest.approx(kobuki_voltage(63.0))


def _hours_until(battery: RobotBattery, done, moving: bool = True, dt: float = 1.0) -> float:
    t = 0.0
    while not done(battery):
        battery.update(dt, moving)
        t += dt
    return t / 3600.0


def test_runtime_idle_and_charge_times():
    assert _hours_until(RobotBattery(_log()), lambda b: b.is_empty) == pytest.approx(3.0, abs=0.001)
    idle = _hours_until(RobotBattery(_log()), lambda b: b.is_empty, moving=False)
    assert idle == pytest.approx(3.0 / 0.35, abs=0.001)
    charging = RobotBattery(_log(), percent=0.0)
    charging.set_docked(True)
    assert _hours_until(charging, lambda b: b.is_full) == pytest.approx(1.5, abs=0.001)
    params = RobotBatteryParams()
    assert params.drive_current_ma == pytest.approx(2200 / 3)
    assert params.charge_current_ma == pytest.approx(2200 / 1.5)


def test_low_and_critical_fire_once_on_crossing_and_rearm_after_charging():
    log = _log()
    battery = RobotBattery(log, percent=30.0)
    for _ in range(3 * 3600):
        battery.update(1.0, moving=True)
    assert battery.is_empty
    assert _kinds(log) == ["BATTERY_LOW", "BATTERY_CRITICAL"]
    lows = [e["percentage"] for e in log.events]
    assert lows[0] == pytest.approx(28.03, abs=0.02) and lows[1] == pytest.approx(5.0, abs=0.02)
    battery.set_docked(True)
    while not battery.is_full:
        battery.update(1.0, moving=False)
    battery.set_docked(False)
    while battery.percentage > 20.0:
        battery.update(1.0, moving=True)
    assert _kinds(log) == ["BATTERY_LOW", "BATTERY_CRITICAL", "PLUGGED_TO_DOCKBASE", "CHARGE_COMPLETED",
                           "UNPLUGGED", "BATTERY_LOW"]


def test_starting_below_low_does_not_fire():
    log = _log()
    battery = RobotBattery(log, percent=20.0)
    battery.update(60.0, moving=True)
    assert battery.is_low and log.events == []


def test_laptop_low_only_when_not_charging():
    log = _log()
    laptop = LaptopBattery(log, LaptopBatteryParams(runtime_h=2.5, low_percent=20.0), percent=21.0)
    seconds = 0
    while not laptop.is_low:
        laptop.update(1.0)
        seconds += 1
    assert seconds == pytest.approx(0.01 * 2.5 * 3600 * 1.0, abs=1.0)  # 1 % of 2.5 h
    laptop.update(100.0)
    assert [e["event"] for e in log.events] == ["LOW"]
    laptop.charging = True
    assert not laptop.is_low
    before = laptop.percentage
    laptop.update(3600.0)  # one hour of a two-hour full charge
    assert laptop.percentage == pytest.approx(before + 50.0)
