"""Evaluation of odometry: windows, model error per metre, ATE, prediction, frame truth.

- :mod:`~terrain_odom.evaluation.windows`: spatial, time and prediction windows.
- :mod:`~terrain_odom.evaluation.metrics`: per-metre window errors, dead
  reckoning, settling time.
- :mod:`~terrain_odom.evaluation.ate`: SE(2) alignment and the absolute trajectory error.
- :mod:`~terrain_odom.evaluation.prediction`: the 2016 paper's prediction error.
- :mod:`~terrain_odom.evaluation.sparse`: windows of positions-only and headings-only rows.
- :mod:`~terrain_odom.evaluation.outage`: dead reckoning through simulated pose outages.
- :mod:`~terrain_odom.evaluation.groundtruth`: scores against a simulated run's truth.
- :mod:`~terrain_odom.evaluation.plausibility`: wheels against poses before estimating.
- :mod:`~terrain_odom.evaluation.mounting`: pose sensors' heading offset and lever arm.
- :mod:`~terrain_odom.evaluation.calibration`: the pose sensors' self-calibration against
  the wheel path (:mod:`~terrain_odom.evaluation.wheel_path`; statistics in
  :mod:`~terrain_odom.evaluation.robust`).
"""

from terrain_odom.evaluation import ate, metrics, outage, plausibility, prediction, sparse, windows
from terrain_odom.evaluation.ate import *  # noqa: F403  (re-exports ate.__all__)
from terrain_odom.evaluation.metrics import *  # noqa: F403  (re-exports metrics.__all__)
from terrain_odom.evaluation.outage import *  # noqa: F403  (re-exports outage.__all__)
from terrain_odom.evaluation.plausibility import *  # noqa: F403  (re-exports plausibility.__all__)
from terrain_odom.evaluation.prediction import *  # noqa: F403  (re-exports prediction.__all__)
from terrain_odom.evaluation.sparse import *  # noqa: F403  (re-exports sparse.__all__)
from terrain_odom.evaluation.windows import *  # noqa: F403  (re-exports windows.__all__)

__all__ = [
    *windows.__all__,
    *metrics.__all__,
    *ate.__all__,
    *prediction.__all__,
    *plausibility.__all__,
    *sparse.__all__,
    *outage.__all__,
]
