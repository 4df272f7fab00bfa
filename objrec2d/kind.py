"""The ``2d`` data-kind plug-in: how the apps open image sources and draw 2D results."""

from .annotate import annotate
from .sources import open_source

__all__ = ["annotate", "open_source"]
