"""The registry of atlas layers: one truth for the evaluator, the writer and the plots.

A layer's metadata (dtype, units, long_name, flags) is data.  The grid
evaluator reads ``kind``, ``branch`` and ``column`` to know what to write, the
Scene copies ``attrs`` onto the Dataset, and the netCDF writer and the plots
read those attrs back.

Layers of a model:

* ``n_solutions`` (int8 flags 0-4: none unique two continuum three_or_more);
* ``stagnation``, ``contact_lost``, ``singular`` (int8 flags 0/1: no yes);
* for each branch B, each senior derivative and reaction X: ``X_B`` (float64,
  NaN where the branch is not admissible);
* for each non-stick branch B: ``coef_B``, the coefficient of the senior
  derivative (NaN where the branch does not apply);
* for models with dynamics, the fate layers of a grid of initial conditions
  (each cell integrated in time by :func:`phasemap.simulate`'s integrator):
  ``fate`` (int8 flags, how the motion ends: see :class:`phasemap.Event`),
  ``n_reversals``, ``t_final`` (when the motion ended), ``t_rest`` (NaN
  unless it stopped in a stagnation zone) and, where rest freezes the whole
  state, the final positions ``phi_rest``... (NaN unless at rest).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np

from phasemap.core.memo import Memo
from phasemap.core import numerics as nx
from phasemap.core import events as ev
from phasemap.core.model import Model, Solvability


class Outcome(NamedTuple):
    """What the integrator returns for a grid of initial states (one array per cell, and
    per coordinate for ``positions``); each fate layer is read from it."""

    fate: np.ndarray
    n_reversals: np.ndarray
    t_final: np.ndarray
    positions: np.ndarray


@dataclass(frozen=True)
class Layer:
    """One atlas variable: what it is, how it is stored, where the kernel finds it.

    Examples
    --------
    >>> import phasemap
    >>> layer = phasemap.layers_for("ladder")["stagnation"]
    >>> layer.dtype, layer.flag_values, layer.flag_meanings
    ('int8', (0, 1), 'no yes')
    """

    name: str
    dtype: str
    long_name: str
    units: str | None = None
    flag_values: tuple[int, ...] | None = None
    flag_meanings: str | None = None
    branch: int = -1  # field layers: the branch row ...
    column: int = -1  # ... and the column of out[branch] to copy
    admissible_only: bool = True  # NaN unless the branch is admissible
    fate: bool = False  # computed by integrating from each cell (see phasemap.motion.integrate)
    #: on the scene's axes and one more, ``cycle``: a cell's section points (the orbit
    #: layers of a map in full coordinates, :mod:`phasemap.maps.motions`)
    cycle: bool = False
    #: Summary layers: the position of the layer's bits in the byte a grid kernel
    #: packs several summaries into (see :data:`SUMMARY_LAYERS`).
    shift: int = -1
    #: fate layers: the layer's values from the integrator's :class:`Outcome`
    outcome: Callable[[Outcome], np.ndarray] | None = field(default=None, compare=False,
                                                             repr=False)

    @property
    def is_summary(self) -> bool:
        return self.branch < 0 and not self.fate

    @property
    def mask(self) -> int:
        """The bits a summary's flag values need, as a mask (7 for the values 0-4)."""
        return (1 << max(self.flag_values).bit_length()) - 1

    @property
    def attrs(self) -> dict:
        attrs: dict = {"long_name": self.long_name}
        if self.flag_values is not None:
            attrs["flag_values"] = np.array(self.flag_values, dtype=self.dtype)
            attrs["flag_meanings"] = self.flag_meanings
        if self.units is not None:
            attrs["units"] = self.units
        return attrs


def _packed(layers: list[Layer]) -> tuple[Layer, ...]:
    """The summary layers with their bits placed one after another in one byte."""
    out, shift = [], 0
    for layer in layers:
        out.append(dataclasses.replace(layer, shift=shift))
        shift += layer.mask.bit_length()
    if shift > 8:
        raise ValueError(f"the summary layers need {shift} bits; a grid kernel packs them "
                         "into one byte")
    return tuple(out)


#: The per-point answers every model offers, in the order of the registry, with
#: their bit positions in a grid kernel's packed byte.
SUMMARY_LAYERS = _packed([
    Layer("n_solutions", "int8", "number of solutions of the motion equations for the senior "
          "derivatives", flag_values=tuple(int(s) for s in Solvability),
          flag_meanings=" ".join(s.name.lower() for s in Solvability)),
    Layer("stagnation", "int8", "zero relative velocity and the stick branch is admissible",
          flag_values=(0, 1), flag_meanings="no yes"),
    Layer("contact_lost", "int8", "a branch needs a one-sided contact to pull",
          flag_values=(0, 1), flag_meanings="no yes"),
    Layer("singular", "int8", "the coefficient of the senior derivative vanishes",
          flag_values=(0, 1), flag_meanings="no yes"),
])
#: Their names.
SUMMARY = tuple(l.name for l in SUMMARY_LAYERS)

#: id(model) -> (model, its layers): two versions of a system (a hand module and its
#: declaration) share a name but not their branches.
_REGISTRIES = Memo("layers.registries")


def _registry(model: Model) -> dict[str, Layer]:
    return _REGISTRIES.get((model,), (), lambda: _make_registry(model))


