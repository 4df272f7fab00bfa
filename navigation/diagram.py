"""Draw the patrol machine as a Mermaid state diagram, active states marked, like smach_viewer's figure.

The drawing is generated from the same state and transition tables the machine is built from, so it
cannot drift from the code, and states added to a machine (tasks at poses, monitors) are drawn too.
Mermaid cannot draw an arrow out of a nested state to an outer one, so such transitions start at the
outer state that contains their source (as smach_viewer draws a container's outcomes), with the inner
source named in the label.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from strictio import write_atomically

from .patrol import OUTCOME, SEP, SHUTDOWN, PatrolMachine, patrol_states, patrol_transitions

INDENT = "    "


def _edges(transitions: list[dict[str, Any]]) -> dict[str, list[tuple[str, str, str]]]:
    """Transitions grouped by the composite state in which they are drawn ('' = top level)."""
    grouped: dict[tuple[str, str, str, str], list[str]] = defaultdict(list)
    for t in transitions:
        if t["source"] == "initial":
            continue
        src, dst = t["source"].split(SEP), t["dest"].split(SEP)
        common = 0
        while common < min(len(src), len(dst)) - 1 and src[common] == dst[common]:
            common += 1
        a, b = src[common], dst[common]
        note = f" from {src[-1]}" if len(src) > common + 1 else ""
        cond = t.get("conditions")
        label_tail = (f" [{cond}]" if cond else "") + note
        grouped[(SEP.join(src[:common]), a, b, label_tail)].append(t["trigger"])
    out: dict[str, list[tuple[str, str, str]]] = defaultdict(list)
    for (scope, a, b, tail), triggers in grouped.items():
        out[scope].append((a, b, ", ".join(dict.fromkeys(triggers)) + tail))
    return out


def _emit(states: list[Any], scope: str, edges: dict[str, list[tuple[str, str, str]]], depth: int,
          lines: list[str], active: set[str], initial: str | None = None) -> None:
    pad = INDENT * depth
    if initial:
        lines.append(f"{pad}[*] --> {initial}")
    for state in states:
        spec = state if isinstance(state, dict) else {"name": state}
        name = spec["name"]
        full = f"{scope}{SEP}{name}" if scope else name
        if "parallel" in spec:
            lines.append(f"{pad}state {name} {{")
            for k, region in enumerate(spec["parallel"]):
                if k:
                    lines.append(f"{pad}{INDENT}--")
                _emit([region], full, edges, depth + 1, lines, active)
            lines.append(f"{pad}}}")
        elif "children" in spec:
            lines.append(f"{pad}state {name} {{")
            _emit(spec["children"], full, edges, depth + 1, lines, active, spec.get("initial"))
            lines.append(f"{pad}}}")
        elif full in active:
            # classDef styling does not reach into composite states in every Mermaid version; a
            # description line does, so active simple states carry both.
            lines.append(f"{pad}{name} : ACTIVE")
        else:
            lines.append(f"{pad}{name}")
    for a, b, label in edges.get(scope, []):
        lines.append(f"{pad}{a} --> {b} : {label}")


def _tables(machine: int | PatrolMachine) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    if isinstance(machine, PatrolMachine):
        return machine.states_table, machine.transitions_table
    return patrol_states(machine), patrol_transitions(machine)


def mermaid(machine: int | PatrolMachine, active: Iterable[str] = ()) -> str:
    """Mermaid ``stateDiagram-v2`` text of a machine (or of the plain patrol of that many goals).

    ``active`` states are marked.
    """
    active = set(active)
    states, transitions = _tables(machine)
    lines = ["stateDiagram-v2", f"{INDENT}[*] --> MONITORED_PATROL"]
    _emit(states, "", _edges(transitions), 1, lines, active)
    lines.append(f"{INDENT}{SHUTDOWN} --> [*] : {OUTCOME}")
    marked = sorted({a.split(SEP)[-1] for a in active})
    lines.append(f"{INDENT}classDef active stroke:#c00,stroke-width:4px,font-weight:bold")
    if marked:
        lines.append(f"{INDENT}%% active: {', '.join(marked)}")
        lines.append(f"{INDENT}class {','.join(marked)} active")
    return "\n".join(lines) + "\n"


def write_diagram(path: str | Path, machine: int | PatrolMachine, active: Iterable[str] = ()) -> Path:
    """Write the diagram; a ``.md`` file gets a fenced mermaid block, anything else the bare text.

    The file is replaced atomically, so a viewer polling it never reads half a diagram; what must not be
    replaced (a device, a FIFO, a read-only file), a missing folder and every write failure are a
    ``strictio.OutputError``. It is rewritten at every state change, so it is not synced to the disk
    each time (a lost diagram is drawn again by the next change).
    """
    path = Path(path)
    text = mermaid(machine, active)
    if path.suffix.lower() == ".md":
        text = "```mermaid\n" + text + "```\n"
    write_atomically(path, text, durable=False)
    return path
