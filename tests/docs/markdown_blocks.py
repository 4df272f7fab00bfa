"""The code blocks of the project's Markdown pages, and the output a page shows for a Python block's lines.

The conventions (docs/CONTRIBUTING.md, "Code blocks in the docs"), checked by tests/docs/test_doc_snippets.py:

- every ```python block runs, in a fresh child process, in a working folder of its page where ``params/`` and
  ``examples/`` of the repository are reachable;
- a block that cannot run (a GUI, robot hardware, a file the reader brings, a fragment) says why in an HTML
  comment on the line before it: ``<!-- no-run: why -->``;
- a block whose first line is ``# NAME.py`` (or ``# NAME.yaml``, ``# NAME.json``, ``# NAME.txt``) is also saved
  as NAME in that folder before any block of the page runs, so later blocks import or read it; a Python file
  block that defines ``test_*`` functions has them called;
- a ``print(...)`` line's trailing comment is the text it prints (``print(p.h_min)  # 100``), optionally followed
  by ``, `` and a remark (``# 2d, without building anything``); any other statement's trailing comment that
  starts with ``prints`` is what the statement prints (``# prints [('h_min', 0, 100)]``, ``# prints nothing``).
  Other comments are only comments.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from dataclasses import dataclass
from pathlib import Path

_FENCE = re.compile(r"^(`{3,})\s*([\w+-]*)\s*$")
_NO_RUN = re.compile(r"^<!--\s*no-run:\s*(.+?)\s*-->$")
_FILE_NAME = re.compile(r"^#\s*([\w.-]+\.(?:py|yaml|yml|json|txt))\s*$")


@dataclass(frozen=True)
class Block:
    """One fenced code block of a page."""

    page: str  # relative to the repository, e.g. docs/architecture.md
    line: int  # 1-based line of the opening fence
    lang: str
    text: str
    no_run: str | None  # why it does not run, from its <!-- no-run: why --> marker

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}"

    @property
    def file_name(self) -> str | None:
        """NAME when the block's first line is ``# NAME.ext``: the block is also that file of the page."""
        first = self.text.splitlines()[0] if self.text else ""
        match = _FILE_NAME.match(first.strip())
        return match.group(1) if match else None


def blocks(path: Path, root: Path) -> list[Block]:
    """Every fenced block of the Markdown file ``path``, in order."""
    lines = path.read_text(encoding="utf-8").splitlines()
    found: list[Block] = []
    index = 0
    while index < len(lines):
        opening = _FENCE.match(lines[index])
        if not opening:
            index += 1
            continue
        fence, lang = opening.groups()
        start = index
        index += 1
        body: list[str] = []
        while index < len(lines) and not lines[index].startswith(fence):
            body.append(lines[index])
            index += 1
        previous = next((lines[i].strip() for i in range(start - 1, -1, -1) if lines[i].strip()), "")
        marker = _NO_RUN.match(previous)
        found.append(Block(str(path.relative_to(root)), start + 1, lang.lower(), "\n".join(body) + "\n",
                           marker.group(1) if marker else None))
        index += 1
    return found


@dataclass(frozen=True)
class Expected:
    """What the page shows a statement of a block prints."""

    first: int  # the statement's lines in the block, 1-based
    last: int
    text: str  # "" for "prints nothing"
    remark_allowed: bool  # a print line's comment may add ", remark" after the output

    def matches(self, printed: str) -> bool:
        printed = printed.rstrip("\n")
        if printed == self.text:
            return True
        return self.remark_allowed and bool(printed) and "\n" not in printed and self.text.startswith(printed + ", ")


def expected_output(code: str) -> list[Expected]:
    """The outputs a block's trailing comments show (the conventions above), by statement."""
    tree = ast.parse(code)
    simple = [node for node in ast.walk(tree) if isinstance(node, ast.stmt)
              and not isinstance(node, (ast.For, ast.While, ast.If, ast.With, ast.Try, ast.FunctionDef,
                                        ast.ClassDef, ast.AsyncFunctionDef, ast.AsyncFor, ast.AsyncWith))]
    found = []
    for token in tokenize.generate_tokens(io.StringIO(code).readline):
        if token.type != tokenize.COMMENT or not token.line[: token.start[1]].strip():
            continue  # a comment on a line of its own
        row = token.start[0]
        comment = token.string[1:].strip()
        owners = [n for n in simple if n.lineno <= row <= (n.end_lineno or n.lineno)]
        if not owners:
            continue
        node = min(owners, key=lambda n: (n.end_lineno or n.lineno) - n.lineno)
        is_print = (isinstance(node, ast.Expr) and isinstance(node.value, ast.Call)
                    and isinstance(node.value.func, ast.Name) and node.value.func.id == "print")
        last = node.end_lineno or node.lineno
        if is_print:
            found.append(Expected(node.lineno, last, comment, remark_allowed=True))
        elif comment == "prints nothing":
            found.append(Expected(node.lineno, last, "", remark_allowed=False))
        elif comment.startswith("prints "):
            found.append(Expected(node.lineno, last, comment.removeprefix("prints "), remark_allowed=False))
    return found
