"""The one YAML dialect the project reads: YAML's safe subset without aliases, duplicate keys or deep nesting.

``yaml.safe_load`` already refuses tags that build Python objects; this reader also refuses aliases (an
alias bomb turns kilobytes into gigabytes), duplicate keys (the first would silently lose) and nesting past
a depth (Python would hit its recursion limit), and reads through :func:`open_input`. Documents are read
from libyaml's events where PyYAML has it (:mod:`strictio.yaml_events`: a 2 MB file near the node limit in about
a second instead of 10-40), with the pure-Python loader below as the fallback that gives the same data and errors.

It also records where each key and list item stands (:func:`yaml_text_with_lines`), so a reader that finds
a wrong value deep in a document can name its line; an integer too long to convert is refused naming its
line and key path the same way.
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
from .yaml_events import AVAILABLE as _LIBYAML
from .yaml_events import EventBuilder, LongInteger, TooManyNodes, Unusual

_short = reprlib.Repr()
_short.maxstring = 60
_short.maxother = 60


@dataclass(frozen=True)
class YAMLLimits:
    """How large a YAML document may be: bytes on disk and nesting depth."""

    max_bytes: int = 64 * 1024 * 1024
    max_depth: int = 50


#: The 1-based line of every key and list item of a document, by key path (``("objects", 2, "radius")``);
#: the empty path is the document itself.
KeyLines = dict[tuple[Any, ...], int]


class YAMLInputError(InputError):
    """A YAML document refused at a known place: ``line`` (1-based) and, where known, the ``key_path``."""

    def __init__(self, path: str | os.PathLike[str], message: str, where: str, line: int,
                 key_path: tuple[Any, ...] | None = None) -> None:
        super().__init__(path, message, where)
        self.line = line
        self.key_path = key_path


#: Raised inside either loader; reported as a LimitError naming the file, or an error naming the line.
_TooManyNodes = TooManyNodes
_LongInteger = LongInteger


class _StrictLoader(yaml.SafeLoader):
    max_depth = YAMLLimits.max_depth

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0
        self._nodes = 0
        self._max_nodes = YAML_NODES.value()
        self.key_lines: KeyLines = {}
        self._scalar_paths: dict[int, tuple[Any, ...]] = {}

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

    def construct_document(self, node: Any) -> Any:
        """Record the line of every key and list item (walking without recursion), then build the data."""
        stack: list[tuple[Any, tuple[Any, ...]]] = [(node, ())]
        self.key_lines[()] = node.start_mark.line + 1
        while stack:
            current, path = stack.pop()
            if isinstance(current, yaml.MappingNode):
                for key_node, value_node in current.value:
                    if not isinstance(key_node, yaml.ScalarNode):
                        continue  # a collection as a key: the base class refuses it
                    key = self.construct_object(key_node, deep=True)  # 0: is the int 0, as the data has it
                    child = (*path, key)
                    self.key_lines.setdefault(child, key_node.start_mark.line + 1)
                    stack.append((value_node, child))
            elif isinstance(current, yaml.SequenceNode):
                for index, item in enumerate(current.value):
                    self.key_lines.setdefault((*path, index), item.start_mark.line + 1)
                    stack.append((item, (*path, index)))
            else:
                self._scalar_paths[id(current)] = path
        return super().construct_document(node)

    def construct_yaml_int(self, node: Any) -> Any:
        try:
            return super().construct_yaml_int(node)
        except ValueError:  # more digits than Python converts (sys.get_int_max_str_digits)
            digits = sum(c.isdigit() for c in str(node.value))
            raise _LongInteger(digits, node.start_mark.line + 1, self._scalar_paths.get(id(node))) from None


_StrictLoader.add_constructor("tag:yaml.org,2002:int", _StrictLoader.construct_yaml_int)


def yaml_text(text: str, path: str | os.PathLike[str] = "<text>", limits: YAMLLimits | None = None) -> Any:
    """Parse YAML text with the strict dialect; errors are InputError naming ``path``, line and column."""
    return yaml_text_with_lines(text, path, limits)[0]


def yaml_text_with_lines(text: str, path: str | os.PathLike[str] = "<text>",
                         limits: YAMLLimits | None = None) -> tuple[Any, KeyLines]:
    """Like :func:`yaml_text`, with the line of every key and list item; errors at a known place are
    :class:`YAMLInputError` carrying the line."""
    limits = limits or YAMLLimits()
    loader: Any = None
    try:
        fast = _built_from_events(text, limits)
        if fast is not None:
            return fast
        loader = type("_Loader", (_StrictLoader,), {"max_depth": limits.max_depth})(text)  # control characters
        return loader.get_single_data(), loader.key_lines
    except _LongInteger as exc:
        raise YAMLInputError(path, f"not valid YAML: an integer of {exc.digits:,} digits is not a usable number",
                             f"line {exc.line}", exc.line, exc.key_path) from None
    except RecursionError:
        raise InputError(path, "not valid YAML: nested too deeply") from None
    except _TooManyNodes as exc:
        raise LimitError(path, YAML_NODES, int(str(exc)), "YAML values and collections, at least") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = exc.problem or str(exc)
        if "could not determine a constructor" in str(exc):
            problem = f"{problem} (tags that build Python objects are not allowed)"
        if mark is None:
            raise InputError(path, f"not valid YAML: {problem}") from None
        where = f"line {mark.line + 1}, column {mark.column + 1}"
        raise YAMLInputError(path, f"not valid YAML: {problem}", where, mark.line + 1) from None
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


def _built_from_events(text: str, limits: YAMLLimits) -> tuple[Any, KeyLines] | None:
    """The document through libyaml (:mod:`strictio.yaml_events`), or None where only the pure-Python loader
    reads it: no libyaml, text libyaml cannot encode (a lone surrogate), a merge key or a tagged collection,
    nesting past libyaml's own depth limit (refused there, at the place the dialect's limit is passed), a
    surrogate escape ("\udcff")."""
    if not _LIBYAML:
        return None
    try:
        builder = EventBuilder(text, limits.max_depth, YAML_NODES.value())
    except UnicodeEncodeError:
        return None
    try:
        return builder.build()
    except Unusual:
        return None
    except yaml.MarkedYAMLError as exc:
        # libyaml's own depth limit, met ahead of the parser's events: the pure-Python loader names where the
        # dialect's limit is passed. A "\udcff" escape libyaml refuses and PyYAML reads (as a lone surrogate,
        # which every reader of names then shows escaped): the same document reads the same either way.
        if any(text in str(exc.problem) for text in ("maximum nesting depth", "invalid Unicode character escape")):
            return None
        raise
    finally:
        builder.dispose()


def read_yaml(path: str | os.PathLike[str], limits: YAMLLimits | None = None) -> Any:
    """Read one YAML document from a regular file of bounded size, with the strict dialect."""
    limits = limits or YAMLLimits()
    return yaml_text(read_text(path, limits.max_bytes), path, limits)


def read_yaml_with_lines(path: str | os.PathLike[str], limits: YAMLLimits | None = None) -> tuple[Any, KeyLines]:
    """Like :func:`read_yaml`, with the line of every key and list item (:func:`yaml_text_with_lines`)."""
    limits = limits or YAMLLimits()
    return yaml_text_with_lines(read_text(path, limits.max_bytes), path, limits)
