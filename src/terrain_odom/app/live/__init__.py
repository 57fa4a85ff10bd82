"""Odometry on a live robot, middleware-free: the core of ``terrain-odom-ros`` (docs/ros.md).

:mod:`.build` makes a :class:`~.odometry.LiveOdometry` from a configuration
file (:func:`~.build.build_live`); :mod:`.odometry` holds the ordering
policy (the time-ordered buffer, rows, late and jumped-back messages, the
counts); :mod:`.convert` turns a message of a role into stamped values with
``import``'s streams; :mod:`.frame_worker` classifies camera frames on a
thread of their own; :mod:`.options` names the topics and the policy's
options, :mod:`.output` what is published after each row. Nothing is
imported here.
"""