def _make_registry(model: Model) -> dict[str, Layer]:
    layers = {l.name: l for l in SUMMARY_LAYERS}
    for b, branch in enumerate(model.branches):
        for j, var in enumerate(model.accelerations + model.reactions):
            name = f"{var.name}_{branch}"
            layers[name] = Layer(name, "float64", f"{var.long_name}, branch {branch}",
                                 units=var.units, branch=b, column=nx.FIRST_ACC + j)
        if b != model.stick_branch:
            name = f"coef_{branch}"
            layers[name] = Layer(name, "float64", f"{model.coefficient.long_name}, branch {branch}",
                                 units=model.coefficient.units, branch=b, column=nx.COEF,
                                 admissible_only=False)
    if model.dynamics is not None:
        layers["fate"] = Layer("fate", "int8", "how the motion from this initial state ends",
                               flag_values=ev.FATE_VALUES, flag_meanings=ev.FATE_MEANINGS,
                               fate=True, outcome=lambda o: o.fate)
        layers["n_reversals"] = Layer("n_reversals", "int32", "number of reversals of the "
                                      "relative velocity", units="1", fate=True,
                                      outcome=lambda o: o.n_reversals)
        layers["t_final"] = Layer("t_final", "float64", "time at which the motion ended (the "
                                  "horizon if still moving)", units="s", fate=True,
                                  outcome=lambda o: o.t_final)
        layers["t_rest"] = Layer("t_rest", "float64", "time to rest in a stagnation zone",
                                 units="s", fate=True,
                                 outcome=lambda o: np.where(o.fate == ev.REST, o.t_final, np.nan))
        if model.dynamics.stick_is_rest:
            for j, c in enumerate(model.dynamics.coordinates):
                var = model.variable(c[0])
                layers[f"{c[0]}_rest"] = Layer(f"{c[0]}_rest", "float64",
                                               f"{var.long_name} at rest", units=var.units,
                                               fate=True, outcome=lambda o, j=j: o.positions[j])
    return layers


def layers_for(model: str | Model) -> dict[str, Layer]:
    """Every layer a model offers, by name, in a stable order.

    Parameters
    ----------
    model : str or Model
        a model name (``phasemap.MODELS``, or a friction oscillator's), or a
        :class:`Model`.

    Returns
    -------
    dict of str to Layer
        the summary layers (``n_solutions``, ``stagnation``, ...), then each
        branch's accelerations and reactions, then the fate layers.

    Raises
    ------
    ValueError
        for an unknown model name.

    Examples
    --------
    >>> import phasemap
    >>> layers = phasemap.layers_for("ladder")
    >>> list(layers)[:4]
    ['n_solutions', 'stagnation', 'contact_lost', 'singular']
    >>> layers["n_solutions"].flag_meanings
    'none unique two continuum three_or_more'
    """
    from phasemap.maps.full import FullModel, map_model

    model = map_model(model)
    if isinstance(model, FullModel):   # a system in full coordinates (phasemap.maps.full)
        return _full_registry(model)
    return dict(_registry(model))


def _full_registry(model) -> dict[str, Layer]:
    """The layers of a map in full coordinates (:mod:`phasemap.maps.full`): the summaries,
    then the unique motion's accelerations and reactions (its row's columns)."""
    out = {l.name: dataclasses.replace(l, long_name=_FULL_MEANINGS.get(l.name, l.long_name))
           for l in SUMMARY_LAYERS}
    for j, var in enumerate(model.accelerations + model.reactions):
        out[var.name] = Layer(var.name, "float64", f"{var.long_name} (the unique motion)",
                              units=var.units, branch=0, column=j)
    out.update(_full_motion_layers(model))
    return out


def _full_motion_layers(model) -> dict[str, Layer]:
    """The layers a map in full coordinates computes by moving from each cell
    (:mod:`phasemap.maps.motions`): the motion's end, then its section points."""
    from phasemap.motion.periodic.orbit import state_variables

    state = state_variables(model.mech)
    out = {
        "fate": Layer("fate", "int8", "how the motion from this state ends (horizon: it ran "
                      "through)", flag_values=ev.FATE_VALUES, flag_meanings=ev.FATE_MEANINGS,
                      fate=True),
        "n_reversals": Layer("n_reversals", "int32", "number of reversals of a relative "
                             "velocity", units="1", fate=True),
        "n_sticks": Layer("n_sticks", "int32", "number of times a contact stuck (to its "
                          "surface: on a belt, moving with it)", units="1", fate=True),
        "t_final": Layer("t_final", "float64", "time from the start at which the motion "
                         "ended (t_end if still moving)", units="s", fate=True),
        "t_rest": Layer("t_rest", "float64", "time from the start to rest", units="s",
                        fate=True),
    }
    for name, units in state:
        out[f"{name}_final"] = Layer(f"{name}_final", "float64",
                                     f"{name} where the motion ended", units=units, fate=True)
    forced = model.mech.period is not None
    where = ("at the forcing phase, once per forcing period" if forced
             else "at each maximum of the section coordinate")
    for name, units in state:
        out[f"section_{name}"] = Layer(f"section_{name}", "float64",
                                       f"{name} of the settled motion {where}", units=units,
                                       fate=True, cycle=True)
    # (0: no period up to phasemap.motion.periodic.orbit.MAX_MULTIPLE)
    out["multiple"] = Layer("multiple", "int8", "settled motion's period, in "
                            f"{'forcing periods' if forced else 'section points'} (0: none)",
                            units="1", fate=True)
    return out


#: What the summaries mean in full coordinates, where the candidates are phases.
_FULL_MEANINGS = {
    "stagnation": "a contact at rest relative to its surface, and a motion that keeps it stuck",
    "contact_lost": "a motion opens a one-sided contact that touches: the body leaves it",
    "singular": "the coefficient of the senior derivative of a slipping phase vanishes",
}
