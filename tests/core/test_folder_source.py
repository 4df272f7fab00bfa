"""objrec_core.folder_source: the one folder-of-files source both kinds subclass, tried on a kind of its own
(text files holding one number), so that what is tested is the base and not a reader."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from objrec_core import SourceError
from objrec_core.folder_source import FolderFilesSource, natural_key
from strictio import InputError, read_text


class NumberFiles(FolderFilesSource):
    """Files holding one number each."""

    kind = "numbers"
    extensions = (".num",)
    what = "number files"
    reads: list[str] = []  # noqa: RUF012 - the files read, in order, across the test

    @classmethod
    def read_file(cls, path: Path) -> float:
        cls.reads.append(path.name)
        try:
            return float(read_text(path, 100))
        except ValueError:
            raise InputError(path, "not a number") from None


def folder(tmp_path: Path, files: dict[str, str]) -> Path:
    where = tmp_path / "numbers"
    where.mkdir()
    for name, text in files.items():
        (where / name).write_text(text)
    return where


def test_files_in_natural_order_with_the_unreadable_skipped_once_each(tmp_path, caplog):
    where = folder(tmp_path, {"n10.num": "10", "n2.num": "2", "N1.num": "1", "n3.num": "three", "notes.txt": "x"})
    (where / "sub.num").mkdir()  # a folder is no file, whatever its name
    source = NumberFiles(where)
    assert source.length == 4 and source.seekable
    with caplog.at_level(logging.WARNING):
        frames = list(source)
        again = list(source)
    assert [(f.index, f.data, Path(f.source).name) for f in frames] == [(0, 1.0, "N1.num"), (1, 2.0, "n2.num"),
                                                                         (3, 10.0, "n10.num")]
    assert [(f.index, f.data) for f in again] == [(f.index, f.data) for f in frames]
    assert [p.name for p in source.skipped] == ["n3.num"]
    assert [r.getMessage() for r in caplog.records] == [f"{where / 'n3.num'}: not a number; skipped"] * 2


def test_seeking_reads_only_the_files_from_there_on(tmp_path):
    where = folder(tmp_path, {f"f{i}.num": str(i * 1.5) for i in range(6)})
    NumberFiles.reads.clear()
    frames = list(NumberFiles(where).frames_from(4))
    assert [(f.index, f.data) for f in frames] == [(4, 6.0), (5, 7.5)]
    assert NumberFiles.reads == ["f4.num", "f5.num"]
    assert list(NumberFiles(where).frames_from(6)) == []
    assert [f.index for f in NumberFiles(where).frames_from(-3)] == list(range(6))


def test_a_folder_of_nothing_readable_is_one_error_after_every_file_was_tried(tmp_path):
    where = folder(tmp_path, {"a.num": "x", "b.num": "y"})
    source = NumberFiles(where, name="my numbers")
    with pytest.raises(SourceError, match=r"^my numbers: none of its 2 number files could be read$"):
        list(source)
    assert [p.name for p in source.skipped] == ["a.num", "b.num"]


def test_one_file_alone_is_read_or_refused_at_once(tmp_path):
    where = folder(tmp_path, {"one.num": "4.25", "bad.num": "x", "other.txt": "1"})
    assert [(f.index, f.data) for f in NumberFiles(where / "one.num")] == [(0, 4.25)]
    with pytest.raises(InputError, match=r"bad\.num: not a number"):
        list(NumberFiles(where / "bad.num"))
    with pytest.raises(SourceError, match=r"other\.txt: number files end in \.num$"):
        NumberFiles(where / "other.txt")
    with pytest.raises(SourceError, match=r"missing\.num: no such file or folder$"):
        NumberFiles(where / "missing.num")


def test_a_folder_without_such_files_says_which_it_looked_for(tmp_path):
    where = folder(tmp_path, {"a.txt": "1"})
    with pytest.raises(SourceError, match=r"numbers: folder holds no number files \(\.num\)$"):
        NumberFiles(where)


def test_natural_order_compares_numbers_as_numbers():
    names = ["img10.png", "img9.png", "Img1.png", "img09b.png", "a.png"]
    assert sorted(names, key=lambda n: natural_key(Path(n))) == ["a.png", "Img1.png", "img9.png", "img09b.png",
                                                                  "img10.png"]
