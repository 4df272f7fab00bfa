"""navigation: the patrol state machine against a built-in 2D simulator.

ROS map_server maps (:mod:`navigation.maps`), the goal-pose file (:mod:`navigation.poses`), a simulated
TurtleBot 2 with move_base-like planning and following, Kobuki and laptop batteries, a docking station,
and the smach patrol machine rebuilt with ``transitions`` (:mod:`navigation.patrol`). The command is
``objrec-patrol`` (:mod:`navigation.cli`). It imports nothing from the recognition packages.
"""
