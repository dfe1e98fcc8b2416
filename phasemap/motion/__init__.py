"""motion: trajectories in time and phase curves.

``integrate`` (the compiled integrator, its methods and the fate driver), ``simulate``
(one motion as a Dataset), ``phase`` (phase curves from first integrals) and
``workprecision`` (error against run time).
"""
