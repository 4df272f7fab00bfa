"""The ROS 1 message types the patrol speaks with a live robot, in one typestore.

rosbags' ROS 1 (Noetic) store knows ``actionlib_msgs``, ``geometry_msgs``, ``nav_msgs`` and ``sensor_msgs`` but
not the action messages of ``move_base`` (``move_base_msgs``) or of the Kobuki's auto-docking
(``kobuki_msgs/AutoDocking``, the TurtleBot 2's ``dock_drive_action``), nor the Kobuki's core sensor state
(``kobuki_msgs/SensorState``, which carries the battery voltage). Their definitions are written here as the
``.msg`` files that ``genaction`` derives from each ``.action`` file (comments dropped: they do not count for the
md5sum), and registered with :func:`objrec_ros.msgdefs.register_definitions`. A test proves the md5sums equal
those of Debian's ``python3-move-base-msgs`` (rospy checks them on every connection) and kobuki_msgs' published
ones.
"""

from __future__ import annotations

import functools

from rosbags.typesys.store import Typestore

from objrec_ros.msgdefs import register_definitions, standard_typestore

GOAL_ID = "actionlib_msgs/msg/GoalID"
GOAL_STATUS_ARRAY = "actionlib_msgs/msg/GoalStatusArray"
POSE_WITH_COVARIANCE_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
BATTERY_STATE = "sensor_msgs/msg/BatteryState"

MOVE_BASE_ACTION = "move_base_msgs/msg/MoveBase"
AUTO_DOCKING_ACTION = "kobuki_msgs/msg/AutoDocking"


def _action_definitions(action: str, goal: str, result: str, feedback: str) -> dict[str, str]:
    """The six messages genaction makes of one ``.action`` file (``pkg/msg/Name``): goal, result, feedback
    and their Action* envelopes with header, goal id or status."""
    name = action.rpartition("/msg/")[2]
    return {
        f"{action}Goal": goal,
        f"{action}Result": result,
        f"{action}Feedback": feedback,
        f"{action}ActionGoal": f"Header header\nactionlib_msgs/GoalID goal_id\n{name}Goal goal\n",
        f"{action}ActionResult": f"Header header\nactionlib_msgs/GoalStatus status\n{name}Result result\n",
        f"{action}ActionFeedback": f"Header header\nactionlib_msgs/GoalStatus status\n{name}Feedback feedback\n",
    }


#: move_base_msgs/MoveBase.action: goal ``target_pose``, no result fields, feedback ``base_position``.
MOVE_BASE_DEFINITIONS = _action_definitions(
    MOVE_BASE_ACTION, "geometry_msgs/PoseStamped target_pose\n", "", "geometry_msgs/PoseStamped base_position\n")

#: kobuki_msgs/AutoDocking.action: an empty goal, result ``text``, feedback ``state`` and ``text``.
AUTO_DOCKING_DEFINITIONS = _action_definitions(
    AUTO_DOCKING_ACTION, "", "string text\n", "string state\nstring text\n")


#: kobuki_msgs/SensorState: the Kobuki's core sensors (``/mobile_base/sensors/core``), with the battery voltage in
#: 0.1 V and the charger's state. Its constants count for the md5sum, so they are all here, in their order.
SENSOR_STATE = "kobuki_msgs/msg/SensorState"
_SENSOR_STATE_CONSTANTS = (
    ("BUMPER_RIGHT", 1), ("BUMPER_CENTRE", 2), ("BUMPER_LEFT", 4), ("WHEEL_DROP_RIGHT", 1), ("WHEEL_DROP_LEFT", 2),
    ("CLIFF_RIGHT", 1), ("CLIFF_CENTRE", 2), ("CLIFF_LEFT", 4), ("BUTTON0", 1), ("BUTTON1", 2), ("BUTTON2", 4),
    ("DISCHARGING", 0), ("DOCKING_CHARGED", 2), ("DOCKING_CHARGING", 6), ("ADAPTER_CHARGED", 18),
    ("ADAPTER_CHARGING", 22), ("OVER_CURRENT_LEFT_WHEEL", 1), ("OVER_CURRENT_RIGHT_WHEEL", 2),
    ("OVER_CURRENT_BOTH_WHEELS", 3), ("DIGITAL_INPUT0", 1), ("DIGITAL_INPUT1", 2), ("DIGITAL_INPUT2", 4),
    ("DIGITAL_INPUT3", 8), ("DB25_TEST_BOARD_CONNECTED", 64))
_CONSTANT_LINES = "".join(f"uint8 {name}={value}\n" for name, value in _SENSOR_STATE_CONSTANTS)
SENSOR_STATE_DEFINITIONS = {SENSOR_STATE: _CONSTANT_LINES + (
    "Header header\nuint16 time_stamp\nuint8 bumper\nuint8 wheel_drop\nuint8 cliff\nuint16 left_encoder\n"
    "uint16 right_encoder\nint8 left_pwm\nint8 right_pwm\nuint8 buttons\nuint8 charger\nuint8 battery\n"
    "uint16[] bottom\nuint8[] current\nuint8 over_current\nuint16 digital_input\nuint16[] analog_input\n")}
#: SensorState.charger values: on the dock or the adapter, charging or charged.
KOBUKI_CHARGING = (6, 22)
KOBUKI_CHARGED = (2, 18)


def action_types(action: str) -> tuple[str, str]:
    """The ActionGoal and ActionResult types of an action (``move_base_msgs/msg/MoveBase``)."""
    return f"{action}ActionGoal", f"{action}ActionResult"


@functools.cache
def _patrol_typestore() -> Typestore:
    store = standard_typestore(1)
    for action, definitions in ((MOVE_BASE_ACTION, MOVE_BASE_DEFINITIONS),
                                (AUTO_DOCKING_ACTION, AUTO_DOCKING_DEFINITIONS)):
        register_definitions(store, f"{action}ActionGoal", definitions)  # all six at once
    register_definitions(store, SENSOR_STATE, SENSOR_STATE_DEFINITIONS)
    return store


def patrol_typestore() -> Typestore:
    """A ROS 1 typestore with the standard types plus move_base's and the Kobuki's auto-docking action types
    and the Kobuki's SensorState (built once; read-only afterwards, so the transport's threads may share it)."""
    return _patrol_typestore()
