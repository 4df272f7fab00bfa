"""The inspection report: per visit, what was found where and the verdict on each expected object.

It is built visit by visit (a visit listener of the patrol machine), so a run cut short by Ctrl-C still
reports every visit it finished. Written as JSON (for programs) and Markdown (for people), atomically.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from navigation.tasks import Visit
from navigation.world import World
from strictio import write_atomically

from .mission import Mission
from .verdict import NOT_CHECKED, Found, Verdict, judge, merge


class InspectionReport:
    """Collects visits; ``objects`` holds each expected object's latest checked verdict."""

    def __init__(self, mission: Mission, reference: World, sources: dict[str, str]) -> None:
        self.mission = mission
        self.reference = reference
        self.sources = sources
        self.visits: list[dict[str, Any]] = []
        self.found: list[tuple[int, Found]] = []
        self.objects: dict[str, tuple[int, Verdict]] = {}

    def add_visit(self, visit: Visit) -> None:
        """Judge one finished visit and keep its record."""
        found = merge(visit.data.get("sightings", []))
        expected = self.mission.expected[visit.pose_index]
        verdicts = judge(expected, found, self.reference, visit.data.get("looked_for", set()))
        self.found += [(visit.number, f) for f in found]
        for v in verdicts:
            if v.status != NOT_CHECKED or v.name not in self.objects:
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

    def to_dict(self, summary: dict[str, Any] | None = None) -> dict[str, Any]:
        return {
            **self.sources,
            "outcome": (summary or {}).get("outcome"),
            "summary": summary or {},
            "objects": {name: {"status": v.status, "visit": n, "error_m": v.as_dict()["error_m"],
                               "found": v.found.as_dict() if v.found else None}
                        for name, (n, v) in self.objects.items()},
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
        lines += ["", "## Expected objects", "", "| object | status | found at (x, y, z) | error | visit |",
                  "|---|---|---|---|---|"]
        for name, (n, v) in self.objects.items():
            lines.append(f"| {name} | {_status(v.status)} | {_where(v.found)} | {_error(v)} | {n} |")
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
                lines += ["", "| expected | status | error |", "|---|---|---|"]
                lines += [f"| {e['name']} | {_status(e['status'])} | "
                          f"{'-' if e['error_m'] is None else format(e['error_m'], '.2f') + ' m'} |"
                          for e in rec["expected"]]
        return "\n".join(lines) + "\n"

    def write(self, folder: Path, summary: dict[str, Any] | None, picture: str | None) -> list[Path]:
        """``report.json`` and ``report.md`` in ``folder``."""
        paths = [folder / "report.json", folder / "report.md"]
        write_atomically(paths[0], json.dumps(self.to_dict(summary), indent=2) + "\n")
        write_atomically(paths[1], self.markdown(summary, picture))
        return paths


def _status(status: str) -> str:
    return {"present": "present", "absent": "**ABSENT**", "moved": "**MOVED**"}.get(status, status.replace("_", " "))


def _where(found: Found | None) -> str:
    return "-" if found is None else f"{found.x:.2f}, {found.y:.2f}, {found.z:.2f}"


def _error(v: Verdict) -> str:
    return "-" if v.error is None else f"{v.error:.2f} m"
