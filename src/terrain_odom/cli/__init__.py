"""Command-line interface of terrain-odom (a thin layer over :mod:`terrain_odom.app`)."""
