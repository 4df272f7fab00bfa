"""The ROS 1 test environment itself: a real master comes up on loopback and a rospy node talks to it."""

from __future__ import annotations

from pathlib import Path

from tests.ros.live import ros1_env
from tests.ros.live.ros1_env import Ros1Master, RospyNode

ros1_master = ros1_env.ros1_master  # the fixture, used by name

_TALKER = """
import sys
import rospy
from std_msgs.msg import String
rospy.init_node("env_talker", anonymous=True, disable_signals=True)
pub = rospy.Publisher(sys.argv[1], String, queue_size=1)
print("ready", rospy.get_name(), flush=True)
rospy.spin()
"""


def test_master_answers_and_lists_a_rospy_publisher(ros1_master: Ros1Master, tmp_path: Path) -> None:
    assert ros1_master.uri.startswith("http://127.0.0.1:")
    with RospyNode.start(_TALKER, ros1_master, tmp_path, args=["/env_check"], name="talker") as node:
        ready = node.wait_for("ready")
        assert ready is not None, node.diagnostics()
        node_name = ready.split()[1]
        publishers = dict((name, members) for name, members in ros1_master.system_state()[0])
        assert publishers["/env_check"] == [node_name]
    assert node.process.returncode is not None
