"""The one opener, the one strict YAML reader and the one atomic writer refuse what they must, by name."""

from __future__ import annotations

import os
import stat

import pytest

from strictio import InputError, OutputError, YAMLLimits, read_bytes, read_text, read_yaml, write_atomically


def test_a_fifo_is_refused_at_once_instead_of_blocking(tmp_path):
    fifo = tmp_path / "params.yaml"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"params\.yaml: is a FIFO \(named pipe\), not a regular file"):
        read_text(fifo)


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom", "/dev/null"])
def test_devices_are_refused(device):
    if not os.path.exists(device):
        pytest.skip(f"{device} is absent")
    with pytest.raises(InputError, match="character device"):
        read_bytes(device)


def test_a_folder_and_a_missing_file_are_named(tmp_path):
    with pytest.raises(InputError, match="folder"):
        read_bytes(tmp_path)
    with pytest.raises(InputError, match=r"nope\.yaml: file not found"):
        read_bytes(tmp_path / "nope.yaml")


def test_an_oversized_file_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_bytes(b"a" * 1001)
    with pytest.raises(InputError, match="1,001 bytes, over the limit of 1,000"):
        read_bytes(path, limit=1000)
    assert read_bytes(path, limit=1001) == b"a" * 1001


def test_a_byte_order_mark_is_dropped_and_bad_utf8_is_named(tmp_path):
    path = tmp_path / "poses.txt"
    path.write_bytes(b"\xef\xbb\xbfkind: 2d\n")
    assert read_yaml(path) == {"kind": "2d"}
    path.write_bytes(b"ok\n\xff\xfe")
    with pytest.raises(InputError, match="not utf-8 text"):
        read_text(path)


def test_an_alias_bomb_is_refused_quickly(tmp_path):
    lines = ["a: &a [x, x, x, x, x, x, x, x, x]"]
    lines += [f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]" for i in range(9)]
    path = tmp_path / "map.yaml"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"line 2, column \d+: not valid YAML: aliases"):
        read_yaml(path)


def test_deep_nesting_duplicates_tags_and_huge_numbers(tmp_path):
    path = tmp_path / "d.yaml"
    path.write_text("[" * 60 + "]" * 60)
    with pytest.raises(InputError, match="nested deeper than 50 levels"):
        read_yaml(path)
    assert read_yaml(path, YAMLLimits(max_depth=100)) is not None
    path.write_text("a: 1\nb: 2\na: 3\n")
    with pytest.raises(InputError, match=r"line 3, column 1: not valid YAML: key 'a' appears twice"):
        read_yaml(path)
    path.write_text("a: !!python/object/apply:os.system ['true']\n")
    with pytest.raises(InputError, match="tags that build Python objects are not allowed"):
        read_yaml(path)
    path.write_text("a: " + "9" * 5000 + "\n")
    with pytest.raises(InputError, match="not valid YAML"):
        read_yaml(path)


def test_atomic_save_keeps_mode_and_refuses_what_is_not_a_regular_file(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("old")
    path.chmod(0o640)
    write_atomically(path, "new")
    assert path.read_text() == "new" and stat.S_IMODE(path.stat().st_mode) == 0o640
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match="not a regular file"):
        write_atomically(fifo, "x")
    assert stat.S_ISFIFO(fifo.stat().st_mode)  # not replaced by a regular file
    with pytest.raises(OutputError, match="does not exist"):
        write_atomically(tmp_path / "no" / "p.yaml", "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo.yaml", "p.yaml"]  # no temporary left behind
