"""Scenario sweeps of osiris sensor models on Dask (see docs/sweep.md)."""

__version__ = "0.1.0"
