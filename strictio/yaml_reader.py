"""The one YAML dialect the project reads: YAML's safe subset without aliases, duplicate keys or deep nesting.

``yaml.safe_load`` already refuses tags that build Python objects; this reader also refuses aliases (an
alias bomb turns kilobytes into gigabytes), duplicate keys (the first would silently lose) and nesting past
a depth (Python would hit its recursion limit), and reads through :func:`open_input`.
"""

from __future__ import annotations

import os
import reprlib
from dataclasses import dataclass
from typing import Any

import yaml

from .errors import InputError
from .limits import YAML_NODES, LimitError
from .opener import read_text

_short = reprlib.Repr()
_short.maxstring = 60
_short.maxother = 60


@dataclass(frozen=True)
class YAMLLimits:
    """How large a YAML document may be: bytes on disk and nesting depth."""

    max_bytes: int = 64 * 1024 * 1024
    max_depth: int = 50


class _TooManyNodes(Exception):
    """Raised inside the loader; reported as a LimitError naming the file."""


class _StrictLoader(yaml.SafeLoader):
    max_depth = YAMLLimits.max_depth

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0
        self._nodes = 0
        self._max_nodes = YAML_NODES.value()

    def compose_node(self, parent: Any, index: Any) -> Any:
        self._nodes += 1
        if self._nodes > self._max_nodes:
            raise _TooManyNodes(self._nodes)
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.composer.ComposerError(None, None, "aliases (*name) are not allowed", event.start_mark)
        if self.check_event(yaml.MappingStartEvent, yaml.SequenceStartEvent):
            self._depth += 1
            if self._depth > self.max_depth:
                event = self.peek_event()
                raise yaml.composer.ComposerError(
                    None, None, f"nested deeper than {self.max_depth} levels", event.start_mark
                )
            try:
                return super().compose_node(parent, index)
            finally:
                self._depth -= 1
        return super().compose_node(parent, index)

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if isinstance(key, list | dict):
                continue  # unhashable: the base class reports it
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {_short.repr(key)} appears twice", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep)


def yaml_text(text: str, path: str | os.PathLike[str] = "<text>", limits: YAMLLimits | None = None) -> Any:
    """Parse YAML text with the strict dialect; errors are InputError naming ``path``, line and column."""
    limits = limits or YAMLLimits()
    loader_class = type("_Loader", (_StrictLoader,), {"max_depth": limits.max_depth})
    loader = None
    try:
        loader = loader_class(text)  # refuses control characters at once
        return loader.get_single_data()
    except RecursionError:
        raise InputError(path, "not valid YAML: nested too deeply") from None
    except _TooManyNodes as exc:
        raise LimitError(path, YAML_NODES, int(str(exc)), "YAML values and collections, at least") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = exc.problem or str(exc)
        if "could not determine a constructor" in str(exc):
            problem = f"{problem} (tags that build Python objects are not allowed)"
        raise InputError(path, f"not valid YAML: {problem}", where) from None
    except yaml.reader.ReaderError as exc:
        raise InputError(path, f"not valid YAML: character #x{exc.character:04x} at position {exc.position} is "
                               "not allowed (control characters)") from None
    except yaml.YAMLError as exc:
        raise InputError(path, f"not valid YAML: {exc}") from None
    except (IndexError, KeyError, TypeError, AttributeError):  # PyYAML's own constructors on odd tagged values
        raise InputError(path, "not valid YAML: a tagged value (!!float, !!int, ...) cannot be read as its "
                               "tag says") from None
    except ValueError as exc:  # e.g. an integer with more digits than Python converts
        raise InputError(path, f"not valid YAML: {exc}") from None
    finally:
        if loader is not None:
            loader.dispose()


def read_yaml(path: str | os.PathLike[str], limits: YAMLLimits | None = None) -> Any:
    """Read one YAML document from a regular file of bounded size, with the strict dialect."""
    limits = limits or YAMLLimits()
    return yaml_text(read_text(path, limits.max_bytes), path, limits)
