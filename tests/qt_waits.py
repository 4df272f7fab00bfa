"""How long GUI tests wait for something to show: a hang guard, never a speed limit.

``qtbot.waitUntil`` and ``waitSignal`` return as soon as the condition holds, so a long bound costs a passing
test nothing; a short one fails a correct GUI on a busy 2-core machine (no test asserts wall-clock
time). Two minutes only ends a test whose window really stopped answering.
"""

HANG_GUARD_MS = 120_000
