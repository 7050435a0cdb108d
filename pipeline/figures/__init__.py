"""Figures and the report (``make figures``): one module per figure, headless, reading HDF5/JSON only."""
