"""A plug-in that adds a parameter type, ``Colour``, with no edit to objrec's framework: its declaration
says what a colour is (validation, text, conformance values, description), a Qt editor for it is registered
with ``register_editor`` (``objrec_colour.editor``, the only part that needs Qt), and ``TintFilter`` uses it.
"""

from .colour import Colour, rgb
from .tint import TintFilter

__all__ = ["Colour", "TintFilter", "rgb"]
