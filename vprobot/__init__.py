"""vprobot: robot-guided visual inspection planning in MuJoCo."""

__version__ = "0.1.0"
