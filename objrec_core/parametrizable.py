"""The base of every filter and detector: declared parameters, an id, observers, and state hooks."""

from __future__ import annotations

import re
import threading
from abc import ABCMeta
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, ClassVar

from .observer import Subject
from .parameters import Parameter, ParameterError

_ID_PATTERN = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")


#: Ids that name a stage of their own in views (the pipeline's input).
RESERVED_IDS = frozenset({"input"})


def check_module_id(module_id: str) -> str:
    """Ids key parameter files and panels, so they must be plain names."""
    if not isinstance(module_id, str) or not _ID_PATTERN.match(module_id):
        raise ValueError(
            f"module id {module_id!r} is invalid: use letters, digits, '_', '-' or '.', starting with a letter"
        )
    if module_id in RESERVED_IDS:
        raise ValueError(f"module id {module_id!r} is reserved for the pipeline's input stage; choose another")
    return module_id


class Parametrizable(Subject, metaclass=ABCMeta):
    """An object whose behaviour is set by declared parameters.

    Subclasses declare parameters as class attributes (``h_min = Int(0, "...", min=0, max=179)``). Values
    live in an immutable mapping that is replaced, never mutated, on every change: a worker thread that
    takes ``self.params`` once per frame sees one consistent set even while the GUI thread sets new values.

    Non-scalar state (a feature detector's target image) goes through ``get_state`` and the two-phase
    ``prepare_state``/``apply_state`` so that ``ParameterStorage`` can validate a whole file before it
    changes anything.
    """

    #: The data this module works on: "2d" (images) or "3d" (point clouds). Set by the package base classes.
    kind: ClassVar[str | None] = None
    #: The name of this type in parameter files and the registry; defaults to the class name.
    type_name: ClassVar[str]
    _declared: ClassVar[dict[str, Parameter]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        declared: dict[str, Parameter] = {}
        for klass in reversed(cls.__mro__):
            for name, value in vars(klass).items():
                if isinstance(value, Parameter):
                    declared[name] = value
                elif name in declared:  # a subclass replaced the declaration with something else
                    del declared[name]
        framework = [k for k in cls.__mro__ if k.__module__.startswith("objrec_core.")]
        for name in declared:
            owner = next((k for k in framework if name in vars(k) or hasattr(k, name)), None)
            if owner is not None:
                raise TypeError(f"{cls.__name__}: parameter {name!r} would hide {owner.__name__}.{name}; rename it")
        cls._declared = declared
        if "type_name" not in vars(cls):
            cls.type_name = cls.__name__

    def __init__(self, id: str | None = None, **parameters: Any) -> None:
        super().__init__()
        self._id = check_module_id(id if id is not None else self.type_name)
        self._lock = threading.RLock()
        self._values: Mapping[str, Any] = MappingProxyType({n: p.default for n, p in self._declared.items()})
        if parameters:
            self.set_parameters(**parameters)

    # -- identity ---------------------------------------------------------------------------------------
    @property
    def id(self) -> str:
        return self._id

    @property
    def label(self) -> str:
        """How messages name this module: its type and, where different, its id."""
        return self.type_name if self._id == self.type_name else f"{self.type_name} '{self._id}'"

    def __repr__(self) -> str:
        values = ", ".join(f"{k}={v!r}" for k, v in self._values.items())
        return f"{type(self).__name__}(id={self._id!r}, {values})"

    # -- declarations -----------------------------------------------------------------------------------
    @classmethod
    def parameter_specs(cls) -> tuple[Parameter, ...]:
        """The declarations, in declaration order; widgets and docs are generated from these."""
        return tuple(cls._declared.values())

    @classmethod
    def parameter_spec(cls, name: str) -> Parameter:
        try:
            return cls._declared[name]
        except KeyError:
            raise KeyError(f"{cls.type_name} has no parameter {name!r}") from None

    # -- values -----------------------------------------------------------------------------------------
    @property
    def params(self) -> Mapping[str, Any]:
        """A consistent, read-only snapshot of all values: take it once per frame."""
        return self._values

    def get_parameters(self) -> dict[str, Any]:
        return dict(self._values)

    def validate_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """Check values against the declarations without applying them; returns them in canonical form."""
        clean = {}
        for name, value in values.items():
            spec = self._declared.get(name)
            if spec is None:
                known = ", ".join(self._declared) or "none"
                raise ParameterError(self.label, name, value, f"no such parameter (known: {known})")
            clean[name] = spec.validate(value, self.label)
        return clean

    def check_values(self, values: Mapping[str, Any]) -> None:
        """Hook: rules between parameters (a minimum above its maximum), given every value that would be in
        force. Raise ParameterError to refuse; called by ``set_parameters`` and when a file is loaded."""

    def set_parameters(self, **values: Any) -> None:
        """Validate every value first, then apply them together and notify observers once."""
        clean = self.validate_parameters(values)
        with self._lock:
            changed = {n for n, v in clean.items() if self._values[n] != v}
            if not changed:
                return
            merged = {**self._values, **clean}
            self.check_values(merged)
            self._values = MappingProxyType(merged)
            self.parameters_changed(changed)
        self.notify()

    def reset_parameters(self) -> None:
        """Restore every declared default."""
        self.set_parameters(**{n: p.default for n, p in self._declared.items()})

    def parameters_changed(self, changed: set[str]) -> None:
        """Hook: called after ``set_parameters`` applied new values (before observers hear of them).

        A module whose derived data depends on parameters (the feature detector's target keypoints)
        recomputes it here.
        """

    # -- non-scalar state: ParameterStorage's two hooks ------------------------------------------------
    def get_state(self) -> dict[str, Any] | None:
        """Hook: extra state to save beside the parameters, as YAML-safe data (bytes are allowed)."""
        return None

    def prepare_state(self, state: Any, parameters: Mapping[str, Any]) -> Any:
        """Hook: check and decode saved state without changing anything; raise ValueError if it is bad.

        ``parameters`` are the values that will be in force when the state is applied. ``state`` is None
        when the file holds none. The return value is passed to ``apply_state``.
        """
        if state is not None:
            raise ValueError(f"{self.type_name} keeps no state, but the file has some")
        return None

    def apply_state(self, prepared: Any) -> None:
        """Hook: install what ``prepare_state`` returned. Must not fail for prepared input."""

    def load(self, values: Mapping[str, Any], prepared_state: Any, notify: bool = True) -> None:
        """Replace every value and the state at once (used by ParameterStorage after validation).

        The state is applied first, then ``parameters_changed`` hears of every value that changed, as after
        ``set_parameters``. ``notify=False`` lets the storage notify once the whole file is applied.
        """
        with self._lock:
            complete = {**{n: p.default for n, p in self._declared.items()}, **values}
            changed = {n for n, v in complete.items() if self._values[n] != v}
            self._values = MappingProxyType(complete)
            self.apply_state(prepared_state)
            if changed:
                self.parameters_changed(changed)
        if notify:
            self.notify()
