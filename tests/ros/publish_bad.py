"""A test publisher of bad input for the node (run with Debian's Python, ``rospy``).

On ``WHEELS`` (nav_msgs/Odometry, 100 Hz): 100 good messages, 5 with a NaN
speed, 3 stamped 0.3 s back (late), 3 ``std_msgs/String`` on ``HEADING``
(a wrong type for an Imu topic), then time jumps back 10 s (a looping bag)
and 100 good messages more. Prints ``published`` when done.

Usage: ``python publish_bad.py WHEELS HEADING``.
"""

from __future__ import annotations

import math
import sys
import time

import rospy
from nav_msgs.msg import Odometry
from std_msgs.msg import String


def _odometry(stamp: float, v: float) -> Odometry:
    msg = Odometry()
    msg.header.stamp = rospy.Time.from_sec(stamp)
    msg.twist.twist.linear.x = v
    msg.twist.twist.angular.z = 0.1
    return msg


def main() -> None:
    wheels_topic, heading_topic = sys.argv[1:3]
    rospy.init_node("bad_publisher")
    wheels = rospy.Publisher(wheels_topic, Odometry, queue_size=500)
    heading = rospy.Publisher(heading_topic, String, queue_size=10)
    end = time.monotonic() + 30.0
    while (wheels.get_num_connections() == 0 or heading.get_num_connections() == 0) and (
        time.monotonic() < end
    ):
        time.sleep(0.05)
    time.sleep(0.5)
    t = 1000.0
    for k in range(100):
        t += 0.01
        wheels.publish(_odometry(t, 0.5))
        if k % 20 == 10:  # a NaN speed, on 5 messages
            wheels.publish(_odometry(t + 0.005, math.nan))
        if k in (50, 60, 70):  # late: stamped 0.3 s back
            wheels.publish(_odometry(t - 0.3, 0.5))
        if k in (30, 40, 80):
            heading.publish(String(data="not an Imu"))
        time.sleep(0.01)
    t -= 10.0  # time jumps back
    for _ in range(100):
        t += 0.01
        wheels.publish(_odometry(t, 0.5))
        time.sleep(0.01)
    time.sleep(0.5)
    print("published", flush=True)


if __name__ == "__main__":
    main()
