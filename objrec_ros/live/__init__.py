"""Live ROS 1 and ROS 2 topics in and out, with no ROS installation: see :mod:`objrec_ros.live.transport`.

Transports are plug-ins of the ``objrec.transports`` entry-point group (``ros1``, ``ros2``), loaded only when
a spec names one, so a run that reads files never imports cyclonedds or opens a socket.
"""

from __future__ import annotations

from collections.abc import Mapping

from declare.registry import PluginError, Registry

from .transport import LiveError, LiveMessage, LiveTopic, Publisher, Subscription, Transport


def _validate(name: str, obj: object) -> type[Transport]:
    if not (isinstance(obj, type) and issubclass(obj, Transport)):
        raise PluginError(f"transport {name}: {obj!r} is not a Transport subclass")
    return obj


#: The installed transports by scheme.
TRANSPORTS: Registry[type[Transport]] = Registry("objrec.transports", "transport", validate=_validate,
                                                name_of=lambda t: t.scheme)


def open_transport(scheme: str, options: Mapping[str, str] | None = None, node_name: str = "objrec") -> Transport:
    """Join a live system through the transport named ``scheme`` (``ros1``, ``ros2``)."""
    return TRANSPORTS.get(scheme).open(options or {}, node_name)


__all__ = ["TRANSPORTS", "LiveError", "LiveMessage", "LiveTopic", "Publisher", "Subscription", "Transport",
           "open_transport"]
