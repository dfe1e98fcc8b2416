"""
A trajectory with stick and slip
================================

``phasemap.simulate`` integrates the motion with a compiled Dormand-Prince
method and classifies the state after every step with the model's own branch
functions. Where the slider of Painlevé's elliptic pendulum comes to a stop,
the event is located on the dense output and the motion *sticks*: the slider's
velocity is then exactly zero, with no smoothing of the friction law, until the
static friction limit is reached and it *slips* again.
"""

import matplotlib.pyplot as plt

import phasemap

ds = phasemap.simulate("elliptic_pendulum", t_end=3.0, phi=1.0, omega=0.0, xdot=1.0, f=0.3)
for t, kind in zip(ds.event_t.values, ds.event_kind.values):
    print(f"t = {t:7.4f} s  {phasemap.Event(int(kind)).name.lower()}")

stick = ds.branch == 4                       # the stick branch
print("xdot on the stick stages:", set(ds.xdot.where(stick, drop=True).values.tolist()))

fig = ds.phasemap.plot(size="two_column")
plt.show()
