"""Programs and trajectories a cell runs, made from a plan JSON, and the replay check that
holds them to the cell's limits (docs/motion.md#export).

One module per format in `formats`, registered in `formats.FORMATS`; `formats.export_plan`
writes any of them. This module holds only what the command line needs before it runs one (no
heavy imports).
"""

from __future__ import annotations

EXPORT_DT_S = 0.008
"""Default sampling step of the exported trajectories (s): 125 Hz, the rate of the UR's
controller and a common one of ROS 2 controllers."""
CHECK_DT_S = 0.002
"""Default replay step of the check (s): four times finer than the exported files'."""
