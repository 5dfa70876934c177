"""Continuation and bifurcation analysis (placeholder docstring, replaced below)."""
