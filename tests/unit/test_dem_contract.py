"""The engines' adapters against the contract of ``dem/core/contract.py``, read from their source (the venv has
neither engine), and the DEM core without any engine: what a LAMMPS-only machine needs."""

import ast
import dataclasses
import inspect
import subprocess
import sys

import pytest

from dem.core import cell, contract, protocol
from pipeline import spec as run_spec
from pipeline.engines import DEFAULT_ENGINE, ENGINES
from pipeline.paths import ROOT


def members(protocol_class) -> set[str]:
    return {name for name, value in vars(protocol_class).items()
            if not name.startswith("_") and (inspect.isfunction(value) or isinstance(value, staticmethod))}


def classes_of(module: str) -> dict[str, ast.ClassDef]:
    tree = ast.parse((ROOT / (module.replace(".", "/") + ".py")).read_text())
    return {node.name: node for node in tree.body if isinstance(node, ast.ClassDef)}


def methods(node: ast.ClassDef) -> set[str]:
    return {item.name for item in node.body if isinstance(item, ast.FunctionDef)}


@pytest.mark.parametrize("engine", list(ENGINES))
def test_each_engines_scene_implements_the_contract(engine):
    """``Run`` subclasses the driver's ``Experiment`` with every member of ``EngineRun``; ``Scene`` has every
    member of ``EngineScene``. The contract itself lists 9 and 7 members."""
    assert (len(members(contract.EngineRun)), len(members(contract.EngineScene))) == (9, 7)
    found = classes_of(ENGINES[engine].scene)
    run, scene = found["Run"], found["Scene"]
    assert [ast.unparse(b) for b in run.bases] == ["driver.Experiment"]
    assert members(contract.EngineRun) <= methods(run), members(contract.EngineRun) - methods(run)
    assert members(contract.EngineScene) <= methods(scene), members(contract.EngineScene) - methods(scene)


def test_the_registry_names_the_reference_first_and_every_scene_module_exists():
    assert DEFAULT_ENGINE == "yade" == next(iter(ENGINES))
    for engine in ENGINES.values():
        assert (ROOT / (engine.scene.replace(".", "/") + ".py")).is_file()
        assert engine.install in (ROOT / "Makefile").read_text()


def test_every_seed_of_the_tiny_cell_gets_its_grains_without_any_engine():
    """Random placement stalls for about one seed in seven of the tiny cell in the usual box; the box then grows,
    so seeds 1-25 all build (4 of them in a grown box). ``dem.core`` imports neither Yade nor LAMMPS."""
    spec = run_spec.resolve(180, "tiny")
    placed = []
    for seed in range(1, 26):
        s = dataclasses.replace(spec, seed=seed)
        n = protocol.grain_count(s)
        cloud, y_top = cell.initial_cloud(s, n, int(s.width_d), 1.0)
        placed.append((len(cloud), n, y_top))
        radii = [r for _, r in cloud]
        assert min(radii) >= spec.diameter_min_d / 2 - 1e-12 and max(radii) <= spec.diameter_max_d / 2 + 1e-12
    assert all(made == n for made, n, _ in placed)
    usual = min(y_top for _, _, y_top in placed)
    assert sum(y_top > usual + 1e-9 for _, _, y_top in placed) >= 3  # the box grew for some seeds
    code = "import sys, dem.core.driver, dem.core.cell, dem.lammps.contact; print(sorted(m for m in sys.modules if " \
           "m.split('.')[0] in ('yade', 'lammps')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out.strip() == "[]"
