"""ROS bags, one wing: read, convert, merge, derive the configuration; one pass returns its contents.

:mod:`.reader` opens and streams a bag, :mod:`.messages`, :mod:`.streams`
and :mod:`.frames` convert its messages, :mod:`.log` merges the wheel log,
:mod:`.configuration` derives the configuration the bag gives, and
:func:`.contents.read_bag` returns a :class:`~.contents.BagContents` in one
pass; :mod:`.writer` writes bags (tests, benchmarks). Nothing is imported
here: :mod:`.paths` and :mod:`.options` load without ``rosbags``.
"""
