"""strictio.signals: the one helper through which the commands take Ctrl-C and SIGTERM over and give them back."""

from __future__ import annotations

import os
import signal
import threading

import pytest

from strictio.signals import STOP_SIGNALS, StopSignals, handling, raise_interrupt


def test_handling_installs_for_the_block_and_gives_the_previous_back_even_after_an_error():
    before = {sig: signal.getsignal(sig) for sig in STOP_SIGNALS}
    seen: list[int] = []
    with pytest.raises(RuntimeError), handling(lambda signum, _frame: seen.append(signum)):
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGINT)
        raise RuntimeError("the block failed")
    assert seen == [signal.SIGTERM, signal.SIGINT]
    assert {sig: signal.getsignal(sig) for sig in STOP_SIGNALS} == before


def test_handling_can_ignore_one_signal_and_leave_the_other_alone():
    before_term = signal.getsignal(signal.SIGTERM)
    with handling(signal.SIG_IGN, (signal.SIGINT,)):
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) is before_term
        os.kill(os.getpid(), signal.SIGINT)  # ignored: nothing raised
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_sigterm_as_ctrl_c():
    with pytest.raises(KeyboardInterrupt), handling(raise_interrupt, (signal.SIGTERM,)):
        os.kill(os.getpid(), signal.SIGTERM)


def test_handling_outside_the_main_thread_changes_nothing():
    before = signal.getsignal(signal.SIGINT)
    inside: list[object] = []

    def worker() -> None:
        with handling(signal.SIG_IGN):
            inside.append(signal.getsignal(signal.SIGINT))

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join(timeout=60)
    assert inside == [before] and signal.getsignal(signal.SIGINT) is before


def test_the_first_signal_is_a_flag_with_its_name_and_a_second_gives_up():
    with StopSignals() as stop:
        os.kill(os.getpid(), signal.SIGTERM)
        assert (stop.count, stop.reason, stop.event.is_set()) == (1, "SIGTERM", True)
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
        assert (stop.count, stop.reason) == (2, "SIGTERM")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_only_the_named_signals_give_up_on_a_second_arrival():
    with StopSignals(escalate=(signal.SIGINT,)) as stop:
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGTERM)  # a supervisor repeating itself: still a clean stop
        assert (stop.count, stop.reason) == (2, "SIGTERM")
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)


def test_a_signal_ignored_when_the_block_begins_stays_ignored():
    """A background job's Ctrl-C (ignored by the shell that started it) is not taken over; SIGTERM still is."""
    seen: list[int] = []
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with handling(lambda signum, _frame: seen.append(signum)):
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGINT)
            os.kill(os.getpid(), signal.SIGTERM)
        assert seen == [signal.SIGTERM]
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        with StopSignals() as stop:
            os.kill(os.getpid(), signal.SIGINT)
            assert (stop.count, stop.event.is_set()) == (0, False)
    finally:
        signal.signal(signal.SIGINT, previous)
