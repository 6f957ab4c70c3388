"""The parts to inspect as files: loading a mesh (`loading`), its planning copy
(`simplify`), objects made from a seed (`generated`) and the splits (`splits`).
"""
