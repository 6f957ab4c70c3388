"""Geometry without a cell: poses and rotations (`poses`), view directions on a
sphere (`viewsphere`) and the triangle rasterizer (`raster`).
"""
