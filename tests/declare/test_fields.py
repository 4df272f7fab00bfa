"""declare.fields: typed document fields read against the lines the strict YAML reader records."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from declare import Bool, Choice, Float, Int, Ordered, Str
from declare.fields import (
    REQUIRED,
    DocumentError,
    FilePath,
    Free,
    Invalid,
    ListOf,
    MapOf,
    Record,
    Value,
    Vector,
    code_place,
    document_from_text,
    not_blank,
    read_document,
)
from strictio import InputError, YAMLLimits

SHELF = Record({
    "name": Value(Str("", "the shelf's name"), required=True, check=not_blank),
    "height": Value(Float(1.0, "metres", min=0.0, min_open=True, max=10.0)),
    "boxes": ListOf(Record({
        "label": Value(Str("", "what is written on it"), required=True),
        "size": Vector(Float(0.1, "metres", min=0.0, max=5.0), ("width", "depth", "height"), required=True),
        "fragile": Bool(False, "handle with care"),
        "colour": Choice("brown", ("brown", "white"), "its colour"),
    }), null_is_empty=True),
})

TEXT = """\
name: top
height: 2.5
boxes:
  - label: books
    size: [0.3, 0.2, 0.2]
  - label: plates
    fragile: true
    size: [0.4, 0.4,
           7.5]
