"""The stages import one way: each only the stages before it, and the modules below the stages (``schema``, ``io``,
``paths``, ...) none; ``model/`` imports nothing of the pipeline, no h5py and no matplotlib."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: the stages in the order data flows through them (the front door, ``targets``, calls them all)
ORDER = ("dataset", "runs", "calibration", "comparison", "model_selection", "figures", "studies", "targets")
BELOW = ("schema",)  # a package below every stage; the modules of pipeline/ itself are below too


def imported(path: Path) -> set[str]:
    """The top-level parts of ``pipeline`` (``pipeline.<part>``) a module imports, relative or absolute."""
    package = path.relative_to(ROOT).with_suffix("").parts[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(package[:len(package) - node.level + 1])
                full = base + (node.module.split(".") if node.module else [])
                names = [full + [a.name] for a in node.names] if len(full) == 1 else [full]
            else:
                names = [(node.module or "").split(".")]
            found |= {n[1] for n in names if len(n) > 1 and n[0] == "pipeline"}
        elif isinstance(node, ast.Import):
            found |= {a.name.split(".")[1] for a in node.names if a.name.startswith("pipeline.")}
    return found


@pytest.mark.parametrize("stage", ORDER + BELOW)
def test_a_stage_imports_only_the_stages_before_it(stage):
    allowed = set(ORDER[:ORDER.index(stage)]) if stage in ORDER else set()
    for path in sorted((ROOT / "pipeline" / stage).rglob("*.py")):
        bad = imported(path) & set(ORDER) - allowed - {stage}
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}: against the flow {' -> '.join(ORDER)}"


def test_the_modules_below_the_stages_import_no_stage():
    for path in sorted((ROOT / "pipeline").glob("*.py")):
        bad = imported(path) & set(ORDER)
        assert not bad, f"{path.relative_to(ROOT)} imports the stage(s) {sorted(bad)}"


def test_the_model_imports_nothing_of_the_pipeline_nor_files_nor_plots():
    for path in sorted((ROOT / "model").rglob("*.py")):
        tree = ast.parse(path.read_text())
        names = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        names |= {(n.module or "").split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                  and not n.level}
        assert not names & {"pipeline", "h5py", "matplotlib"}, path


def test_the_rule_finds_a_back_import(tmp_path):
    """The check can fail: a stage module that imports a later stage is named."""
    path = ROOT / "pipeline" / "dataset" / "_zz_back_import_probe.py"
    path.write_text("from ..comparison import metrics\n")
    try:
        assert "comparison" in imported(path)
        with pytest.raises(AssertionError, match="imports \\['comparison'\\]"):
            test_a_stage_imports_only_the_stages_before_it("dataset")
    finally:
        path.unlink()
