"""The adapter contract an engine implements (``dem/yade/``, ``dem/lammps/``), declared once.

An engine's scene module defines two classes: ``Run``, a subclass of ``dem.core.driver.Experiment`` that adds the
few things only the engine knows (:class:`EngineRun`), and ``Scene``, which builds, resumes, advances and saves the
simulation for ``dem.core.driver.run_scene`` (:class:`EngineScene`). Every measurement is ``dem.core.measure``'s, on
the arrays ``gather`` hands over. Units: d = p = rho = 1 (time in d sqrt(rho/p)). ``tests/unit/test_dem_contract.py``
holds each engine's scene module to these members.
"""

from typing import Protocol, runtime_checkable


@runtime_checkable
class EngineRun(Protocol):
    """The engine's side of the running experiment; ``radius`` and ``mass`` are the grains' (arrays, d and rho d^3)."""

    def iteration(self) -> int:
        """Steps done since the scene was built."""

    def time(self) -> float:
        """Simulated time, d sqrt(rho/p)."""

    def dt(self) -> float:
        """The time step."""

    def wall_heights(self) -> tuple:
        """Heights of the bottom and top walls' compact layers, d."""

    def wall_force(self) -> tuple:
        """Force of the grains on the top wall (x, y, z), p d^2."""

    def move_walls(self, top, bottom) -> None:
        """Set the top and bottom walls' velocities (3-vectors, d / (d sqrt(rho/p)))."""

    def wall_record(self) -> dict:
        """The walls' state a sample records."""

    def gather(self, grains: bool = True) -> tuple:
        """The contact and grain arrays of ``dem.core.measure`` (on every rank where there are several); the grain
        arrays None where ``grains`` is false."""

    def stop_after_this_step(self) -> None:
        """End the engine's loop once the current step is done (the driver's checkpoints and end)."""


@runtime_checkable
class EngineScene(Protocol):
    """A simulation that ``dem.core.driver.run_scene`` drives: built or resumed, advanced, saved."""

    def start(self):
        """Build the scene or resume it from its checkpoint (``dem.core.driver.damaged`` refuses a damaged one);
        returns its ``Run``."""

    def advance(self, run, stop) -> None:
        """Run the engine until the driver stops it (a checkpoint, the end, a failure, a signal)."""

    @staticmethod
    def agreed_stop(stop) -> dict:
        """The stop every process agrees on (its ``signal`` entry: 0 for none)."""

    def checkpoint_bytes(self) -> int:
        """The size of the last checkpoint, for the free-space check before the next."""

    def save(self, run) -> None:
        """Write the checkpoint (the engine's state and ``run.state``), synced."""

    def reload(self):
        """Reload the checkpoint just written (every run reloads its own: a resumed run is bit-identical)."""

    def meta(self) -> dict:
        """The engine's entries of ``raw.npz``: ``engine``, ``engine_version``."""
