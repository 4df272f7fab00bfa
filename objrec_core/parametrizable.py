"""The base of every filter and detector: declared parameters and rules, an id, observers, and state hooks."""

from __future__ import annotations

import dataclasses
import re
import threading
from abc import ABCMeta
from collections.abc import Mapping
from typing import Any, ClassVar

from declare.parameters import Parameter, ParameterError, printable
from declare.rules import Rule

from .observer import Change, Subject

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


def _snapshot_type(cls: type, names: list[str]) -> type:
    """A frozen, slotted record with one attribute per parameter: ``p.h_min``; ``p.h_mim`` fails at once."""
    fields = [(name, Any) for name in names]
    return dataclasses.make_dataclass(f"{cls.__name__}Parameters", fields, frozen=True, slots=True)


def _overridden(cls: type, klass: type, inherited: Parameter, value: Any) -> Parameter:
    """A subclass's plain value for an inherited parameter (``class MyHSV(HSVFilter): h_min = 10``): the
    inherited declaration with that default, as HoloViz param does, checked against it (a ParameterError
    naming the class and the parameter at class creation). A method or property there would hide the
    parameter, so it is refused."""
    if hasattr(value, "__get__") or isinstance(value, staticmethod | classmethod):
        raise TypeError(f"{klass.__name__}: {inherited.name!r} is a declared parameter; a "
                        f"{type(value).__name__} cannot replace it (rename one of them)")
    changed = inherited.with_default(value, klass.__name__)
    setattr(cls, inherited.name, changed)  # the descriptor again, so ``module.h_min`` reads the value
    return changed


