"""Run one documentation snippet and record what each of its top-level lines printed:
``python snippet_runner.py SNIPPET.py REPORT.json [--call-tests]``.

Run as a child of tests/docs/test_doc_snippets.py, so that a snippet's imports, registrations and global state
cannot leak into the test session or into the next snippet. Standard output is attributed to the line of the
snippet's own module-level code that was running when it was written (a ``print`` inside a loop, a callback or
a function called from line N counts for line N), so the test can compare it with the output the page shows
beside that line. ``--call-tests`` then calls every ``test_*`` function the snippet defined (a page's example
test file), each with no arguments. REPORT gets ``{"lines": {"N": "text printed", ...}}``.
"""

from __future__ import annotations

import io
import json
import runpy
import sys
from collections import defaultdict
from pathlib import Path


class _LineStdout(io.TextIOBase):
    """Standard output that keeps, beside passing it on, what each line of the snippet's module code printed."""

    def __init__(self, snippet: str, real: io.TextIOBase) -> None:
        self.snippet = snippet
        self.real = real
        self.by_line: defaultdict[int, list[str]] = defaultdict(list)

    def _module_line(self) -> int:
        frame = sys._getframe(2)
        line = 0
        while frame is not None:
            if frame.f_code.co_filename == self.snippet and frame.f_code.co_name == "<module>":
                line = frame.f_lineno
            frame = frame.f_back
        return line

    def writable(self) -> bool:
        return True

    def write(self, text: str) -> int:
        self.by_line[self._module_line()].append(text)
        return self.real.write(text)

    def flush(self) -> None:
        self.real.flush()


def main() -> int:
    snippet, report = str(Path(sys.argv[1]).resolve()), Path(sys.argv[2])
    stdout = _LineStdout(snippet, sys.stdout)
    sys.stdout = stdout
    sys.path.insert(0, str(Path(snippet).parent))
    try:
        namespace = runpy.run_path(snippet, run_name="__main__")
        if "--call-tests" in sys.argv[3:]:
            for name, function in namespace.items():
                if name.startswith("test_") and callable(function):
                    function()
    finally:
        sys.stdout = stdout.real
        lines = {str(line): "".join(parts) for line, parts in stdout.by_line.items()}
        report.write_text(json.dumps({"lines": lines}), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
