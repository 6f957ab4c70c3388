"""Reports over committed results (`vprobot report`): the README's tables from evaluation
folders (`tables`), trained agents beside the baselines (`baselines`) and two evaluation tables
compared cell by cell (`compare`, the behaviour-unchanged check)."""
