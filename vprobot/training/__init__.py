"""Training agents and measuring them: the RL loop (`train`), the teacher's data and the
imitation it fits (`teacher`, `pretrain`, `stream`), evaluations during training
(`evaluation`, `callbacks`), run folders (`runs`), seeds, sweeps and curves.

It sits above the planners, which it runs; `vprobot.agents` (below them) loads and runs a
trained policy.
"""