class Parametrizable(Subject, metaclass=ABCMeta):
    """An object whose behaviour is set by declared parameters.

    Subclasses declare parameters (``h_min = Int(0, "...", min=0, max=179)``) and rules between them
    (``order = Ordered("min_radius", "max_radius")``) as class attributes. Processing code reads a typed,
    immutable snapshot, ``p = self.params`` then ``p.h_min``: it is replaced, never mutated, on every change,
    so a worker thread that takes it once per frame sees one consistent set even while the GUI thread sets
    new values.

    Non-scalar state (a feature detector's target image) goes through ``get_state`` and the two-phase
    ``prepare_state``/``apply_state`` so that ``ParameterStorage`` can validate a whole file before it
    changes anything.
    """

    #: The data kind this module works on (a kind's registered name, such as "2d"); set by kind base classes.
    kind: ClassVar[str | None] = None
    #: The name of this type in parameter files and the registry; defaults to the class name.
    type_name: ClassVar[str]
    _declared: ClassVar[dict[str, Parameter]] = {}
    _rules: ClassVar[tuple[Rule, ...]] = ()
    #: Parameters no tuning search should change, name -> why (a seed, a display switch): objrec-tune keeps them
    #: at the file's values and the conformance suite checks the names are declared.
    untuned: ClassVar[Mapping[str, str]] = {}
    Parameters: ClassVar[type] = _snapshot_type(object, [])

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        declared: dict[str, Parameter] = {}
        rules: dict[str, Rule] = {}
        for klass in reversed(cls.__mro__):
            for name, value in vars(klass).items():
                if isinstance(value, Parameter):
                    declared[name] = value
                elif isinstance(value, Rule):
                    rules[name] = value
                elif name in declared:  # ``h_min = 10`` in a subclass: the inherited declaration, new default
                    declared[name] = _overridden(cls, klass, declared[name], value)
                else:
                    rules.pop(name, None)
        framework = [k for k in cls.__mro__ if k.__module__.startswith("objrec_core.")]
        for name in declared:
            owner = next((k for k in framework if name in vars(k) or hasattr(k, name)), None)
            if owner is not None:
                raise TypeError(f"{cls.__name__}: parameter {name!r} would hide {owner.__name__}.{name}; rename it")
        for rule_name, rule in rules.items():
            missing = [n for n in rule.names if n not in declared]
            if missing:
                raise TypeError(f"{cls.__name__}: rule {rule_name} names undeclared parameters {missing}")
        cls._declared = declared
        cls._rules = tuple(rules.values())
        cls.Parameters = _snapshot_type(cls, list(declared))
        if "type_name" not in vars(cls):
            cls.type_name = cls.__name__

    def __init__(self, id: str | None = None, **parameters: Any) -> None:
        super().__init__()
        self._id = check_module_id(id if id is not None else self.type_name)
        self._lock = threading.RLock()
        defaults = self.default_values()
        for name, spec in self._declared.items():  # a default the installation cannot serve (SURF) is refused
            defaults[name] = spec.validate(defaults[name], self.label)
        self._snapshot = self.Parameters(**defaults)
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
        values = ", ".join(f"{k}={v!r}" for k, v in self.get_parameters().items())
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

    @classmethod
    def parameter_rules(cls) -> tuple[Rule, ...]:
        """The declared rules between parameters."""
        return cls._rules

    @classmethod
    def default_values(cls) -> dict[str, Any]:
        return {name: spec.default for name, spec in cls._declared.items()}

    def relevant_parameters(self, values: Mapping[str, Any] | None = None) -> list[str]:
        """The names of the parameters that matter with these values (default: the current ones)."""
        values = self.get_parameters() if values is None else values
        return [name for name, spec in self._declared.items() if spec.is_relevant(values)]

    # -- values -----------------------------------------------------------------------------------------
    @property
    def params(self) -> Any:
        """A consistent, immutable, typed snapshot of all values (``p.h_min``): take it once per frame."""
        return self._snapshot

    def get_parameters(self) -> dict[str, Any]:
        snapshot = self._snapshot
        return {name: getattr(snapshot, name) for name in self._declared}

    def validate_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """Check values against the declarations without applying them; returns them in canonical form."""
        clean = {}
        for name, value in values.items():
            spec = self._declared.get(name)
            if spec is None:
                known = ", ".join(self._declared) or "none"
                raise ParameterError(self.label, printable(name), value, f"no such parameter (known: {known})")
            clean[name] = spec.validate(value, self.label)
        return clean

    def check_values(self, values: Mapping[str, Any]) -> None:
        """Rules between parameters, given every value that would be in force: the declared rules, then
        whatever a subclass adds (call ``super().check_values(values)``). Raise ParameterError to refuse."""
        for rule in self._rules:
            rule.check(values, self.label)

    def set_parameters(self, **values: Any) -> None:
        """Validate every value first, then apply them together and notify observers once, with the changes."""
        clean = self.validate_parameters(values)
        with self._lock:
            current = self.get_parameters()
            changes = [Change(self, n, current[n], v) for n, v in clean.items() if current[n] != v]
            if not changes:
                return
            merged = {**current, **clean}
            self.check_values(merged)
            self._snapshot = self.Parameters(**merged)
            self.parameters_changed({c.name for c in changes})
        self.notify(changes)

    def reset_parameters(self) -> None:
        """Restore every declared default."""
        self.set_parameters(**self.default_values())

    def parameters_changed(self, changed: set[str]) -> None:
        """Hook: called after new values were applied (before observers hear of them).

        A module whose derived data depends on parameters (the feature detector's target keypoints)
        recomputes it here.
        """

    # -- non-scalar state: ParameterStorage's two hooks ------------------------------------------------
    @classmethod
    def keeps_state(cls) -> bool:
        """Whether this type saves state beside its parameters (it overrides ``get_state``)."""
        return cls.get_state is not Parametrizable.get_state

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

    def load(self, values: Mapping[str, Any], prepared_state: Any, notify: bool = True) -> list[Change]:
        """Replace every value and the state at once (used by ParameterStorage after validation).

        The state is applied first, then ``parameters_changed`` hears of every value that changed, as after
        ``set_parameters``. Returns the changes (a ``"state"`` change included); ``notify=False`` lets the
        storage notify once the whole file is applied.
        """
        with self._lock:
            current = self.get_parameters()
            complete = {**self.default_values(), **values}
            changes = [Change(self, n, current[n], v) for n, v in complete.items() if current[n] != v]
            self._snapshot = self.Parameters(**complete)
            self.apply_state(prepared_state)
            if changes:
                self.parameters_changed({c.name for c in changes})
            if self.keeps_state():
                changes.append(Change(self, "state"))
        if notify:
            self.notify(changes)
        return changes
