"""Hostile and careless parameter files: each is refused quickly with the key path and the value, and a
file load reaches observers and modules as one complete change."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from objrec2d import BinaryDetector, HSVFilter, MorphologyFilter
from objrec_core import ParameterError, ParameterFileError, ParameterStorage, RecognitionSystem, build_system

HEAD = "format_version: 1\nkind: 2d\n"


def load_error(tmp_path, text: str) -> ParameterFileError:
    path = tmp_path / "p.yaml"
    path.write_text(text)
    with pytest.raises(ParameterFileError) as info:
        build_system(path)
    return info.value


def test_an_alias_bomb_is_refused_at_once(tmp_path):
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]" for i in range(1, 9)]
    start = time.thread_time()  # CPU time of this thread: a loaded machine cannot fail it
    error = load_error(tmp_path, HEAD + "description: *a8\n" + "\n".join(lines) + "\npipeline: []\n")
    assert time.thread_time() - start < 1.0
    assert "aliases" in str(error)


def test_deep_nesting_is_refused_without_a_crash(tmp_path):
    error = load_error(tmp_path, HEAD + "pipeline: " + "[" * 5000 + "]" * 5000 + "\n")
    assert "line 3, column 42: not valid YAML: nested deeper than 32 levels" in str(error)


def test_duplicate_keys_are_refused_with_their_line(tmp_path):
    error = load_error(tmp_path, HEAD + "pipeline:\n- type: HSVFilter\n  parameters:\n    h_min: 100\n    h_min: 10\n")
    assert "'h_min' appears twice" in str(error) and "line 7" in error.key_path
    error = load_error(tmp_path, HEAD + "pipeline: []\npipeline:\n- type: HSVFilter\n")
    assert "'pipeline' appears twice" in str(error)


@pytest.mark.parametrize(
    ("parameters", "key_path", "fragment"),
    [
        ("{h_min: null}", "pipeline[0].parameters.h_min", "None is invalid: expected an integer"),
        ("{h_min: 99999999999999999999}", "pipeline[0].parameters.h_min", "99999999999999999999 is invalid"),
        ("false", "pipeline[0].parameters", "False is invalid: expected a mapping"),
        ("[1, 2]", "pipeline[0].parameters", "[1, 2] is invalid: expected a mapping"),
    ],
)
def test_messages_name_the_value(tmp_path, parameters, key_path, fragment):
    error = load_error(tmp_path, HEAD + f"pipeline:\n- type: HSVFilter\n  parameters: {parameters}\n")
    assert error.key_path == key_path and fragment in str(error)


def test_scientific_notation_gets_a_hint(tmp_path):
    error = load_error(tmp_path, HEAD + "pipeline:\n- type: BinaryDetector\n  parameters: {min_contour_length: 1e3}\n")
    assert "'1e3' is invalid" in str(error) and "write 1.0e3" in str(error)


def test_huge_values_are_shortened_in_messages(tmp_path):
    error = load_error(tmp_path, HEAD + "pipeline:\n- type: HSVFilter\n  parameters: {h_min: '" + "x" * 5000 + "'}\n")
    assert len(str(error)) < 400


def test_rules_between_parameters_are_checked_in_files_and_in_code(tmp_path):
    error = load_error(
        tmp_path,
        HEAD + "pipeline:\n- type: BinaryDetector\n  parameters: {min_contour_length: 900, max_contour_length: 50}\n",
    )
    assert error.key_path == "pipeline[0].parameters.min_contour_length"
    assert "min_contour_length: 900.0 is invalid: must be at most max_contour_length=50.0" in str(error)
    detector = BinaryDetector(max_contour_length=100)
    with pytest.raises(ParameterError, match="nothing could ever be found"):
        detector.set_parameters(min_contour_length=200)
    assert detector.min_contour_length == 40.0


def test_loading_informs_modules_of_changed_values(tmp_path):
    """A file that only changes the kernel shape must not leave the old kernel in use."""
    system = RecognitionSystem([MorphologyFilter(id="m", kernel_size=5), BinaryDetector(id="b")])
    mask = np.zeros((21, 21), np.uint8)
    mask[10, 10] = 255
    system.module("m").set_parameters(operation="dilate")
    assert system.module("m").filter(mask).sum() // 255 == 25  # a 5x5 rect, cached
    other = RecognitionSystem(
        [MorphologyFilter(id="m", kernel_size=5, operation="dilate", kernel_shape="cross"), BinaryDetector(id="b")]
    )
    path = tmp_path / "cross.yaml"
    ParameterStorage(other).save_parameters(path)
    ParameterStorage(system).load_parameters(path)
    assert system.module("m").filter(mask).sum() // 255 == 9  # a 5x5 cross


def test_a_file_load_is_one_change_for_observers(tmp_path):
    a, b = HSVFilter(id="a"), HSVFilter(id="b")
    system = RecognitionSystem([a, b, BinaryDetector(id="d")])
    seen = []
    a.watch(lambda changes: seen.append((a.h_min, b.h_min, [(c.name, c.old, c.new) for c in changes])))
    system.watch(lambda changes: seen.append(("system", a.h_min, b.h_min)))
    source = RecognitionSystem([HSVFilter(id="a", h_min=50), HSVFilter(id="b", h_min=60), BinaryDetector(id="d")])
    path = tmp_path / "p.yaml"
    ParameterStorage(source).save_parameters(path)
    ParameterStorage(system).load_parameters(path)
    assert seen == [(50, 60, [("h_min", 0, 50)]), ("system", 50, 60)]


def test_saving_through_a_link_updates_the_shared_file(tmp_path):
    real = tmp_path / "shared.yaml"
    link = tmp_path / "mine.yaml"
    ParameterStorage(RecognitionSystem([HSVFilter(h_min=1), BinaryDetector()])).save_parameters(real)
    link.symlink_to(real)
    ParameterStorage(RecognitionSystem([HSVFilter(h_min=7), BinaryDetector()])).save_parameters(link)
    assert link.is_symlink()
    assert build_system(real).module("HSVFilter").h_min == 7


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_saving_into_a_read_only_folder_is_a_parameter_file_error(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(ParameterFileError, match="cannot save"):
            ParameterStorage(RecognitionSystem([HSVFilter(), BinaryDetector()])).save_parameters(folder / "p.yaml")
    finally:
        folder.chmod(0o700)


def test_name_changes_are_notified():
    detector = BinaryDetector()
    system = RecognitionSystem([detector], object_name="cup")
    heard = []
    system.watch(lambda changes: heard.extend(("system", c.name, c.old, c.new) for c in changes))
    detector.watch(lambda changes: heard.extend(("detector", c.name, c.old, c.new) for c in changes))
    system.object_name = "mug"
    system.description = "on the table"
    detector.object_name = "special"
    assert heard == [("system", "object_name", "cup", "mug"), ("system", "description", "", "on the table"),
                     ("detector", "object_name", None, "special")]
    with pytest.raises(ValueError, match="non-empty"):
        system.object_name = " "


def test_choice_values_are_stored_as_plain_text(tmp_path):
    m = MorphologyFilter(operation=np.str_("close"))
    assert type(m.operation) is str
    ParameterStorage(RecognitionSystem([m, BinaryDetector()])).save_parameters(tmp_path / "p.yaml")


def test_binary_detector_takes_boolean_and_float_masks():
    mask = np.zeros((40, 40), bool)
    mask[5:25, 5:25] = True
    assert len(BinaryDetector().detect(mask)) == 1
    assert len(BinaryDetector().detect(mask.astype(np.float32))) == 1
