"""Yade's adapter of the Couette scene (the reference engine)."""
