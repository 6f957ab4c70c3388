"""Programs and trajectories a cell runs, made from a plan JSON, and the replay check that
holds them to the cell's limits (docs/motion.md#export).

One module per format in `formats`, registered in `formats.FORMATS`; `program.export_plan`
writes any of them. This module holds only what the command line needs before it runs one (no
heavy imports).
"""

from __future__ import annotations

EXPORT_DT_S = 0.008
"""Default sampling step of the exported trajectories (s): 125 Hz, the rate of the UR's
controller and a common one of ROS 2 controllers."""
CHECK_DT_S = 0.002
"""Default replay step of the check (s): four times finer than the exported files'."""
MIN_DT_S = 1e-4
"""Finest sampling step of `export` and `check` (s): 10 kHz, ten times a fast controller's
rate; finer steps only multiply the samples (and the check's collision checks)."""
CHECK_MAX_DT_S = EXPORT_DT_S
"""Coarsest replay step of the check (s): the exported files' default step. Divided differences
over coarser samples average the acceleration and the jerk over more of a move and can pass
a trajectory over the limits."""
