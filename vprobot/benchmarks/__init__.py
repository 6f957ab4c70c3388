"""Benchmarks of vprobot's speed and quality targets (`vprobot benchmark ...`)."""
