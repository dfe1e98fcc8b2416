"""maps: points and grids of points.

``classify`` (one state), ``layers`` (the layer registry), ``grid`` (the grid evaluator),
``scene`` (a study's system, axes and layers, computed in blocks) and ``blocks`` (the
estimates, memory checks and block runner behind a scene).
"""
