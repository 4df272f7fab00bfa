"""Typed document fields: every file objrec reads is a table of them, so every error reads the same way.

A reader declares what its YAML document holds as a table: a :class:`Record` of named fields (required or
optional with a default), nested records, :class:`ListOf` records, fixed-length :class:`Vector` values,
:class:`MapOf` mappings and :class:`Free` values where the content is checked elsewhere. Scalar fields are
the parameter declarations of :mod:`declare.parameters` (``Int``, ``Float``, ``Bool``, ``Choice``, ``Str``),
so a value is checked and described exactly as a module parameter is. Reading a document against its table
gives plain typed values or raises one :class:`DocumentError`, whose one line is always::

    FILE:LINE: key.path[3].field: VALUE is invalid: RULE

The lines come from the strict YAML reader (:func:`strictio.yaml_reader.read_yaml_with_lines`), which records
the line of every key and list item; a place with no line of its own (a missing key) takes its record's.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from strictio import InputError, YAMLLimits
from strictio.errors import escape_controls
from strictio.yaml_reader import KeyLines, YAMLInputError, read_yaml_with_lines, yaml_text_with_lines

from .parameters import Parameter, ParameterError, printable, short_repr
from .rules import Rule


class _Marker:
    def __init__(self, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return self.name


#: The default of a field that must be given.
REQUIRED: Any = _Marker("REQUIRED")
#: An error that names no value (a missing or unknown key).
NO_VALUE: Any = _Marker("NO_VALUE")


class DocumentError(InputError):
    """A file's content refused at one place: ``FILE:LINE: key.path: VALUE is invalid: RULE``.

    An :class:`~strictio.InputError`, so every command prints it as one line and exits 2. ``line`` is None
    where the document has no line for the place (values given in code; no path either); ``key_path`` is the shown
    path (``objects[2].radius``), ``rule`` what the value breaks, ``value`` the value or :data:`NO_VALUE`.
    """

    def __init__(self, path: str | os.PathLike[str], key_path: str, rule: str, *, line: int | None = None,
                 value: Any = NO_VALUE) -> None:
        self.path = str(path)
        self.key_path = key_path
        self.where = key_path
        self.line = line
        self.rule = rule
        self.value = value
        self.message = rule if value is NO_VALUE else f"{short_repr(value)} is invalid: {rule}"
        place = f"{self.path}:{line}" if line is not None else self.path
        text = ": ".join(part for part in (place, key_path, self.message) if part)
        ValueError.__init__(self, escape_controls(text))


class Invalid(ValueError):
    """Raised by a reader's own check for what no declaration can say; the field reading the value turns it
    into a :class:`DocumentError` at its place. ``key`` names a field of the record when the check is a
    record's (None: the value being read)."""

    def __init__(self, rule: str, key: str | None = None, value: Any = NO_VALUE) -> None:
        super().__init__(rule)
        self.rule, self.key, self.value = rule, key, value


@dataclass(frozen=True)
class Document:
    """A parsed document: its data, the file it came from and the line of every key and list item.

    ``path`` is None for values given in code (errors then name only the key path); ``base`` is the folder
    relative file names are resolved against (default: the file's); ``error`` the class its errors take
    (a subclass of DocumentError that callers catch by name).
    """

    path: Path | None
    data: Any = None
    lines: KeyLines = field(default_factory=dict)
    base: Path | None = None
    error: type[DocumentError] = DocumentError

    @property
    def folder(self) -> Path:
        """Where relative file names in the document are resolved."""
        if self.base is not None:
            return self.base
        return self.path.parent if self.path is not None else Path()

    @property
    def root(self) -> Place:
        return Place(self, (), "")


