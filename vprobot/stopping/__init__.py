"""Knowing when to stop without the model: the stop rules and the model-free coverage estimate.

`rules` holds the stop rules any planner can use; `features` states what a real cell knows after
each view; `estimator` maps it to an estimate of the current coverage (mean and standard
deviation), learned in simulation where the coverage is known. The studies that fit the estimate
and compare the rules run planners, and live above them (`vprobot.stop_studies`).
"""
