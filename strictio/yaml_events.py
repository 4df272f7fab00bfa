"""The strict YAML dialect built straight from libyaml's events: the fast path of :mod:`strictio.yaml_reader`.

PyYAML's pure-Python scanner and parser take 13-47 s and up to 740 MB for a 1-2 MB file near the node limit;
composing through the C loader (``yaml.CSafeLoader``) still keeps a node object with two marks per
value (300 MB for a million). This builder reads the C parser's events one at a time and builds the data as
they come, with the same checks as the pure-Python loader (no aliases, no duplicate keys, nesting and node
limits, the line of every key and list item) and the same scalar values (SafeConstructor's own constructors
and resolver): a million values cost about a second and the data itself. libyaml refuses nesting deeper than
1000 levels on its own, so its recursion cannot exhaust the stack.

What it does not handle (a merge key ``<<``, a collection with a tag of its own such as ``!!set`` or
``!!omap``) raises :class:`Unusual`, and the caller reads the document with the pure-Python loader instead.
"""

from __future__ import annotations

import reprlib
from collections.abc import Hashable
from typing import Any

import yaml
from yaml.constructor import ConstructorError
from yaml.nodes import ScalarNode

#: libyaml is present (PyYAML built with it); without it the pure-Python loader is the only one.
AVAILABLE = bool(getattr(yaml, "__with_libyaml__", False)) and hasattr(yaml, "CSafeLoader")

_short = reprlib.Repr()
_short.maxstring = 60
_short.maxother = 60
_SEQ = "tag:yaml.org,2002:seq"
_MAP = "tag:yaml.org,2002:map"
_MERGE = "tag:yaml.org,2002:merge"
#: Plain scalars' resolved tags, remembered for the most common texts (keys, small numbers, true/false).
_CACHE_SIZE = 4096


class Unusual(Exception):
    """A construct the event builder leaves to the pure-Python loader (merge keys, tagged collections)."""


class TooManyNodes(Exception):
    """More values and collections than the node limit; the count so far is the argument."""


class LongInteger(Exception):
    """An integer scalar with more digits than Python converts, and where it stands."""

    def __init__(self, digits: int, line: int, key_path: tuple[Any, ...] | None) -> None:
        super().__init__(digits)
        self.digits, self.line, self.key_path = digits, line, key_path


class _Collection:
    """One open list or mapping: its data, its key path, and (for a mapping) the key waiting for its value."""

    __slots__ = ("data", "has_key", "key", "mark", "path")

    def __init__(self, data: Any, path: tuple[Any, ...], mark: Any) -> None:
        self.data, self.path, self.mark = data, path, mark
        self.key: Any = None
        self.has_key = False


if AVAILABLE:
    _Base: type = yaml.CSafeLoader
else:  # pragma: no cover - PyYAML without libyaml
    _Base = object


