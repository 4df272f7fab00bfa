"""Untrusted text reaches the terminal only escaped, through the one function strictio.shown.

The regression: ``objrec-detect --source $'zz\\u202eabc:1'`` wrote a raw right-to-left override to the
terminal, so the error line read ``zz1:cba``. The commands are run as a user runs them, in a child process.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

import navigation
import objrec_apps
from declare import printable as declared_printable
from declare import short_repr as declared_short_repr
from strictio.cli_numbers import one_line
from strictio.errors import InputError
from strictio.shown import escape_controls, printable, short_repr

from .harness import assert_refused, raw_controls, run

HSV = str(Path(objrec_apps.__file__).parent / "systems" / "hsv_demo.yaml")
NAV_DATA = Path(navigation.__file__).parent / "data"

HOSTILE = ["zz\u202eabc", "a\nb", "\x1b[2J\x1b[31mred", "a\rb", "iso\u2067late\u2069", "line\u2028sep", "c1\x9b31m"]


@pytest.mark.parametrize("text", HOSTILE)
def test_every_helper_escapes_what_a_terminal_acts_on(text):
    for shown in (escape_controls(text), printable(text), short_repr(text), one_line(text),
                  str(InputError(text, "unreadable"))):
        assert not raw_controls(shown), (text, shown)
        assert shown.isprintable(), shown


def test_the_override_is_shown_as_its_escape():
    assert printable("zz\u202eabc:1") == "zz\\u202eabc:1"
    assert short_repr({"k": "\x1b"}) == "{'k': '\\x1b'}"


def test_printable_cuts_long_text_at_the_limit():
    assert printable("x" * 100) == "x" * 57 + "..."
    assert printable("\u202e" * 10, limit=12) == "\\u202e" + "\\u2..."
    assert len(printable("y" * 500, limit=400)) == 400


def test_declare_reexports_the_one_helper_rather_than_a_copy():
    assert declared_printable is printable
    assert declared_short_repr is short_repr


def test_detect_escapes_a_bidi_override_in_the_source(tmp_path):
    outcome = run(["objrec-detect", HSV, "--source", "zz\u202eabc:1", "--max-frames", "1"], tmp_path)
    assert_refused(outcome, "zz\\u202eabc:1")
    assert "\u202e" not in outcome.stderr


def test_detect_escapes_a_terminal_escape_in_a_file_name(tmp_path):
    name = "frame\x1b[2J\u202e.png"
    (tmp_path / name).write_bytes(b"\x89PNG\r\n\x1a\n not really an image")
    outcome = run(["objrec-detect", HSV, "--source", name, "--max-frames", "1"], tmp_path)
    assert_refused(outcome, "frame\\x1b[2J\\u202e.png")


def test_detect_escapes_a_bidi_override_in_the_parameter_file_name(tmp_path):
    outcome = run(["objrec-detect", "sys\u202etem.yaml", "--source", "demo"], tmp_path)
    assert_refused(outcome, "sys\\u202etem.yaml")


def test_patrol_escapes_a_bidi_override_in_the_poses_file_name(tmp_path):
    outcome = run(["objrec-patrol", "poses\u202e.txt", "--map", str(NAV_DATA / "b5203.yaml"), "--laps", "1"],
                  tmp_path)
    assert_refused(outcome, "poses\\u202e.txt")


def test_the_commands_log_lines_show_their_message_escaped():
    from objrec_apps.cli import EscapingFormatter

    formatter = EscapingFormatter("objrec-detect: %(levelname)s: %(message)s")
    record = logging.LogRecord("objrec2d.sources", logging.WARNING, __file__, 1, "%s: no frame, retrying",
                               ("cam\u202eera\n",), None)
    assert formatter.format(record) == "objrec-detect: WARNING: cam\\u202eera\\n: no frame, retrying"
