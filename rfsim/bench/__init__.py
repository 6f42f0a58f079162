"""Benchmarks of rfsim's own hot paths, run by ``rfsim bench``.

Each module here exposes functions returning a dict of named measurements (with units
in the key names), so the numbers reported in notes come from the repository itself.
"""