@dataclass(frozen=True)
class Place:
    """Where a value stands in a document: its keys (for the line) and its shown path (for the message)."""

    document: Document
    keys: tuple[Any, ...]
    shown: str

    def key(self, name: Any) -> Place:
        """The place of a mapping's key ``name``."""
        text = printable(name)
        return Place(self.document, (*self.keys, name), f"{self.shown}.{text}" if self.shown else text)

    def item(self, index: int) -> Place:
        """The place of a list's item ``index``."""
        return Place(self.document, (*self.keys, index), f"{self.shown}[{index}]")

    @property
    def line(self) -> int | None:
        """The line of this place, or of the nearest enclosing one the document has a line for."""
        lines = self.document.lines
        for n in range(len(self.keys), -1, -1):
            line = lines.get(self.keys[:n])
            if line is not None:
                return line
        return None

    def fail(self, rule: str, value: Any = NO_VALUE) -> DocumentError:
        """The error for this place (raise it)."""
        path = self.document.path
        return self.document.error("" if path is None else path, self.shown, rule, line=self.line, value=value)

    def invalid(self, exc: Invalid, value: Any = NO_VALUE) -> DocumentError:
        """The error for an :class:`Invalid` raised while reading the value here."""
        at = self.key(exc.key) if exc.key is not None else self
        return at.fail(exc.rule, value if exc.value is NO_VALUE else exc.value)


def code_place(folder: Path, error: type[DocumentError] = DocumentError) -> Place:
    """The root of values given in code rather than read from a file: errors name the key path alone, file
    names are resolved against ``folder``."""
    return Document(None, base=folder, error=error).root


def document_error(exc: InputError, what: str = "") -> DocumentError:
    """An input error as the document error family has it (``what`` names the file's role: "map")."""
    if isinstance(exc, DocumentError):
        return exc
    if exc.message == "file not found":
        return DocumentError(exc.path, "", f"{what} file not found" if what else "file not found")
    if isinstance(exc, YAMLInputError) and exc.key_path is not None:  # a value no number type holds
        keys = "".join(f"[{k}]" if isinstance(k, int) else f".{printable(k)}" for k in exc.key_path)
        return DocumentError(exc.path, keys.lstrip("."), exc.message.removeprefix("not valid YAML: "), line=exc.line)
    # not YAML at all: the parser's "line 7, column 3" stays where the key path would be (there is none)
    error = DocumentError(exc.path, exc.where, exc.message)
    error.line = getattr(exc, "line", None)
    return error


def read_document(path: str | os.PathLike[str], limits: YAMLLimits | None = None, what: str = "") -> Document:
    """Read a YAML file with the strict reader and its lines; every refusal is a :class:`DocumentError`
    (``what`` names the file's role in "world file not found")."""
    try:
        data, lines = read_yaml_with_lines(path, limits)
    except InputError as exc:
        raise document_error(exc, what) from None
    return Document(Path(path), data, lines)


def document_from_text(text: str, path: str | os.PathLike[str], limits: YAMLLimits | None = None) -> Document:
    """Parse YAML text as the document of ``path`` (which names it in errors and anchors file names)."""
    try:
        data, lines = yaml_text_with_lines(text, path, limits)
    except InputError as exc:
        raise document_error(exc, "") from None
    return Document(Path(path), data, lines)


# -- fields ------------------------------------------------------------------------------------------------
Check = Callable[[Any], str | None]


class Field:
    """One declared field of a document: how its value is read, and what an absent key gives."""

    def __init__(self, *, required: bool = False, default: Any = None, doc: str = "",
                 check: Check | None = None) -> None:
        self.required = required
        self.default = REQUIRED if required else default
        self.doc = doc
        self.check = check

    def read(self, value: Any, at: Place) -> Any:
        """The typed value, or raise DocumentError at ``at``."""
        try:
            result = self.convert(value, at)
            rule = self.check(result) if self.check is not None else None
        except Invalid as exc:
            raise at.invalid(exc, value) from None
        if rule is not None:
            raise at.fail(rule, value)
        return result

    def convert(self, value: Any, at: Place) -> Any:
        raise NotImplementedError

    def absent(self, at: Place) -> Any:
        """The value of an absent key: the default, or an error when the field is required."""
        if self.required:
            raise at.fail(f"missing ({self.doc})" if self.doc else "missing")
        return self.default

    def describe(self) -> str:
        """The allowed values in words."""
        return "any value"


FieldLike = Field | Parameter


