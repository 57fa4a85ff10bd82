"""The ROS 1 node (``terrain-odom-ros``): the outermost layer, beside the command line."""
