"""Undo and redo for the definition window, recorded from the Change events of the system and its modules.

Nothing that changes a parameter needs to know about undo: whatever calls ``set_parameters`` (a panel, the
eyedropper, a script) makes one notification, and one notification becomes one undo step. A slider drag
is one step too: while a slider is held (``gestures``), consecutive changes of the same parameter merge.
Pipeline edits (add, remove, move: the system's ``pipeline`` change) and target selections (a module's
``state`` change) are steps as well. Changes made by undo or redo themselves are not recorded.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from PySide6.QtCore import QObject, Signal
from PySide6.QtGui import QUndoCommand, QUndoStack

from objrec_core import Change, Parametrizable, RecognitionSystem

log = logging.getLogger(__name__)

#: Steps kept; older ones are dropped (a long tuning session must not grow without bound).
UNDO_LIMIT = 500


class Gestures:
    """Which pointer gesture (a held slider) is under way: changes made during one merge into one step."""

    def __init__(self) -> None:
        self._count = 0
        self._held = False

    def begin(self) -> None:
        self._count += 1
        self._held = True

    def end(self) -> None:
        self._held = False

    @property
    def current(self) -> int | None:
        """The id of the gesture under way, None when no slider is held."""
        return self._count if self._held else None


#: The one gesture tracker of the application: panels report slider presses and releases here.
gestures = Gestures()


@dataclass
class _Action:
    """One reversible change: what undo and redo do."""

    undo: Callable[[], None]
    redo: Callable[[], None]


class Step(QUndoCommand):
    """One undo step: the actions one notification recorded. The change is already made when pushed,
    so the first ``redo`` (QUndoStack.push calls it) does nothing."""

    def __init__(self, recorder: UndoRecorder, text: str, actions: list[_Action],
                 merge: tuple[int, str, int] | None = None, values: dict[str, list[Any]] | None = None,
                 module: Parametrizable | None = None) -> None:
        super().__init__(text)
        self.recorder = recorder
        self.actions = actions
        #: (module id(), parameter, gesture) for a change a slider drag may extend, else None.
        self.merge_key = merge
        self.values = values
        self.module = module
        self._pushed = False

    def id(self) -> int:
        return 1 if self.merge_key is not None else -1

    def mergeWith(self, other: QUndoCommand) -> bool:  # noqa: N802 - Qt override
        if not isinstance(other, Step) or other.merge_key is None or other.merge_key != self.merge_key:
            return False
        assert self.values is not None and other.values is not None and self.module is not None
        old = self.values[self.merge_key[1]][0]
        new = other.values[self.merge_key[1]][1]
        self.values[self.merge_key[1]] = [old, new]
        self.actions = [_parameter_action(self.module, {self.merge_key[1]: (old, new)})]
        self.setText(other.text())  # the Edit menu names where the drag ended, not its first step
        return True

    def redo(self) -> None:
        if not self._pushed:
            self._pushed = True
            return
        with self.recorder.applying():
            for action in self.actions:
                action.redo()

    def undo(self) -> None:
        with self.recorder.applying():
            for action in reversed(self.actions):
                action.undo()


def _parameter_action(module: Parametrizable, values: dict[str, tuple[Any, Any]]) -> _Action:
    olds = {name: old for name, (old, _new) in values.items()}
    news = {name: new for name, (_old, new) in values.items()}
    return _Action(lambda: module.set_parameters(**olds), lambda: module.set_parameters(**news))


def apply_state(module: Parametrizable, state: Any) -> None:
    """Give ``module`` the saved state ``state`` (None: none) as a file load would, and tell its observers."""
    prepared = module.prepare_state(state, module.get_parameters())
    module.apply_state(prepared)
    module.notify([Change(module, "state")])


class _Observer:
    """Hands a subject's notifications to the recorder's signal: direct in the GUI thread, queued from
    the worker thread (a selection is processed there)."""

    def __init__(self, recorder: UndoRecorder) -> None:
        self.recorder: UndoRecorder | None = recorder

    def update(self, subject: Any, changes: Sequence[Change]) -> None:
        recorder = self.recorder
        if recorder is not None:
            recorder.heard.emit(subject, tuple(changes))


class UndoRecorder(QObject):
    """Keeps ``stack`` (a QUndoStack) in step with the changes of ``system`` and of its modules."""

    heard = Signal(object, object)

    def __init__(self, system: RecognitionSystem, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.system = system
        self.stack = QUndoStack(self)
        self.stack.setUndoLimit(UNDO_LIMIT)
        self._applying = 0
        self._observer = _Observer(self)
        self._watched: dict[int, Parametrizable] = {}
        self._states: dict[int, Any] = {}
        self.heard.connect(self._record)
        system.add_observer(self._observer)
        self._follow_pipeline()

    # -- what is observed ----------------------------------------------------------------------------------
    def _follow_pipeline(self) -> None:
        """Observe exactly the modules in the pipeline (a removed module comes back through undo with its
        values, and is observed again then)."""
        current = {id(m): m for m in self.system.modules}
        for key, module in list(self._watched.items()):
            if key not in current:
                module.remove_observer(self._observer)
                del self._watched[key]
                self._states.pop(key, None)
        for key, module in current.items():
            if key not in self._watched:
                module.add_observer(self._observer)
                self._watched[key] = module
                if module.keeps_state():
                    self._states[key] = module.get_state()

    def reset(self) -> None:
        """A new document (a file opened): no steps, clean, the states as they are now."""
        self.stack.clear()
        self._follow_pipeline()
        for key, module in self._watched.items():
            if module.keeps_state():
                self._states[key] = module.get_state()
        self.stack.setClean()

    def detach(self) -> None:
        self._observer.recorder = None
        self.system.remove_observer(self._observer)
        for module in self._watched.values():
            module.remove_observer(self._observer)
        self._watched.clear()

    # -- recording ------------------------------------------------------------------------------------------
    class _Applying:
        def __init__(self, recorder: UndoRecorder) -> None:
            self.recorder = recorder

        def __enter__(self) -> None:
            self.recorder._applying += 1

        def __exit__(self, *exc: object) -> None:
            self.recorder._applying -= 1

    def applying(self) -> UndoRecorder._Applying:
        """Within: changes come from undo or redo and are not recorded."""
        return UndoRecorder._Applying(self)

    def _record(self, subject: Any, changes: tuple[Change, ...]) -> None:
        if subject is self.system:
            if any(c.name == "pipeline" for c in changes):
                self._follow_pipeline()
            if not self._applying:
                self._record_system(changes)
        elif isinstance(subject, Parametrizable):
            if any(c.name == "state" for c in changes) and subject.keeps_state():
                old_state = self._states.get(id(subject))
                new_state = subject.get_state()
                self._states[id(subject)] = new_state
            else:
                old_state = new_state = None
            if not self._applying and id(subject) in self._watched:
                self._record_module(subject, changes, old_state, new_state)

    def _record_system(self, changes: Sequence[Change]) -> None:
        system = self.system
        actions: list[_Action] = []
        texts: list[str] = []
        for change in changes:
            if change.name == "pipeline":
                old, new = tuple(change.old or ()), tuple(change.new or ())
                actions.append(_Action(lambda old=old: system.set_modules(old),
                                       lambda new=new: system.set_modules(new)))
                texts.append(_pipeline_text(old, new))
            elif change.name in ("object_name", "description"):
                name, old, new = change.name, change.old, change.new
                actions.append(_Action(lambda name=name, old=old: setattr(system, name, old),
                                       lambda name=name, new=new: setattr(system, name, new)))
                texts.append(f"{name.replace('_', ' ')} {new!r}")
        if actions:
            self.stack.push(Step(self, "; ".join(texts), actions))

    def _record_module(self, module: Parametrizable, changes: Sequence[Change], old_state: Any,
                       new_state: Any) -> None:
        declared = {spec.name for spec in module.parameter_specs()}
        values = {c.name: (c.old, c.new) for c in changes if c.name in declared}
        actions: list[_Action] = []
        texts: list[str] = []
        merge = None
        if values:
            actions.append(_parameter_action(module, values))
            texts.append(", ".join(f"{module.id}.{name} = {new!r}" for name, (_old, new) in values.items()))
            gesture = gestures.current
            if gesture is not None and len(values) == 1:
                merge = (id(module), next(iter(values)), gesture)
        if any(c.name == "state" for c in changes) and module.keeps_state():
            actions.append(_Action(lambda: apply_state(module, old_state), lambda: apply_state(module, new_state)))
            texts.append(f"{module.id} target")
            merge = None
        if actions:
            step_values = {name: [old, new] for name, (old, new) in values.items()}
            self.stack.push(Step(self, "; ".join(texts), actions, merge, step_values, module))


def _pipeline_text(old: tuple[Parametrizable, ...], new: tuple[Parametrizable, ...]) -> str:
    """``add colour``, ``remove blobs``, ``move open``: what a pipeline change did, for the Edit menu."""
    added = [m.id for m in new if not any(m is o for o in old)]
    removed = [m.id for m in old if not any(m is n for n in new)]
    if added and not removed:
        return "add " + ", ".join(added)
    if removed and not added:
        return "remove " + ", ".join(removed)
    if not added and not removed:
        moved = [m.id for i, m in enumerate(new) if i >= len(old) or old[i] is not m]
        return "move " + ", ".join(moved[:1] or ["modules"])
    return "replace the pipeline"
