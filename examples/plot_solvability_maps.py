"""
Solvability maps of every built-in system
=========================================

How many motions do the equations allow at each state? One map per
registered system, over its default axes (``model.default_axes``, what
``phasemap atlas MODEL`` draws when no axis is given), each at a velocity
where something happens and the model's defaults elsewhere: *none* is a
Painlevé inconsistency, *two* an indeterminacy, *contact lost* (hatched) a
state the body leaves by lifting off a one-sided contact.
"""

import matplotlib.pyplot as plt
import numpy as np

import phasemap
from phasemap.study import collect_legend

# the velocity held fixed on each map (rad/s, or m/s for a slider)
FIXED = {"ladder": {"omega": 3.0}, "wheel": {"omega": 6.0}, "elliptic_pendulum": {"xdot": -1.0},
         "hinge_pendulum": {"omega": 1.0}, "painleve_rod": {"xdot": -1.0},
         "rod_on_step": {"omega": -3.0}}
names = list(phasemap.MODELS)
handles: dict = {}
with phasemap.plot.style():
    fig, axes = plt.subplots(3, 2, figsize=(7.2, 8.0), layout="constrained")
    for name, ax in zip(names, axes.ravel()):
        model = phasemap.get_model(name)
        axes_spec = {k: np.linspace(lo, hi, 160) for k, (lo, hi, _) in model.default_axes.items()}
        fixed = FIXED.get(name, {})
        atlas = phasemap.Scene(model, axes=axes_spec, fixed=fixed,
                               layers=["n_solutions", "contact_lost"]).compute()
        phasemap.plot.map_figure(atlas, ax=ax, colorbar="none")
        collect_legend(ax, handles)            # one legend for the six panels
        held = ", ".join(f"{k} = {v:g}" for k, v in fixed.items())
        ax.set_title(f"{name.replace('_', ' ')} ({held}, defaults elsewhere)", loc="left")
        counts = {int(k): int((atlas.n_solutions == k).sum()) for k in np.unique(atlas.n_solutions)}
        print(f"{name:18s} cells per n_solutions: {counts}")
    phasemap.plot.figure_legend(fig, list(handles.values()), list(handles))
plt.show()
