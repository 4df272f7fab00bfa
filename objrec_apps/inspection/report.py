"""The inspection report: per visit, what was found where and the verdict on each expected object.

It is built visit by visit (a visit listener of the patrol machine), so a run cut short by Ctrl-C still
reports every visit it finished. Written as JSON (for programs) and Markdown (for people), atomically.

Every expected object of the mission is in the report from the start, ``not_checked`` until a visit judges it,
so a run cut short (a goal aborted, ``stop_on_failure``, Ctrl-C, a time limit, a monitor) still lists it, with
why it was not checked; the JSON and the Markdown are made from the same verdicts (:meth:`verdicts`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from navigation.tasks import Visit
from navigation.world import World
from strictio import write_atomically

from .mission import Mission
from .verdict import NOT_CHECKED, Found, Verdict, centre_of, judge, merge


class InspectionReport:
    """Collects visits; ``objects`` holds every expected object's latest checked verdict (visit ``None``: the
    object's pose was never visited)."""

    def __init__(self, mission: Mission, reference: World, sources: dict[str, str]) -> None:
        self.mission = mission
        self.reference = reference
        self.sources = sources
        self.visits: list[dict[str, Any]] = []
        self.found: list[tuple[int, Found]] = []
        self.objects: dict[str, tuple[int | None, Verdict]] = {}
        for row in mission.expected:
            for e in row:
                if e.name not in self.objects:
                    self.objects[e.name] = (None, Verdict(e.name, e.label, NOT_CHECKED, centre_of(reference, e.name),
                                                          e.tolerance, reason=NOT_VISITED))

    def add_visit(self, visit: Visit) -> None:
        """Judge one finished visit and keep its record."""
        found = merge(visit.data.get("sightings", []))
        expected = self.mission.expected[visit.pose_index]
        verdicts = [v.with_reason(_unchecked_why(visit, v.label)) if v.status == NOT_CHECKED else v
                    for v in judge(expected, found, self.reference, visit.data.get("looked_for", set()))]
        self.found += [(visit.number, f) for f in found]
        for v in verdicts:
            if v.status != NOT_CHECKED or v.name not in self.objects or self.objects[v.name][1].status == NOT_CHECKED:
                self.objects[v.name] = (visit.number, v)
        self.visits.append({
            "visit": visit.number, "pose": visit.name, "index": visit.pose_index, "lap": visit.lap,
            "goal": visit.goal.as_dict(), "goal_status": visit.goal_status or "none",
            "arrived": visit.arrived.as_dict() if visit.arrived else None,
            "started_s": round(visit.started, 2), "ended_s": None if visit.ended is None else round(visit.ended, 2),
            "tasks": [{"state": t.state.rsplit(".", 1)[-1], "task": t.kind, "status": t.status, "text": t.text}
                      for t in visit.tasks],
            "found": [f.as_dict() for f in found],
            "expected": [v.as_dict() for v in verdicts],
            "photos": list(visit.data.get("photos", [])),
        })

    def verdicts(self, summary: dict[str, Any] | None = None) -> dict[str, tuple[int | None, Verdict]]:
        """Every expected object's verdict; one whose pose was never visited says why (how the run ended)."""
        why = self._unvisited_why(summary or {})
        return {name: (n, v.with_reason(why) if n is None else v) for name, (n, v) in self.objects.items()}

    def _unvisited_why(self, summary: dict[str, Any]) -> str:
        last = self.visits[-1] if self.visits else None
        if self.mission.stop_on_failure and last is not None and _failure(last):
            return f"mission stopped after visit {last['visit']} ({_failure(last)}; stop_on_failure)"
        outcome = summary.get("outcome")
        if outcome is None:
            return NOT_VISITED
        reason = f": {summary['reason']}" if summary.get("reason") else ""
        return f"run ended ({outcome}{reason}) before its pose was visited"

    def to_dict(self, summary: dict[str, Any] | None = None) -> dict[str, Any]:
        return {
            **self.sources,
            "outcome": (summary or {}).get("outcome"),
            "summary": summary or {},
            "objects": {name: {"status": v.status, "visit": n, "error_m": v.as_dict()["error_m"],
                               "found": v.found.as_dict() if v.found else None, "reason": v.reason}
                        for name, (n, v) in self.verdicts(summary).items()},
            "visits": self.visits,
        }

    def markdown(self, summary: dict[str, Any] | None = None, picture: str | None = None) -> str:
        s = summary or {}
        lines = ["# Inspection report", "",
                 f"Mission `{self.sources.get('mission', '')}` on map `{self.sources.get('map', '')}`, world "
                 f"`{self.sources.get('world', '')}`."]
        for change in self.sources.get("changes", []):
            lines.append(f"Simulated with a change to the world: {change}.")
        if s:
            reason = f" ({s['reason']})" if s.get("reason") else ""
            lines += ["", f"Outcome: **{s.get('outcome')}**{reason} after {s.get('sim_time_s')} s simulated; "
                          f"{s.get('goals_reached')} goals reached, {s.get('goals_aborted')} aborted; "
                          f"{s.get('distance_m')} m driven; {s.get('collisions')} collisions."]
        lines += ["", "## Expected objects", "", "| object | status | found at (x, y, z) | error | visit | why |",
                  "|---|---|---|---|---|---|"]
        for name, (n, v) in self.verdicts(summary).items():
            lines.append(f"| {name} | {_status(v.status)} | {_where(v.found)} | {_error(v)} | "
                         f"{'-' if n is None else n} | {v.reason or '-'} |")
        if picture:
            lines += ["", f"![the map with the route, the objects found and the missing ones]({picture})"]
        lines += ["", "## Visits"]
        for rec in self.visits:
            lines += ["", f"### Visit {rec['visit']}: {rec['pose']} (lap {rec['lap']}), goal {rec['goal_status']}"]
            items = [f"- {t['state']}: {t['status']}" + (f" ({t['text']})" if t["text"] else "") for t in rec["tasks"]]
            items += [f"- photo: [{p}](photos/{p})" for p in rec["photos"]]
            lines += ["", *items] if items else []
            if rec["found"]:
                lines += ["", "| found | x | y | z | placed by | sightings |", "|---|---|---|---|---|---|"]
                lines += [f"| {f['name']} | {f['x']:.2f} | {f['y']:.2f} | {f['z']:.2f} | {f['method']} | "
                          f"{f['sightings']} |" for f in rec["found"]]
            if rec["expected"]:
                lines += ["", "| expected | status | error | why |", "|---|---|---|---|"]
                lines += [f"| {e['name']} | {_status(e['status'])} | "
                          f"{'-' if e['error_m'] is None else format(e['error_m'], '.2f') + ' m'} | "
                          f"{e['reason'] or '-'} |" for e in rec["expected"]]
        return "\n".join(lines) + "\n"

    def write(self, folder: Path, summary: dict[str, Any] | None, picture: str | None) -> list[Path]:
        """``report.json`` and ``report.md`` in ``folder``."""
        paths = [folder / "report.json", folder / "report.md"]
        write_atomically(paths[0], json.dumps(self.to_dict(summary), indent=2) + "\n")
        write_atomically(paths[1], self.markdown(summary, picture))
        return paths


