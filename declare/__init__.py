"""declare: the declarations floor.

What a value may be, said once and used everywhere: typed, bounded parameter declarations (``Int``,
``Float``, ``Bool``, ``Choice``, ``Str``) and rules between them (``Ordered``, ``Check``). Module parameters,
source options and the fields of every file objrec reads (parameter files, maps, worlds, poses, missions)
are declared with these, so validation, messages and widgets come from one place. This package sits at the
bottom beside ``strictio``: ``objrec_core`` and ``navigation`` both build on it, and it imports nothing of
the project but ``strictio``.
"""

from .parameters import Bool, Choice, Float, Int, Parameter, ParameterError, Str, printable, short_repr
from .rules import Check, Ordered, Rule

__all__ = [
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
    "short_repr",
]