def as_field(declared: FieldLike) -> Field:
    """A table entry as a Field: a bare parameter declaration is an optional :class:`Value` with its default."""
    if isinstance(declared, Field):
        return declared
    if isinstance(declared, Parameter):
        return Value(declared)
    raise TypeError(f"expected a Field or a parameter declaration (Int, Float, ...), got {declared!r}")


class Value(Field):
    """A scalar checked by a parameter declaration (``Value(Float(1.0, min=0.0, min_open=True), required=True)``)."""

    def __init__(self, declaration: Parameter, *, required: bool = False, default: Any = REQUIRED, doc: str = "",
                 check: Check | None = None) -> None:
        super().__init__(required=required, default=declaration.default if default is REQUIRED else default,
                         doc=doc or declaration.doc, check=check)
        self.declaration = declaration

    def convert(self, value: Any, at: Place) -> Any:
        try:
            return self.declaration.validate(value, "")
        except ParameterError as exc:
            raise Invalid(exc.rule) from None

    def describe(self) -> str:
        return self.declaration.describe()


class Free(Field):
    """A value taken as it is: its reader checks it (a module's parameters, a task entry)."""

    def __init__(self, *, required: bool = False, default: Any = None, doc: str = "",
                 kinds: tuple[type, ...] = (), what: str = "", check: Check | None = None) -> None:
        super().__init__(required=required, default=default, doc=doc, check=check)
        self.kinds = kinds
        self.what = what

    def convert(self, value: Any, at: Place) -> Any:
        wrong = (isinstance(value, bool) and bool not in self.kinds) or not isinstance(value, self.kinds)
        if self.kinds and wrong:
            raise Invalid(f"expected {self.describe()}, got {type(value).__name__}")
        return value

    def describe(self) -> str:
        return self.what or " or ".join(k.__name__ for k in self.kinds) or "any value"


class FilePath(Field):
    """A file name, resolved against the document's folder unless absolute (``~`` expanded)."""

    def convert(self, value: Any, at: Place) -> Path:
        if not isinstance(value, str) or not value.strip():
            raise Invalid(f"expected {self.describe()}")
        path = Path(value).expanduser()
        return path if path.is_absolute() else at.document.folder / path

    def describe(self) -> str:
        return f"a file name{f' ({self.doc})' if self.doc else ''}"


class Record(Field):
    """A mapping of declared fields; unknown keys are refused naming the allowed ones.

    ``shorthand`` is the field a bare value sets (``- wait: 2`` is ``{seconds: 2}``); ``null_is_empty`` reads
    ``key:`` with nothing after it as an empty mapping; ``rules`` are declare's rules between the fields;
    ``ignore_unknown`` lets other tools' keys pass (a ROS map YAML).
    """

    def __init__(self, fields: Mapping[str, FieldLike], *, required: bool = False, doc: str = "",
                 shorthand: str | None = None, null_is_empty: bool = False, rules: Sequence[Rule] = (),
                 check: Check | None = None, ignore_unknown: bool = False) -> None:
        super().__init__(required=required, default=None, doc=doc, check=check)
        self.fields = {name: as_field(f) for name, f in fields.items()}
        self.ignore_unknown = ignore_unknown
        self.shorthand = shorthand
        self.null_is_empty = null_is_empty
        self.rules = tuple(rules)

    def absent(self, at: Place) -> Any:
        if self.required:
            return super().absent(at)
        return {name: f.absent(at.key(name)) for name, f in self.fields.items()}

    def convert(self, value: Any, at: Place) -> dict[str, Any]:
        if value is None and self.null_is_empty:
            value = {}
        if self.shorthand is not None and not isinstance(value, Mapping):
            value = {self.shorthand: value}
        if not isinstance(value, Mapping):
            raise Invalid(f"expected {self.describe()}, got {type(value).__name__}")
        for key in value:
            if key not in self.fields and not self.ignore_unknown:
                raise at.key(key).fail(f"unknown key (allowed: {', '.join(self.fields) or 'none'})")
        out: dict[str, Any] = {}
        for name, f in self.fields.items():
            out[name] = f.read(value[name], at.key(name)) if name in value else f.absent(at.key(name))
        for rule in self.rules:
            try:
                rule.check(out, "")
            except ParameterError as exc:
                raise at.key(exc.parameter).fail(exc.rule, exc.value) from None
        return out

    def describe(self) -> str:
        return f"a mapping of {', '.join(self.fields)}" if self.fields else "an empty mapping"


