"""The one opener, the one strict YAML reader and the one atomic writer refuse what they must, by name."""

from __future__ import annotations

import errno
import os
import pickle
import random
import signal
import stat
import subprocess
import sys
import time

import pytest

from strictio import InputError, OutputError, YAMLLimits, atomic, read_bytes, read_text, read_yaml, write_atomically
from strictio.atomic import LineOutput, remove_stale_temporaries, temporary_path
from strictio.errors import escape_controls


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


# -- saves: what is at the path stays, killed saves leave nothing for long ------------------------------------
def char_device(tmp_path) -> str:
    """A character device node like /dev/full, made in the test folder (root only), so that a regression
    can never replace the system's own."""
    node = tmp_path / "full"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 7))
    except (PermissionError, AttributeError, OSError) as exc:
        pytest.skip(f"cannot make a device node here: {exc}")
    return str(node)


def test_a_device_a_folder_and_a_read_only_file_are_refused_and_left_as_they_are(tmp_path):
    device = char_device(tmp_path)
    with pytest.raises(OutputError, match=r"full: cannot save: it is a character device, not a regular file"):
        write_atomically(device, "x")
    assert stat.S_ISCHR(os.stat(device).st_mode) and os.stat(device).st_rdev == os.makedev(1, 7)
    with pytest.raises(OutputError, match="cannot save: it is a folder"):
        write_atomically(tmp_path, "x")
    locked = tmp_path / "locked.yaml"
    locked.write_text("old")
    locked.chmod(0o444)  # root may write to it all the same: the save still refuses
    with pytest.raises(OutputError, match=r"locked\.yaml: cannot save: the file is read-only"):
        write_atomically(locked, "new")
    assert locked.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full", "locked.yaml"]


def test_a_link_to_a_device_is_refused_too(tmp_path):
    link = tmp_path / "diagram.md"
    link.symlink_to(char_device(tmp_path))
    with pytest.raises(OutputError, match="character device"):
        write_atomically(link, "x")
    assert link.is_symlink() and stat.S_ISCHR(link.stat().st_mode)


def test_a_save_that_fails_midway_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "p.yaml"
    path.write_text("old")
    real_fdopen = os.fdopen

    def full_disk(fd, *args, **kwargs):
        stream = real_fdopen(fd, *args, **kwargs)

        def write(_data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        stream.write = write
        return stream

    monkeypatch.setattr(atomic.os, "fdopen", full_disk)
    with pytest.raises(OutputError, match=r"p\.yaml: cannot save: No space left on device"):
        write_atomically(path, "new")
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["p.yaml"]


def test_temporaries_of_dead_savers_are_removed_and_those_of_live_ones_kept(tmp_path):
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    try:
        host = temporary_path(tmp_path / "x").name.split("saving-")[1].rsplit("-", 2)[0]
        (tmp_path / f".p.yaml.saving-{host}-{live.pid}-0123abcd.tmp").write_text("in progress")
        (tmp_path / f".p.yaml.saving-{host}-{dead.pid}-0123abcd.tmp").write_text("left by a kill")
        (tmp_path / f".run.avi.saving-{host}-{dead.pid}-89abcdef.avi").write_text("left by a kill")
        (tmp_path / f".out.mcap.saving-{host}-{dead.pid}-00000000.tmp").mkdir()  # a typed output's folder
        elsewhere = f".p.yaml.saving-other-machine-{dead.pid}-0123abcd.tmp"  # a pid that means nothing here
        (tmp_path / elsewhere).write_text("another machine's save in progress")
        (tmp_path / ".p.yaml.swp").write_text("an editor's: not ours")
        assert remove_stale_temporaries(tmp_path) == 3
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
            [f".p.yaml.saving-{host}-{live.pid}-0123abcd.tmp", elsewhere, ".p.yaml.swp"])
    finally:
        live.kill()
        live.wait()


def start_saving_forever(path, size: int) -> int:
    """A forked child that saves two versions of ``path`` in turn until it is killed; returns its pid once it
    has started (forked rather than started afresh, so that fifty of them take seconds)."""
    ready, told = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns
        try:
            os.close(ready)
            os.write(told, b"r")
            contents = (b"A" * size, b"B" * size)
            turn = 0
            while True:
                write_atomically(path, contents[turn % 2])
                turn += 1
        finally:
            os._exit(1)
    os.close(told)
    assert os.read(ready, 1) == b"r"
    os.close(ready)
    return pid