#: The reason of an expected object whose pose no visit has reached yet.
NOT_VISITED = "its pose was not visited"


def _unchecked_why(visit: Visit, label: str) -> str:
    """Why a visit did not check an object: its goal not reached, a task that did not succeed, or no detection
    at the pose looks for the object's label."""
    if not visit.reached:
        return f"goal {(visit.goal_status or 'not reached').lower()} at {visit.name}"
    failed = next((t for t in visit.tasks if t.status != "succeeded"), None)
    if failed is not None:
        return f"{failed.kind} task {failed.status} at {visit.name}" + (f" ({failed.text})" if failed.text else "")
    return f"no detection at {visit.name} looks for {label!r}"


def _failure(record: dict[str, Any]) -> str:
    """What failed at a recorded visit (its goal or a task), or ''."""
    if record["goal_status"] != "SUCCEEDED":
        return f"goal {record['goal_status'].lower()} at {record['pose']}"
    failed = next((t for t in record["tasks"] if t["status"] != "succeeded"), None)
    return "" if failed is None else f"{failed['task']} task {failed['status']} at {record['pose']}"


def _status(status: str) -> str:
    return {"present": "present", "absent": "**ABSENT**", "moved": "**MOVED**"}.get(status, status.replace("_", " "))


def _where(found: Found | None) -> str:
    return "-" if found is None else f"{found.x:.2f}, {found.y:.2f}, {found.z:.2f}"


def _error(v: Verdict) -> str:
    return "-" if v.error is None else f"{v.error:.2f} m"