class ListOf(Field):
    """A list whose every item is read by one field (``ListOf(Record({...}))``); a tuple of the items."""

    def __init__(self, item: FieldLike, *, required: bool = False, default: Any = (), doc: str = "",
                 min_items: int = 0, null_is_empty: bool = False, check: Check | None = None) -> None:
        super().__init__(required=required, default=default, doc=doc, check=check)
        self.item = as_field(item)
        self.min_items = min_items
        self.null_is_empty = null_is_empty

    def convert(self, value: Any, at: Place) -> tuple[Any, ...]:
        if value is None and self.null_is_empty:
            value = []
        if not isinstance(value, list):
            raise Invalid(f"expected {self.describe()}, got {type(value).__name__}")
        if len(value) < self.min_items:
            raise Invalid(f"expected {self.describe()}")
        return tuple(self.item.read(v, at.item(i)) for i, v in enumerate(value))

    def describe(self) -> str:
        least = "a non-empty list" if self.min_items == 1 else (
            f"a list of at least {self.min_items}" if self.min_items else "a list")
        return f"{least}, each {self.item.describe()}"


class Vector(Field):
    """A list of exactly ``len(names)`` values (``origin: [x, y, yaw]``), each read by ``items`` (one field for
    all, or one per name); a tuple."""

    def __init__(self, items: FieldLike | Sequence[FieldLike], names: Sequence[str], *, required: bool = False,
                 default: Any = None, doc: str = "", check: Check | None = None, named: bool = False) -> None:
        super().__init__(required=required, default=default, doc=doc, check=check)
        self.names = tuple(names)
        self.named = named  # items' places are shown by name (goals[2].qx), not by index (origin[2])
        given = list(items) if isinstance(items, Sequence) else [items] * len(self.names)
        if len(given) != len(self.names):
            raise ValueError(f"{len(given)} fields for {len(self.names)} names")
        self.items = tuple(as_field(f) for f in given)

    def convert(self, value: Any, at: Place) -> tuple[Any, ...]:
        if not isinstance(value, list) or len(value) != len(self.names):
            raise Invalid(f"expected {self.describe()}")
        places = [at.key(name) if self.named else at.item(i) for i, name in enumerate(self.names)]
        return tuple(f.read(v, here) for f, v, here in zip(self.items, value, places, strict=True))

    def describe(self) -> str:
        kinds = {f.describe() for f in self.items}
        return f"[{', '.join(self.names)}]" + (f", each {kinds.pop()}" if len(kinds) == 1 else "")


class MapOf(Field):
    """A mapping whose keys are read by a declaration and whose values by one field (``at: {0: ...}``)."""

    def __init__(self, key: Parameter, value: FieldLike, *, required: bool = False, default: Any = None,
                 doc: str = "", null_is_empty: bool = False) -> None:
        super().__init__(required=required, default={} if default is None else default, doc=doc)
        self.key_declaration = key
        self.value = as_field(value)
        self.null_is_empty = null_is_empty

    def convert(self, value: Any, at: Place) -> dict[Any, Any]:
        if value is None and self.null_is_empty:
            value = {}
        if not isinstance(value, Mapping):
            raise Invalid(f"expected {self.describe()}, got {type(value).__name__}")
        out = {}
        for key, item in value.items():
            try:
                good = self.key_declaration.validate(key, "")
            except ParameterError as exc:
                raise at.key(key).fail(f"not a key here: {exc.rule}") from None
            out[good] = self.value.read(item, at.key(key))
        return out

    def describe(self) -> str:
        return f"a mapping of {self.key_declaration.describe()} to {self.value.describe()}"


# -- checks a declaration cannot say ----------------------------------------------------------------------
def not_blank(value: str) -> str | None:
    """A check: the text must hold something besides spaces."""
    return None if value.strip() else "must not be empty"
