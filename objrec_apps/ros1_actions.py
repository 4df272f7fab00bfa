"""An actionlib client over plain topics: what ``actionlib.SimpleActionClient`` does, without rospy.

An action server ``NS`` (``/move_base``, ``/dock_drive_action``) listens on ``NS/goal`` (``<Action>ActionGoal``)
and ``NS/cancel`` (``actionlib_msgs/GoalID``) and reports on ``NS/status`` (``actionlib_msgs/GoalStatusArray``,
every goal it tracks, a few times a second) and ``NS/result`` (``<Action>ActionResult``, once per goal). Goals
carry ids unique to this client (``CALLER-N-SECONDS``, actionlib's form). A goal's end is taken from its result,
or from a terminal status in a status array when the result was lost (the transport keeps only the newest
message of a topic). actionlib's ten statuses map onto the patrol's three outcomes in :data:`TERMINAL`.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Callable, Mapping
from typing import Any

from rosbags.typesys.store import Typestore

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


class ActionClient:
    """Goals to one action server; each goal's ``on_done(status, text)`` runs once, on the clock's thread."""

    def __init__(self, transport: Transport, namespace: str, action: str, typestore: Typestore, clock: WallClock,
                 caller_id: str) -> None:
        self.namespace = namespace.rstrip("/") or "/"
        self.action = action
        self._typestore = typestore
        self._goal_type, result_type = action_types(action)
        self._caller_id = caller_id
        self._ids = itertools.count(1)
        self._pending: dict[str, DoneCallback] = {}
        self.server_seen = False
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

    def send(self, goal: Mapping[str, Any], on_done: DoneCallback) -> str:
        """Publish a goal (the fields of ``<Action>Goal`` as a dict); returns its id."""
        now = time.time()
        goal_id = f"{self._caller_id}-{next(self._ids)}-{now:.3f}"
        message = message_from_dict(self._typestore, self._goal_type, {
            "header": {"stamp": now}, "goal_id": {"stamp": now, "id": goal_id}, "goal": dict(goal)})
        self._pending[goal_id] = on_done
        self._goals.publish(bytes(self._typestore.serialize_ros1(message, self._goal_type)))
        log.debug("%s: goal %s sent", self.namespace, goal_id)
        return goal_id

    def cancel(self, goal_id: str) -> None:
        """Ask the server to cancel ``goal_id``; its result is no longer reported to the caller."""
        self._pending.pop(goal_id, None)
        message = message_from_dict(self._typestore, GOAL_ID, {"stamp": 0.0, "id": goal_id})
        self._cancel.publish(bytes(self._typestore.serialize_ros1(message, GOAL_ID)))
        log.debug("%s: goal %s cancelled", self.namespace, goal_id)

    def _on_status(self, message: Any) -> None:
        self.server_seen = True
        for status in message.status_list:
            if status.goal_id.id in self._pending and status.status in TERMINAL:
                self._done(status.goal_id.id, status.status, status.text)

    def _on_result(self, message: Any) -> None:
        status = message.status
        if status.goal_id.id in self._pending:
            if status.status in TERMINAL:
                self._done(status.goal_id.id, status.status, status.text)
            else:
                log.warning("%s: result of goal %s with a status that is not final: %s", self.namespace,
                            status.goal_id.id, ACTIONLIB_STATUS.get(status.status, status.status))

    def _done(self, goal_id: str, code: int, text: str) -> None:
        on_done = self._pending.pop(goal_id)
        name = ACTIONLIB_STATUS[code]
        log.info("%s: goal %s %s %s", self.namespace, goal_id, name, text)
        on_done(TERMINAL[code], text or f"{name.lower()} ({self.namespace})")

    def close(self) -> None:
        for feed in self._feeds:
            feed.close()
