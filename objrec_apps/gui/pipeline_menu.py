"""The Pipeline menu: add, remove and reorder filters and detectors from the module registry, so a user's
new filter (registered by entry point) is tried here without writing an app."""

from __future__ import annotations

import logging
from collections.abc import Callable

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QMenu, QWidget

from objrec_core import (
    Detector,
    Parametrizable,
    PipelineError,
    RecognitionSystem,
    UnknownModuleError,
    get_kind,
    module_types,
)

log = logging.getLogger(__name__)


def submenu_title(kind: str) -> str:
    """``Add 2d module (images)``: the kind's name and what its data is called."""
    if kind == "any":
        return "Add module (any data)"
    try:
        return f"Add {kind} module ({get_kind(kind).title})"
    except UnknownModuleError:
        return f"Add {kind} module"


def _role(klass: type[Parametrizable]) -> str:
    return "detector" if issubclass(klass, Detector) else "filter"


class PipelineMenu(QMenu):
    """Rebuilt each time it opens, from the registry and the current pipeline.

    ``message`` reports what was done, or why not (mixing data kinds is refused by the pipeline).
    """

    message = Signal(str)

    def __init__(self, system: RecognitionSystem, parent: QWidget | None = None,
                 types: Callable[[], dict[str, type[Parametrizable]]] = module_types) -> None:
        super().__init__("&Pipeline", parent)
        self.system = system
        self._types = types
        self._cache: dict[str, type[Parametrizable]] | None = None
        self.aboutToShow.connect(self.populate)

    def module_types(self) -> dict[str, type[Parametrizable]]:
        """Every registered type, loaded once (types that fail to load are logged and left out)."""
        if self._cache is None:
            self._cache = self._types()
        return self._cache

    def populate(self) -> None:
        self.clear()
        kind = self.system.kind
        by_kind: dict[str, list[type[Parametrizable]]] = {}
        for klass in self.module_types().values():
            by_kind.setdefault(klass.kind or "any", []).append(klass)
        for module_kind in sorted(by_kind):
            submenu = self.addMenu(submenu_title(module_kind))
            submenu.setEnabled(kind is None or module_kind in (kind, "any"))
            if not submenu.isEnabled():
                submenu.setToolTip(f"the pipeline holds {kind} modules; a pipeline cannot mix kinds")
            for klass in sorted(by_kind[module_kind], key=lambda k: (_role(k) == "detector", k.type_name)):
                action = submenu.addAction(f"{klass.type_name}  ({_role(klass)})")
                action.setObjectName(f"add:{klass.type_name}")
                action.setToolTip((klass.__doc__ or "").strip().split("\n")[0])
                action.triggered.connect(lambda _=False, name=klass.type_name: self.add_module(name))
        self.addSeparator()
        modules = self.system.modules
        remove = self.addMenu("Remove")
        up = self.addMenu("Move up")
        down = self.addMenu("Move down")
        for index, module in enumerate(modules):
            action = remove.addAction(module.id)
            action.setObjectName(f"remove:{module.id}")
            action.triggered.connect(lambda _=False, m=module.id: self.remove_module(m))
            if index > 0:
                action = up.addAction(module.id)
                action.setObjectName(f"up:{module.id}")
                action.triggered.connect(lambda _=False, m=module.id, i=index: self.move_module(m, i - 1))
            if index < len(modules) - 1:
                action = down.addAction(module.id)
                action.setObjectName(f"down:{module.id}")
                action.triggered.connect(lambda _=False, m=module.id, i=index: self.move_module(m, i + 1))
        for submenu in (remove, up, down):
            submenu.setEnabled(not submenu.isEmpty())

    def add_module(self, type_name: str) -> Parametrizable | None:
        """A new module with default parameters: a filter goes before the first detector, a detector last."""
        klass = self.module_types()[type_name]
        try:
            module = klass(self.system.unique_id(type_name))
            index = None
            if not issubclass(klass, Detector):
                detectors = [i for i, m in enumerate(self.system.modules) if isinstance(m, Detector)]
                index = detectors[0] if detectors else None
            self.system.add_module(module, index)
        except (PipelineError, ValueError, TypeError) as exc:
            self.message.emit(f"cannot add {type_name}: {exc}")
            return None
        self.message.emit(f"added {module.label}")
        return module

    def remove_module(self, module_id: str) -> None:
        try:
            module = self.system.remove_module(module_id)
        except (KeyError, PipelineError) as exc:
            self.message.emit(f"cannot remove {module_id}: {exc}")
            return
        self.message.emit(f"removed {module.label}")

    def move_module(self, module_id: str, index: int) -> None:
        try:
            self.system.move_module(module_id, index)
        except (KeyError, PipelineError) as exc:
            self.message.emit(f"cannot move {module_id}: {exc}")
            return
        self.message.emit(f"moved {module_id} to position {index + 1}")
