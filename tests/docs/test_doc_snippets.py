"""The code of README.md and docs/*.md runs, and prints what the pages show: a default or an output
that a page states cannot drift from the code unnoticed.

Each ```python block is its own test case, ``docs/page.md:LINE``, run in a child process (tests/docs/
snippet_runner.py) in a working folder of its page; the conventions a page follows are in
tests/docs/markdown_blocks.py and docs/CONTRIBUTING.md. Blocks marked ``<!-- no-run: why -->`` are counted and
reported, not run. Every ``objrec-*`` command line of a page, in a shell block or a code span, is parsed with that
command's own argument parser: an option that does not exist, or a value it refuses, fails here.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import importlib
import io
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from objrec_apps import launch
from tests.docs.markdown_blocks import Block, blocks, expected_output

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
ALL_BLOCKS = [block for page in PAGES for block in blocks(page, ROOT)]
PYTHON = [block for block in ALL_BLOCKS if block.lang == "python"]
RUNNER = Path(__file__).with_name("snippet_runner.py")
#: Wall-clock seconds after which a snippet is taken as hung: a guard, never a speed bound.
HANG_GUARD_SECONDS = 600
#: What a page's working folder links to, so that the pages' relative paths resolve as in the repository.
LINKED = ("params", "examples")


@pytest.fixture(scope="module")
def page_folders(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A working folder per page: the repository's params/ and examples/ linked in, and the page's file blocks
    (``# NAME.py`` first lines) saved there before any of its blocks runs."""
    folders: dict[str, Path] = {}
    for block in ALL_BLOCKS:
        if block.page not in folders:
            folder = tmp_path_factory.mktemp(re.sub(r"\W", "_", block.page))
            for name in LINKED:
                (folder / name).symlink_to(ROOT / name, target_is_directory=True)
            folders[block.page] = folder
        if block.file_name and block.no_run is None:
            (folders[block.page] / block.file_name).write_text(block.text, encoding="utf-8")
    return folders


