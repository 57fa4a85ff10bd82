"""The application layer: files in, the pure core, files out; typed results.

The one layer that combines :mod:`terrain_odom.io`, the core
(:mod:`~terrain_odom.kinematics`, :mod:`~terrain_odom.estimation`,
:mod:`~terrain_odom.vision`, :mod:`~terrain_odom.evaluation`,
:mod:`~terrain_odom.fitting`) and :mod:`terrain_odom.reporting`. Each
function is what one subcommand of the command line runs, and a plain Python
API (usable from a notebook).
"""
