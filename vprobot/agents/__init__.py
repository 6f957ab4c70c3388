"""Reinforcement-learning agents: point-cloud feature extractors, profiles, training."""
