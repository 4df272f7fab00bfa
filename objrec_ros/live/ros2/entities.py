"""Deleting DDS entities when objrec is done with them, not when Python's garbage collector gets to them.

cyclonedds deletes an entity (and, for a participant, its sockets and threads) in the Python object's
finalizer; a transport that is closed must let go of the network at once, and in order (readers and writers
before their topics, everything before the participant). Calling the finalizer is cyclonedds' own,
idempotent way of deleting: it removes the entity from its registry, so a later collection does nothing.
"""

from __future__ import annotations

import logging

from cyclonedds.core import DDSException, Entity

log = logging.getLogger(__name__)


def delete_entity(entity: Entity | None) -> None:
    """Delete ``entity`` now (None, or an entity already deleted: nothing happens)."""
    if entity is None:
        return
    try:
        entity.__del__()
    except DDSException as exc:  # already gone with its parent: nothing left to release
        log.debug("deleting %r: %s", entity, exc)
