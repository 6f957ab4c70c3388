"""The inspection cell in MuJoCo: the compiled cell (`scene`), its own check and
clearances (`check`), whether a part fits it (`fit`) and the ray-cast sensor
(`sensor`).
"""