def _child_env(folder: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OBJREC_MAX_", "PYTEST_"))}
    env.update(QT_QPA_PLATFORM="offscreen", PYTHONDONTWRITEBYTECODE="1", PYTHONPATH=str(folder))
    return env


def _run_block(block: Block, folder: Path) -> list[str]:
    """Run ``block`` in ``folder``; what differs from the output the page shows (fails the test if it fails)."""
    snippet = folder / (block.file_name or f"snippet_{block.line}.py")
    if not block.file_name:
        snippet.write_text(block.text, encoding="utf-8")
    report = folder / f"snippet_{block.line}.json"
    argv = [sys.executable, str(RUNNER), str(snippet), str(report)]
    if block.file_name and block.file_name.startswith("test_"):
        argv.append("--call-tests")
    done = subprocess.run(argv, cwd=folder, env=_child_env(folder), capture_output=True, text=True,
                          timeout=HANG_GUARD_SECONDS, check=False)
    if done.returncode != 0:
        tail = "\n".join(done.stderr.splitlines()[-12:])
        pytest.fail(f"{block.id} failed (exit {done.returncode}):\n{tail}", pytrace=False)
    printed = json.loads(report.read_text(encoding="utf-8"))["lines"]
    problems = []
    for expected in expected_output(block.text):
        text = "".join(printed.get(str(line), "") for line in range(expected.first, expected.last + 1))
        if not expected.matches(text):
            problems.append(f"{block.page}:{block.line + expected.first}: the page shows {expected.text!r}, "
                            f"the code printed {text.rstrip(chr(10))!r}")
    return problems


@pytest.mark.parametrize("block", PYTHON, ids=[block.id for block in PYTHON])
def test_python_block_runs_and_prints_what_the_page_shows(block: Block, page_folders: dict[str, Path]) -> None:
    if block.no_run is not None:
        pytest.skip(f"no-run: {block.no_run}")
    problems = _run_block(block, page_folders[block.page])
    assert not problems, "\n".join(problems)


def test_a_page_showing_other_output_than_the_code_prints_is_caught(tmp_path: Path) -> None:
    code = ("values = [3, 4]\n"
            "print(sum(values))  # 7, the sum\n"
            "for v in values:\n"
            "    print(v * 2)  # 6\n"
            "values.append(print('side'))  # prints nothing\n")
    problems = _run_block(Block("docs/x.md", 10, "python", code, None), tmp_path)
    assert problems == ["docs/x.md:14: the page shows '6', the code printed '6\\n8'",
                        "docs/x.md:15: the page shows '', the code printed 'side'"]


def test_the_pages_show_output_to_compare() -> None:
    """The README's and the guides' printed lines are found (a broken convention would compare nothing)."""
    shown = {block.id: len(expected_output(block.text)) for block in PYTHON if block.no_run is None}
    assert shown["README.md:104"] == 2 and sum(shown.values()) >= 8, shown


def test_every_block_that_does_not_run_says_why() -> None:
    """The skipped blocks are few and each gives a reason: a count that only grows on purpose."""
    skipped = [block for block in PYTHON if block.no_run is not None]
    assert all(block.no_run.strip() for block in skipped)
    ran = len(PYTHON) - len(skipped)
    assert ran >= 12, f"only {ran} of {len(PYTHON)} Python blocks run"
    assert len(skipped) <= 15, [f"{block.id}: {block.no_run}" for block in skipped]


# -- command lines ----------------------------------------------------------------------------------------------
COMMANDS = dict(launch.COMMANDS)  # every console script and the module whose build_parser checks its lines
_SHELL_LANGS = {"bash", "sh", "shell", "console", ""}
_CODE_SPAN = re.compile(r"`([^`\n]+)`")
#: A command line: the command first (after a prompt, VAR=value settings, xvfb-run or a folder such as .venv/bin/).
_COMMAND = re.compile(r"^\s*(?:\$\s+)?(?:\w+=\S*\s+)*(?:xvfb-run\s+(?:-a\s+)?)?(?:\S*/)?"
                      r"(" + "|".join(sorted(map(re.escape, COMMANDS), key=len, reverse=True)) + r")(?=\s|$)")
_OPERATORS = {"|", "||", "&&", ";", ">", ">>", "2>", "2>&1", "&", "<"}
_PLACEHOLDER = re.compile(r"^(\.\.\.|\[.*|.*\]|.*\.\.\..*)$")


def _command_lines() -> list[tuple[str, str, list[str], bool]]:
    """(where, command, arguments, whole) of every objrec-* command line on the pages: ``whole`` for a line of a
    shell block, which must parse; a code span in the prose is often part of a command (``objrec-inspect
    --diagram FILE``), so only its options must exist."""
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        lines = text.splitlines()
        shell_lines: set[int] = set()
        for block in blocks(page, ROOT):
            if block.lang in _SHELL_LANGS:
                joined, first = "", 0
                for offset, line in enumerate(block.text.splitlines(), start=block.line + 1):
                    shell_lines.add(offset)
                    joined, first = (joined + " " + line.rstrip("\\"), first or offset)
                    if line.endswith("\\"):
                        continue
                    found += _commands_in(f"{page.relative_to(ROOT)}:{first}", joined.strip(), whole=True)
                    joined, first = "", 0
        for number, line in enumerate(lines, 1):
            if number in shell_lines:
                continue
            for span in _CODE_SPAN.findall(line):
                found += _commands_in(f"{page.relative_to(ROOT)}:{number}", span, whole=False)
    return found


def _commands_in(where: str, line: str, whole: bool) -> list[tuple[str, str, list[str], bool]]:
    match = _COMMAND.search(line)
    if not match:
        return []
    try:
        words = shlex.split(line[match.end(1):], comments=True)
    except ValueError:
        return []
    arguments = []
    for word in words:
        if word in _OPERATORS or word.startswith((">", "2>")):
            break
        arguments.append(word)
    return [(where, match.group(1), arguments, whole)]


COMMAND_LINES = _command_lines()


def _parse(command: str, arguments: list[str], whole: bool) -> str:
    """What the command's own parser says of ``arguments``: "" when it takes them (``whole=False``: when the
    options exist)."""
    parser: argparse.ArgumentParser = importlib.import_module(COMMANDS[command]).build_parser()
    known = set(parser._option_string_actions)
    unknown = [w.split("=", 1)[0] for w in arguments if w.startswith("-") and w != "-"
               and not re.fullmatch(r"-\d.*", w) and w.split("=", 1)[0] not in known]
    if unknown:
        return f"no option {', '.join(unknown)}"
    if not whole or any(_PLACEHOLDER.match(w) for w in arguments):
        return ""  # a pattern such as "objrec-inspect ... --remove X": the options exist, the rest is prose
    errors = io.StringIO()
    try:
        with contextlib.redirect_stderr(errors), contextlib.redirect_stdout(io.StringIO()):
            parser.parse_args(arguments)
    except SystemExit as ended:
        if ended.code not in (0, None):
            return errors.getvalue().strip().splitlines()[-1] if errors.getvalue().strip() else "refused"
    return ""


@pytest.mark.parametrize(("where", "command", "arguments", "whole"), COMMAND_LINES,
                         ids=[f"{where}:{command}" for where, command, _, _ in COMMAND_LINES])
def test_command_line_on_a_page_is_one_the_command_takes(where: str, command: str, arguments: list[str],
                                                         whole: bool) -> None:
    said = _parse(command, arguments, whole)
    assert not said, f"{where}: {command} {shlex.join(arguments)}: {said}"


def test_the_pages_show_command_lines() -> None:
    """The collection above found the README's and the guides' commands (a broken pattern would find none)."""
    shell = [command for _, command, _, whole in COMMAND_LINES if whole]
    assert len(shell) >= 25 and set(shell) == set(COMMANDS)


# -- signatures ---------------------------------------------------------------------------------------------------
#: Where a function a page writes out as ``name(arg=default, ...)`` is looked up.
SIGNATURE_HOMES = ("objrec_core", "objrec_core.testing", "objrec_core.conformance", "objrec_core.registry",
                   "objrec_core.directors")
_SIGNATURE = re.compile(r"`([a-z_][a-z_0-9]*)\(([^`()]*=[^`()]*)\)`")


def _signatures() -> list[tuple[str, str, str]]:
    """(where, function, arguments) of every ``function(arg=literal, ...)`` code span on the pages."""
    found = []
    for page in PAGES:
        for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
            for name, arguments in _SIGNATURE.findall(line):
                found.append((f"{page.relative_to(ROOT)}:{number}", name, arguments))
    return found


def _function(name: str) -> object | None:
    for home in SIGNATURE_HOMES:
        try:
            module = importlib.import_module(home)
        except ImportError:
            continue
        if callable(getattr(module, name, None)):
            return getattr(module, name)
    return None


SIGNATURES = [s for s in _signatures() if _function(s[1]) is not None]


@pytest.mark.parametrize(("where", "name", "arguments"), SIGNATURES, ids=[f"{w}:{n}" for w, n, _ in SIGNATURES])
def test_a_signature_on_a_page_states_the_code_s_defaults(where: str, name: str, arguments: str) -> None:
    """``check_module(ModuleClass, frames=None, seconds=10.0, ...)``: each keyword the page gives a literal
    default exists, with that default (the page said 5 while the code said 10)."""
    import inspect

    parameters = inspect.signature(_function(name)).parameters  # type: ignore[arg-type]
    problems = []
    for part in arguments.split(","):
        key, _, literal = part.strip().partition("=")
        if not literal:
            continue
        if key not in parameters:
            problems.append(f"no parameter {key!r}")
            continue
        try:
            stated = ast.literal_eval(literal)
        except (ValueError, SyntaxError):
            continue  # "spec=...": a placeholder
        if parameters[key].default != stated:
            problems.append(f"{key}: the page says {stated!r}, the code {parameters[key].default!r}")
    assert not problems, f"{where}: {name}(...): " + "; ".join(problems)


def test_the_pages_state_signatures() -> None:
    assert {name for _, name, _ in SIGNATURES} >= {"check_module", "check_source", "check_kind"}
