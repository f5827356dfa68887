"""trioct: ray and shape queries against trioctd, the collision-query daemon, from Python.

A thin layer over libtrioct (the C client library, loaded with ctypes): numpy arrays in
and out, batches of any length, failures raised as trioct.Error subclasses carrying the
status of the shared table. docs/python.md is the tour.

    import numpy as np, trioct
    with trioct.connect() as c:                     # $LCM_DEFAULT_URL, else LCM's default
        r = c.rays("yard", origins=[0, 0, 50], dirs=[[0, 0, -1], [0.1, 0, -1]])
        print(r.t, r.point, r.normal)               # NaN where a ray missed
"""

from . import _constants, _lib
from .client import (Client, ClearanceResult, DaemonStatus, DistanceResult, RayResult, ShapeDistanceResult, WorldInfo,
                     connect)
from .errors import BadReply, DaemonError, Error, NoReply, Status, TransportError, status_name, status_text

__version__ = _constants.VERSION

#: The file of the libtrioct the package loaded (what the dynamic loader mapped).
library_path = _lib.path

#: The per-request caps the package splits batches under (trioct_limits.h).
MAX_RAYS = _lib.MAX_RAYS
MAX_POSES = _lib.MAX_POSES
MAX_POINTS = _lib.MAX_POINTS

__all__ = ["connect", "Client", "RayResult", "DistanceResult", "ShapeDistanceResult", "ClearanceResult", "WorldInfo", "DaemonStatus", "Error", "DaemonError", "NoReply",
           "TransportError", "BadReply", "Status", "status_name", "status_text", "library_path", "MAX_RAYS",
           "MAX_POSES", "MAX_POINTS", "__version__"]
