"""The studies behind knowing when to stop: they run planners and evaluations, so they sit above
both, apart from the stop rules and the estimate that planners use (`vprobot.stopping`).

`dataset` rolls out model-free planners for the features and the true coverage after each view;
`report` fits the coverage estimate on them (`vprobot stop fit`) and scores it (`vprobot stop
error`), with the leave-one-family-out fits of `folds` and the checks of `calibration` that the
stated uncertainty matches the observed error; `study` runs every stop rule with every planner
(`vprobot stop study`).
"""
