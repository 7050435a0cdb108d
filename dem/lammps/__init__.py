"""LAMMPS's adapter of the Couette scene (the fast engine)."""
