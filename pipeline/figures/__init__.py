"""Figures and the report (``make figures``): one module per figure, headless; they read the comparison
and calibration files and draw, nothing else."""

import matplotlib

matplotlib.use("Agg")  # headless: every figure module imports this package first