"""
VALID = TEXT.replace("7.5", "0.5")


def read(text: str, table: Record = SHELF, name: str = "shelf.yaml") -> dict:
    document = document_from_text(text, name)
    return table.read(document.data, document.root)


def failure(text: str, table: Record = SHELF) -> DocumentError:
    with pytest.raises(DocumentError) as info:
        read(text, table)
    return info.value


def test_a_valid_document_gives_typed_values_and_defaults():
    shelf = read(VALID)
    assert shelf["name"] == "top" and shelf["height"] == 2.5
    books, plates = shelf["boxes"]
    assert books == {"label": "books", "size": (0.3, 0.2, 0.2), "fragile": False, "colour": "brown"}
    assert plates["fragile"] is True and plates["size"] == (0.4, 0.4, 0.5)
    assert read("name: bare\n") == {"name": "bare", "height": 1.0, "boxes": ()}
    assert read("name: bare\nboxes:\n")["boxes"] == ()


def test_a_wrong_value_deep_in_a_list_names_its_line_key_path_value_and_rule():
    error = failure(TEXT)
    assert str(error) == ("shelf.yaml:9: boxes[1].size[2]: 7.5 is invalid: out of range, allowed float in 0..5")
    assert (error.line, error.key_path, error.value) == (9, "boxes[1].size[2]", 7.5)
    assert isinstance(error, InputError)  # commands print it as one line and exit 2


@pytest.mark.parametrize(("change", "expected"), [
    (("fragile: true", "fragile: 'yes'"), "shelf.yaml:7: boxes[1].fragile: 'yes' is invalid: expected true or false"),
    (("fragile: true", "fragle: true"),
     "shelf.yaml:7: boxes[1].fragle: unknown key (allowed: label, size, fragile, colour)"),
    (("  - label: plates\n", "  - colour: white\n"), "shelf.yaml:6: boxes[1].label: missing (what is written on it)"),
    (("height: 2.5", "height: 0"), "shelf.yaml:2: height: 0 is invalid: out of range, allowed float in (0..10]"),
    (("name: top", "name: '  '"), "shelf.yaml:1: name: '  ' is invalid: must not be empty"),
    (("[0.3, 0.2, 0.2]", "[0.3, 0.2]"),
     "shelf.yaml:5: boxes[0].size: [0.3, 0.2] is invalid: expected [width, depth, height], each float in 0..5"),
    (("boxes:\n  - label: books", "boxes: 3\nbox:\n  - label: books"),
     "shelf.yaml:4: box: unknown key (allowed: name, height, boxes)"),
])
def test_every_kind_of_mistake_reads_the_same_way(change, expected):
    assert str(failure(VALID.replace(*change))).startswith(expected)


def test_a_missing_key_takes_the_line_of_its_record():
    error = failure("name: top\nboxes:\n  - size: [1, 1, 1]\n")
    assert str(error) == "shelf.yaml:3: boxes[0].label: missing (what is written on it)"
    assert str(failure("name: top\nboxes: 3\n")).startswith(
        "shelf.yaml:2: boxes: 3 is invalid: expected a list, each a mapping of label, size, fragile, colour, got int")


def test_rules_between_fields_are_declare_rules():
    table = Record({"low": Float(0.0, "low"), "high": Float(1.0, "high")}, rules=(Ordered("low", "high"),))
    assert read("low: 0.2\nhigh: 0.9\n", table) == {"low": 0.2, "high": 0.9}
    assert str(failure("low: 0.95\nhigh: 0.9\n", table)) == (
        "shelf.yaml:1: low: 0.95 is invalid: must be at most high=0.9")


def test_map_of_declares_its_keys():
    table = Record({"at": MapOf(Int(0, "a pose index", min=0, max=3), ListOf(Int(0, "count")))})
    assert read("at:\n  0: [1, 2]\n  3: []\n", table) == {"at": {0: (1, 2), 3: ()}}
    assert str(failure("at:\n  0: [1]\n  7: [2]\n", table)) == (
        "shelf.yaml:3: at.7: not a key here: out of range, allowed int in 0..3")
    assert str(failure("at:\n  0: [1]\n  2: [2, x]\n", table)) == (
        "shelf.yaml:3: at.2[1]: 'x' is invalid: expected an integer, got str")


def test_shorthand_free_and_file_paths(tmp_path: Path):
    table = Record({"file": FilePath(required=True, doc="a file"), "extra": Free(kinds=(dict,), what="a mapping"),
                    "task": Record({"seconds": Float(2.0, "s", min=0.0)}, shorthand="seconds")})
    document = document_from_text("file: sub/a.png\ntask: 4\n", tmp_path / "t.yaml")
    values = table.read(document.data, document.root)
    assert values == {"file": tmp_path / "sub" / "a.png", "extra": None, "task": {"seconds": 4.0}}
    document = document_from_text("file: /abs/a.png\nextra: [1]\n", tmp_path / "t.yaml")
    with pytest.raises(DocumentError, match=r"t\.yaml:2: extra: \[1\] is invalid: expected a mapping, got list"):
        table.read(document.data, document.root)


def test_a_checked_invalid_names_the_field_it_is_about():
    def even(values: dict) -> str | None:
        if values["n"] % 2:
            raise Invalid("must be even", "n", values["n"])
        return None

    table = Record({"n": Int(0, "n")}, check=even)
    assert str(failure("n: 3\n", table)) == "shelf.yaml:1: n: 3 is invalid: must be even"


def test_values_given_in_code_name_the_key_path_alone(tmp_path: Path):
    at = code_place(tmp_path).key("wait")
    with pytest.raises(DocumentError) as info:
        Record({"seconds": Float(1.0, "s", min=0.0)}, shorthand="seconds").read(-1, at)
    assert str(info.value) == "wait.seconds: -1 is invalid: out of range, allowed float in 0..inf"
    assert info.value.line is None


def test_reading_a_file_names_the_file_for_every_refusal(tmp_path: Path):
    with pytest.raises(DocumentError, match=r"nowhere\.yaml: shelf file not found$"):
        read_document(tmp_path / "nowhere.yaml", what="shelf")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: a\nboxes: [\n")
    with pytest.raises(DocumentError) as info:
        read_document(bad)
    assert "bad.yaml: line 3, column 1: not valid YAML" in str(info.value) and info.value.line == 3
    bad.write_text("name: a\nboxes:\n  - size: [1, " + "9" * 5000 + ", 1]\n")
    with pytest.raises(DocumentError) as info:
        read_document(bad, YAMLLimits(max_depth=5))
    assert str(info.value) == f"{bad}:3: boxes[0].size[1]: an integer of 5,000 digits is not a usable number"


def test_messages_stay_one_line_and_errors_survive_pickling():
    error = failure("name: top\nboxes:\n  - label: x\n    size: [1, 1, 1]\n    \"a\\nb\\x1b[2J\": 1\n")
    assert "\n" not in str(error) and "\x1b" not in str(error) and "a\\nb\\x1b[2J" in str(error)
    again = pickle.loads(pickle.dumps(error))
    assert str(again) == str(error) and again.line == error.line == 5


def test_required_fields_have_no_default():
    assert Value(Int(1, "n"), required=True).default is REQUIRED
    assert Value(Int(1, "n")).default == 1
