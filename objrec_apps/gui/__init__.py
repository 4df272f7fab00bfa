"""The definition GUI (``objrec-define``): PySide6 widgets over objrec_core's DefinitionDirector.

Qt is imported here and in ``objrec_apps`` only; the libraries stay usable on a headless robot.
"""

from . import (
    compat,  # noqa: F401 - first: guards against a refcount bug of PySide6 6.12 (see compat.py)
    feature_panel,  # noqa: F401 - registers the FeatureDetector panel
)
from .cloud_view import CloudView
from .interactive_image import InteractiveImage
from .main_window import DefinitionGUI
from .panel_column import PanelColumn
from .panels import ParameterPanel, create_panel, register_panel, unregister_panel
from .stage_views import StageViews
from .view3d import View3D
from .worker import ProcessingWorker, Shown

__all__ = [
    "CloudView",
    "DefinitionGUI",
    "InteractiveImage",
    "PanelColumn",
    "ParameterPanel",
    "ProcessingWorker",
    "Shown",
    "StageViews",
    "View3D",
    "create_panel",
    "register_panel",
    "unregister_panel",
]
