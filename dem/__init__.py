"""The DEM experiment, run by Debian's python3 (standard library, numpy and the engine): ``core/`` is the same for
every engine, ``yade/`` and ``lammps/`` are the engines' adapters of its contract (``core/contract.py``), ``tools/``
the checks and benchmarks that drive a scene."""
