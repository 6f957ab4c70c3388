"""Knowing when to stop without the model: a model-free coverage estimate with its uncertainty.

`features` states what a real cell knows after each view; `estimator` maps it to an estimate of
the current coverage (mean and standard deviation), learned in simulation where the coverage is
known (`dataset`, `report`); `calibration` checks that the stated uncertainty matches the
observed error.
"""
