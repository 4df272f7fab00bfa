"""An actionlib client over plain topics: what ``actionlib.SimpleActionClient`` does, without rospy.

An action server ``NS`` (``/move_base``, ``/dock_drive_action``) listens on ``NS/goal`` (``<Action>ActionGoal``)
and ``NS/cancel`` (``actionlib_msgs/GoalID``) and reports on ``NS/status`` (``actionlib_msgs/GoalStatusArray``,
every goal it tracks, a few times a second) and ``NS/result`` (``<Action>ActionResult``, once per goal). Goals
carry ids unique to this client (``CALLER-N-SECONDS``, actionlib's form). A goal's end is taken from its result,
or from a terminal status in a status array when the result was lost (the transport keeps only the newest
message of a topic): a terminal status ends a goal only after ``RESULT_GRACE_SECONDS`` without its result, since
the result, sent at the same moment, may arrive after the next status array and it alone carries the server's
text. actionlib's ten statuses map onto the patrol's three outcomes in :data:`TERMINAL`.

Every wait has a deadline. A goal that no status and no result names within ``ack_seconds`` of being sent was
never acknowledged (a hung or restarting server that still holds the topics): it ends ABORTED with that reason,
and a cancel for it is published, so that a server which takes it late recalls it as actionlib's server does
with a cancel that came before its goal. A goal the server acknowledged ends ABORTED when the server then says
nothing on its status topic for ``silence_seconds`` (actionlib publishes the status a few times a second, goals
or not). Either way the caller hears an aborted goal and goes on as it does for one move_base aborted.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from rosbags.typesys.store import Typestore

from navigation.clock import Timer
from navigation.move_base import GoalStatus
from objrec_ros.live import Transport
from objrec_ros.msgdefs import message_from_dict

from .ros1_clock import WallClock
from .ros1_feed import TopicFeed
from .ros1_messages import GOAL_ID, GOAL_STATUS_ARRAY, action_types

log = logging.getLogger(__name__)

#: actionlib_msgs/GoalStatus values by name.
ACTIONLIB_STATUS = {0: "PENDING", 1: "ACTIVE", 2: "PREEMPTED", 3: "SUCCEEDED", 4: "ABORTED", 5: "REJECTED",
                    6: "PREEMPTING", 7: "RECALLING", 8: "RECALLED", 9: "LOST"}
#: The terminal statuses and the patrol's outcome for each: a goal the server refused (REJECTED) or lost could
#: not be reached (ABORTED); one cancelled before it started (RECALLED) was preempted.
TERMINAL = {2: GoalStatus.PREEMPTED, 3: GoalStatus.SUCCEEDED, 4: GoalStatus.ABORTED, 5: GoalStatus.ABORTED,
            8: GoalStatus.PREEMPTED, 9: GoalStatus.ABORTED}

DoneCallback = Callable[[GoalStatus, str], None]

#: Seconds a goal may go unacknowledged, and an acknowledged goal's server may stay silent, by default.
DEFAULT_ACK_SECONDS = 5.0
DEFAULT_SILENCE_SECONDS = 10.0
#: How often the status silence of a running goal is checked (seconds).
SILENCE_CHECK_PERIOD = 0.25
#: Seconds a goal whose status is terminal waits for its result before it ends on the status alone: a server
#: publishes both at once, but the status array (10 Hz) may overtake the result, and a goal ended on the status
#: lost the server's text ("goal reached" became "succeeded (/move_base)").
RESULT_GRACE_SECONDS = 0.5


@dataclass
class _PendingGoal:
    """A goal sent and not yet ended: whom to tell, what to call it in a reason, whether the server named it."""

    on_done: DoneCallback
    label: str
    acknowledged: bool = False
    ack_timer: Timer | None = None
    result_timer: Timer | None = None  # a terminal status came: the goal ends on it unless the result follows


class ActionClient:
    """Goals to one action server; each goal's ``on_done(status, text)`` runs once, on the clock's thread.

    ``server`` is what a reason calls the server (``move_base``); ``ack_seconds`` and ``silence_seconds`` are the
    deadlines of the module's docstring."""

    def __init__(self, transport: Transport, namespace: str, action: str, typestore: Typestore, clock: WallClock,
                 caller_id: str, server: str = "", ack_seconds: float = DEFAULT_ACK_SECONDS,
                 silence_seconds: float = DEFAULT_SILENCE_SECONDS) -> None:
        self.namespace = namespace.rstrip("/") or "/"
        self.action = action
        self.server = server or f"the action server {self.namespace}"
        self.ack_seconds = ack_seconds
        self.silence_seconds = silence_seconds
        self._clock = clock
        self._typestore = typestore
        self._goal_type, result_type = action_types(action)
        self._caller_id = caller_id
        self._ids = itertools.count(1)
        self._pending: dict[str, _PendingGoal] = {}
        self._silence_watch: Timer | None = None
        self._status_at = -float("inf")  # clock time of the last status message
        self.server_seen = False
        self.statuses = 0  # status messages heard
        ns = self.namespace
        self._goals = transport.advertise(f"{ns}/goal", self._goal_type, typestore)
        self._cancel = transport.advertise(f"{ns}/cancel", GOAL_ID, typestore)
        status = transport.subscribe(f"{ns}/status", GOAL_STATUS_ARRAY, typestore, reliable=True)
        result = transport.subscribe(f"{ns}/result", result_type, typestore, reliable=True)
        self._feeds = [
            TopicFeed(status, lambda raw: typestore.deserialize_ros1(raw, GOAL_STATUS_ARRAY), self._on_status, clock),
            TopicFeed(result, lambda raw: typestore.deserialize_ros1(raw, result_type), self._on_result, clock),
        ]

    @property
    def connected(self) -> bool:
        """The server reports its status and listens to our goals (what ``wait_for_server`` waits for)."""
        return self.server_seen and self._goals.subscribers > 0

    def send(self, goal: Mapping[str, Any], on_done: DoneCallback, label: str = "") -> str:
        """Publish a goal (the fields of ``<Action>Goal`` as a dict); returns its id. ``label`` names it in the
        reason of a missed deadline (``goal 3 (POSE_2)``)."""
        now = time.time()
        goal_id = f"{self._caller_id}-{next(self._ids)}-{now:.3f}"
        message = message_from_dict(self._typestore, self._goal_type, {
            "header": {"stamp": now}, "goal_id": {"stamp": now, "id": goal_id}, "goal": dict(goal)})
        pending = _PendingGoal(on_done, label or f"goal {goal_id}")
        self._pending[goal_id] = pending
        pending.ack_timer = self._clock.call_later(self.ack_seconds, lambda: self._unacknowledged(goal_id))
        self._goals.publish(bytes(self._typestore.serialize_ros1(message, self._goal_type)))
        log.debug("%s: goal %s sent", self.namespace, goal_id)
        return goal_id

    def cancel(self, goal_id: str) -> None:
        """Ask the server to cancel ``goal_id``; its result is no longer reported to the caller."""
        self._forget(goal_id)
        self._publish_cancel(goal_id)
        log.debug("%s: goal %s cancelled", self.namespace, goal_id)

    def _publish_cancel(self, goal_id: str) -> None:
        message = message_from_dict(self._typestore, GOAL_ID, {"stamp": 0.0, "id": goal_id})
        self._cancel.publish(bytes(self._typestore.serialize_ros1(message, GOAL_ID)))

    def _forget(self, goal_id: str) -> _PendingGoal | None:
        pending = self._pending.pop(goal_id, None)
        if pending is not None and pending.ack_timer is not None:
            pending.ack_timer.cancel()
        if pending is not None and pending.result_timer is not None:
            pending.result_timer.cancel()
        if not self._pending and self._silence_watch is not None:
            self._silence_watch.cancel()
            self._silence_watch = None
        return pending

    def _acknowledged(self, goal_id: str) -> None:
        pending = self._pending.get(goal_id)
        if pending is None or pending.acknowledged:
            return
        pending.acknowledged = True
        if pending.ack_timer is not None:
            pending.ack_timer.cancel()
            pending.ack_timer = None
        if self._silence_watch is None:
            self._silence_watch = self._clock.every(SILENCE_CHECK_PERIOD, self._check_silence)

    def _unacknowledged(self, goal_id: str) -> None:
        pending = self._pending.get(goal_id)
        if pending is None or pending.acknowledged:
            return
        self._give_up(goal_id, f"{self.server} did not acknowledge {pending.label} within {self.ack_seconds:g} s: "
                               f"is {self.server} running on {self.namespace}?")

    def _check_silence(self) -> None:
        quiet = self._clock.now - self._status_at
        if quiet < self.silence_seconds:
            return
        for goal_id, pending in list(self._pending.items()):
            if pending.acknowledged:
                self._give_up(goal_id, f"{self.server} went silent: no status on {self.namespace}/status for "
                                       f"{self.silence_seconds:g} s while {pending.label} ran: is {self.server} "
                                       "still running?")

    def _give_up(self, goal_id: str, reason: str) -> None:
        """End a goal whose server missed a deadline: ABORTED with ``reason``, and a cancel for the server."""
        pending = self._forget(goal_id)
        if pending is None:
            return
        self._publish_cancel(goal_id)
        log.warning("%s", reason)
        pending.on_done(GoalStatus.ABORTED, reason)

    def _on_status(self, message: Any) -> None:
        self.server_seen = True
        self.statuses += 1
        self._status_at = self._clock.now
        for status in message.status_list:
            pending = self._pending.get(status.goal_id.id)
            if pending is not None:
                self._acknowledged(status.goal_id.id)
                if status.status in TERMINAL and pending.result_timer is None:
                    pending.result_timer = self._clock.call_later(
                        RESULT_GRACE_SECONDS,
                        lambda gid=status.goal_id.id, code=status.status, text=status.text: self._done(gid, code, text))

    def _on_result(self, message: Any) -> None:
        status = message.status
        if status.goal_id.id in self._pending:
            self._acknowledged(status.goal_id.id)
            if status.status in TERMINAL:
                self._done(status.goal_id.id, status.status, status.text)
            else:
                log.warning("%s: result of goal %s with a status that is not final: %s", self.namespace,
                            status.goal_id.id, ACTIONLIB_STATUS.get(status.status, status.status))

    def _done(self, goal_id: str, code: int, text: str) -> None:
        pending = self._forget(goal_id)
        if pending is None:
            return
        name = ACTIONLIB_STATUS[code]
        log.info("%s: goal %s %s %s", self.namespace, goal_id, name, text)
        pending.on_done(TERMINAL[code], text or f"{name.lower()} ({self.namespace})")

    def close(self) -> None:
        for pending in self._pending.values():
            if pending.ack_timer is not None:
                pending.ack_timer.cancel()
        if self._silence_watch is not None:
            self._silence_watch.cancel()
            self._silence_watch = None
        for feed in self._feeds:
            feed.close()
