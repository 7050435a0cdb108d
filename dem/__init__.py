"""Yade scene scripts of the Couette experiment and their numpy-only measurement helpers."""
