"""The libyaml event builder (strictio.yaml_events) reads every document as the pure-Python loader does: the same
data, the same key lines, the same refusals; and it is what makes a file near the node limit cheap."""

from __future__ import annotations

import time

import pytest

import strictio.yaml_reader as reader
from strictio import InputError
from strictio.yaml_events import AVAILABLE

pytestmark = pytest.mark.skipif(not AVAILABLE, reason="PyYAML without libyaml")

DOCUMENTS = [
    "a: 1\nb:\n  - x\n  - {c: 2, d: [1, 2.5, true, null, ~, 0x1f, 1_000]}\n  -\n    - q\n",
    "format_version: 1\nkind: 2d\npipeline:\n  - type: HSVFilter\n    id: hsv\n    parameters: {h_min: 0}\n",
    "- 2001-12-14\n- !!binary aGVsbG8=\n- !!str 12\n- '0.5'\n- \"tab\\there\"\n",
    "? [1]\n: 2\n",
    "a: !!set {x, y}\n",
    "name: \"bad\\udcffname\"\n",
    "",
    "# only a comment\n",
    "1: one\n2: two\n",
    "a: &x 1\nb: *x\n",
    "a: 1\na: 2\n",
    "a: 1\n---\nb: 2\n",
    "a: !!python/object:os.system x\n",
    "a: [\n",
    "pipeline: " + "[" * 60 + "]" * 60 + "\n",
    "big: " + "9" * 5000 + "\n",
    "a: !!float x\n",
]


def read_both(text: str) -> tuple[object, object]:
    """(fast, pure Python): each the (data, key lines) or the error text."""
    outcomes = []
    for fast in (True, False):
        saved = reader._LIBYAML
        reader._LIBYAML = fast
        try:
            outcomes.append(reader.yaml_text_with_lines(text, "doc.yaml"))
        except InputError as exc:
            outcomes.append(("refused", str(exc).split(": not valid YAML")[0] if "line" in str(exc) else "",
                             type(exc).__name__))
        finally:
            reader._LIBYAML = saved
    return outcomes[0], outcomes[1]


@pytest.mark.parametrize("text", DOCUMENTS)
def test_the_fast_path_reads_as_the_pure_python_loader(text: str) -> None:
    fast, slow = read_both(text)
    assert fast == slow


def test_a_document_near_the_node_limit_reads_in_seconds_of_cpu() -> None:
    text = "x: [" + ",".join("1" for _ in range(900_000)) + "]\n"
    start = time.process_time()
    data, lines = reader.yaml_text_with_lines(text)
    spent = time.process_time() - start
    assert len(data["x"]) == 900_000 and lines[("x", 899_999)] == 1
    assert spent < 8.0, f"{spent:.1f} s of CPU"  # the pure-Python loader takes over 20


def test_the_node_limit_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OBJREC_MAX_YAML_NODES", "1000")
    with pytest.raises(InputError, match="over the limit of 1,000 nodes"):
        reader.yaml_text("x: [" + ",".join("1" for _ in range(2000)) + "]\n", "doc.yaml")
