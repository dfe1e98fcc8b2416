"""The seed systems of Lapshin (2021), declared: checks of phasemap.models (tests/test_declare.py)."""
