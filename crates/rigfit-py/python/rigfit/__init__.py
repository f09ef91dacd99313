"""rigfit: pose rigged characters from 3D strokes, track articulated bodies and deformable
surfaces through point clouds, and run many takes at once (numpy in and out).

The solvers are Rust (the ``rigfit._rigfit`` extension); this package re-exports them.
``rigfit.cluster`` runs a batch job file on a Dask cluster (``pip install
"distributed==2026.8.0"``); it is imported on demand, not here.
"""

from ._rigfit import *  # noqa: F403  (the extension's public names, listed in __init__.pyi)
from ._rigfit import __version__  # noqa: F401
