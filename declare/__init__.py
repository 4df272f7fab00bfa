"""declare: the declarations floor.

What a value may be, said once and used everywhere: typed, bounded parameter declarations (``Int``,
``Float``, ``Bool``, ``Choice``, ``Str``) and rules between them (``Ordered``, ``Check``). Module parameters,
source options and the fields of every file objrec reads (parameter files, maps, worlds, poses, missions)
are declared with these, so validation, messages and widgets come from one place. What a type of value
means (reading it from text, the values that test it, its description) lives on its class, so a plug-in adds
a type by subclassing ``Parameter``. This package sits at the
bottom beside ``strictio``: ``objrec_core`` and ``navigation`` both build on it, and it imports nothing of
the project but ``strictio``.
"""

from .parameters import (
    NONE_WORDS,
    Bool,
    Choice,
    Float,
    Int,
    Parameter,
    ParameterError,
    Str,
    printable,
    same_value,
    short_repr,
    unique_values,
)
from .rules import Check, Ordered, Rule

__all__ = [
    "NONE_WORDS",
    "Bool",
    "Check",
    "Choice",
    "Float",
    "Int",
    "Ordered",
    "Parameter",
    "ParameterError",
    "Rule",
    "Str",
    "printable",
    "same_value",
    "short_repr",
    "unique_values",
]
