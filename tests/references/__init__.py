"""The paper's hand derivations of the ladder and the wheel (Lapshin 2021), as named
references for the tests: the equations as printed, with their errata corrected, and the
closed forms.  Each module defines a full :class:`phasemap.core.model.Model` (``MODEL``) that
keeps its contacts; what runs as ``ladder`` and ``wheel`` are their declarations
(phasemap.systems.seeds), which also count leaving a contact.  The tests import these as
``from references import ladder`` (tests/ is on the path); benchmarks/grid.py's
``hand_model`` puts tests/ on the path for the benchmarks.
"""
