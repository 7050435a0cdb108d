"""Figures and the report (``make figures``): one module per figure, headless; they read the comparison
and calibration files and draw, nothing else."""
