"""Reinforcement-learning agents as planners use them: loading a trained run, encoders, feature
extractors and the candidate Q-network (training them: `vprobot.training`)."""