class EventBuilder(_Base):  # type: ignore[misc, valid-type]
    """Builds one document from the C parser's events; :meth:`build` returns ``(data, key_lines)``."""

    def __init__(self, text: str, max_depth: int, max_nodes: int) -> None:
        super().__init__(text)  # UnicodeEncodeError for text libyaml cannot take (lone surrogates)
        self._max_depth = max_depth
        self._max_nodes = max_nodes
        self._resolved: dict[tuple[str, bool], str] = {}

    def build(self) -> tuple[Any, dict[tuple[Any, ...], int]]:
        key_lines: dict[tuple[Any, ...], int] = {}
        self.get_event()  # stream start
        if self.check_event(yaml.StreamEndEvent):
            self.get_event()
            return None, key_lines
        self.get_event()  # document start
        key_lines[()] = self.peek_event().start_mark.line + 1
        data = self._document(key_lines)
        self.get_event()  # document end
        if not self.check_event(yaml.StreamEndEvent):
            event = self.get_event()
            raise yaml.composer.ComposerError("expected a single document in the stream", None,
                                              "but found another document", event.start_mark)
        self.get_event()
        return data, key_lines

    def _document(self, key_lines: dict[tuple[Any, ...], int]) -> Any:
        stack: list[_Collection] = []
        nodes = 0
        while True:
            event = self.get_event()
            kind = type(event)
            if kind is yaml.MappingEndEvent or kind is yaml.SequenceEndEvent:
                finished = stack.pop()
                value, mark, scalar = finished.data, finished.mark, False
            else:
                nodes += 1
                if nodes > self._max_nodes:
                    raise TooManyNodes(nodes)
                if kind is yaml.ScalarEvent:
                    value, mark, scalar = self._scalar(event, stack), event.start_mark, True
                elif kind is yaml.SequenceStartEvent or kind is yaml.MappingStartEvent:
                    if len(stack) >= self._max_depth:
                        raise yaml.composer.ComposerError(None, None, f"nested deeper than {self._max_depth} levels",
                                                          event.start_mark)
                    default = _SEQ if kind is yaml.SequenceStartEvent else _MAP
                    if event.tag not in (None, "!", default):
                        raise Unusual(event.tag)
                    path = _child_path(stack[-1]) if stack else ()
                    stack.append(_Collection([] if default == _SEQ else {}, path, event.start_mark))
                    continue
                elif kind is yaml.AliasEvent:
                    raise yaml.composer.ComposerError(None, None, "aliases (*name) are not allowed", event.start_mark)
                else:  # pragma: no cover - libyaml gives no other event inside a document
                    raise yaml.composer.ComposerError(None, None, f"unexpected {kind.__name__}", event.start_mark)
            if not stack:
                return value
            _add(stack[-1], value, mark, scalar, key_lines)

    def _scalar(self, event: Any, stack: list[_Collection]) -> Any:
        tag = event.tag
        if tag is None or tag == "!":
            implicit = event.implicit[0]
            cached = self._resolved.get((event.value, implicit))
            if cached is None:
                cached = self.resolve(ScalarNode, event.value, event.implicit)
                if len(self._resolved) < _CACHE_SIZE:
                    self._resolved[(event.value, implicit)] = cached
            tag = cached
        if tag == _MERGE and stack and isinstance(stack[-1].data, dict) and not stack[-1].has_key:
            raise Unusual(tag)
        constructor = self.yaml_constructors.get(tag) or self.yaml_constructors[None]
        node = ScalarNode(tag, event.value, event.start_mark, event.end_mark, event.style)
        try:
            return constructor(self, node)
        except ValueError:  # an integer of more digits than Python converts (sys.get_int_max_str_digits)
            if tag != "tag:yaml.org,2002:int":
                raise
            digits = sum(c.isdigit() for c in str(event.value))
            path = _child_path(stack[-1]) if stack else ()
            raise LongInteger(digits, event.start_mark.line + 1, path) from None


def _child_path(parent: _Collection) -> tuple[Any, ...]:
    """The key path of the value about to be added to ``parent`` (a key itself gets its mapping's path)."""
    if isinstance(parent.data, list):
        return (*parent.path, len(parent.data))
    return (*parent.path, parent.key) if parent.has_key else parent.path


def _add(parent: _Collection, value: Any, mark: Any, scalar: bool, key_lines: dict[tuple[Any, ...], int]) -> None:
    """Put a finished value (starting at ``mark``) into its list or mapping: as an item, a key (checked) or a
    key's value."""
    data = parent.data
    if isinstance(data, list):
        key_lines.setdefault((*parent.path, len(data)), mark.line + 1)
        data.append(value)
        return
    if parent.has_key:
        data[parent.key] = value
        parent.has_key = False
        return
    if not isinstance(value, Hashable) or isinstance(value, list | dict):
        raise ConstructorError("while constructing a mapping", parent.mark, "found unhashable key", mark)
    if value in data:
        raise ConstructorError(None, None, f"key {_short.repr(value)} appears twice", mark)
    if scalar:  # a collection as a key has no key path (as the pure-Python loader)
        key_lines.setdefault((*parent.path, value), mark.line + 1)
    data[value] = None  # keeps the order and catches a duplicate before the value is built
    parent.key, parent.has_key = value, True