def test_fifty_kills_mid_save_never_damage_the_file_and_leave_no_temporary(tmp_path):
    """A child saves a 5 MB file over and over and is SIGKILLed at a random moment, 50 times: the file is always
    one whole version, and one more save removes whatever temporaries the killed children left."""
    size = 5_000_000
    path = tmp_path / "big.bin"
    write_atomically(path, b"A" * size)
    rng = random.Random(14)
    seen_leftovers = 0
    for _ in range(50):
        pid = start_saving_forever(path, size)
        time.sleep(rng.uniform(0.0, 0.06))
        os.kill(pid, signal.SIGKILL)
        assert os.waitpid(pid, 0)[1] == signal.SIGKILL
        data = path.read_bytes()
        assert len(data) == size and data in (b"A" * size, b"B" * size)
        leftovers = [p for p in tmp_path.iterdir() if p != path]
        assert len(leftovers) <= 2  # each child's first save removed those of the children before
        seen_leftovers += len(leftovers)
    assert seen_leftovers >= 10  # most kills landed in the middle of a save
    write_atomically(path, b"C")
    assert [p.name for p in tmp_path.iterdir()] == ["big.bin"] and path.read_bytes() == b"C"


# -- streamed lines: whole or not at all -----------------------------------------------------------------------
def failing_writes(monkeypatch, allowed: int, error: type[BaseException] | OSError) -> None:
    """``os.write`` in strictio.atomic takes ``allowed`` bytes in all, then writes part of a call and fails."""
    real_write = os.write
    budget = [allowed]

    def write(fd, data):
        if len(data) <= budget[0]:
            budget[0] -= len(data)
            return real_write(fd, data)
        if budget[0]:
            taken, budget[0] = real_write(fd, bytes(data[: budget[0]])), 0
            return taken  # a short write, as the kernel gives at the file size limit
        raise error

    monkeypatch.setattr(atomic.os, "write", write)


def test_a_full_disk_mid_line_is_an_output_error_naming_the_file(tmp_path, monkeypatch):
    path = tmp_path / "out" / "lines.jsonl"
    stream = LineOutput.create(path, make_folders=True)
    failing_writes(monkeypatch, 25, OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)))
    stream.write('{"a": 1}\n')
    stream.write('{"b": 2}\n')
    with pytest.raises(OutputError, match=r"lines\.jsonl: cannot be written: No space left on device; 2 whole "
                                          r"lines before it are kept"):
        stream.write('{"c": 3}\n')
    assert path.read_text() == '{"a": 1}\n{"b": 2}\n'  # the 7 bytes of the third line were taken back
    with pytest.raises(OutputError, match="No space left"):  # and it stays failed
        stream.write('{"d": 4}\n')
    stream.close()  # the failure was raised already: not a second time
    assert path.read_text() == '{"a": 1}\n{"b": 2}\n'


def test_an_interrupt_mid_line_takes_the_part_back_and_goes_on(tmp_path, monkeypatch):
    path = tmp_path / "lines.jsonl"
    with LineOutput.create(path) as stream:
        failing_writes(monkeypatch, 12, KeyboardInterrupt())
        stream.write("first line\n")
        with pytest.raises(KeyboardInterrupt):
            stream.write("second line\n")
        assert path.read_text() == "first line\n"
        monkeypatch.undo()
        stream.write("third line\n")
    assert path.read_text() == "first line\nthird line\n"


def test_a_line_to_a_full_device_is_an_output_error(tmp_path):
    device = char_device(tmp_path)
    stream = LineOutput.create(device)
    with pytest.raises(OutputError, match=r"full: cannot be written: No space left on device; 0 whole lines"):
        stream.write("one\n")
    stream.close()
    assert stat.S_ISCHR(os.stat(device).st_mode)


def test_a_line_output_cannot_be_a_folder(tmp_path):
    with pytest.raises(OutputError, match="cannot be written: it is a folder"):
        LineOutput.create(tmp_path)


# -- messages: one line whatever a file holds ------------------------------------------------------------------
@pytest.mark.parametrize("hostile", ["key\nobjrec-detect: 0 frames", "\x1b[2J\x1b[31mred", "a\rb", "\u202eevil",
                                     "tab\there", "nul\x00", "c1\x9bcsi", "line\u2028sep"])
def test_error_lines_show_control_characters_escaped(hostile):
    for error in (InputError("p.yaml", "unknown key", where=hostile), InputError(f"{hostile}.yaml", hostile),
                  OutputError(f"out/{hostile}.jsonl", f"cannot be written: {hostile}")):
        text = str(error)
        assert text.isprintable(), text
        assert escape_controls(hostile) in text
    assert escape_controls(escape_controls(hostile)) == escape_controls(hostile)


def test_escaping_shows_what_was_there():
    assert escape_controls("a\nb\x1b[31m\u202e\x7f") == "a\\nb\\x1b[31m\\u202e\\x7f"
    assert escape_controls("C:\\maps\\b5203.yaml, café ✓") == "C:\\maps\\b5203.yaml, café ✓"


def test_errors_cross_process_boundaries_whole():
    """A worker process's error reaches the parent as it was (pickled), whatever its class's signature."""
    from strictio.limits import IMAGE_PIXELS, LimitError

    for error in (InputError("a\nb.yaml", "bad", where="k"), OutputError("out.jsonl", "cannot be written: full"),
                  LimitError("big.png", IMAGE_PIXELS, 900_000_000, "image")):
        copy = pickle.loads(pickle.dumps(error))
        assert type(copy) is type(error) and str(copy) == str(error) and copy.path == error.path
