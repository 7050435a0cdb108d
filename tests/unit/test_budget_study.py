"""``make budget`` (``pipeline/studies/budget.py``) on a synthetic run made by the model, whose fabric changes by
rotating kept contacts only: the measured total is then Eq. 13's own rate, and the terms say so."""

import numpy as np
import pytest

import model
from dem.core.rawfile import write_raw
from dem.core.schema import contact_fields
from pipeline.dataset.dem_file import load, write_h5
from pipeline.studies import budget, law_terms
from tests.helpers.synthetic import synthetic_raw


def with_contacts(raw):
    """A synthetic run's raw samples with a contact budget: every change of A by kept contacts."""
    n = len(raw["strain"])
    out = dict(raw)
    for key, info in contact_fields().items():
        shape = [d for d in info["shape"] if isinstance(d, int)]
        out[key] = np.zeros((n, *shape))
    kept = np.full((n, 3, 3), np.nan)
    kept[1:] = np.diff(raw["fabric"], axis=0)
    out["budget_kept"] = kept
    for name in ("made", "lost", "crossed"):
        out[f"budget_{name}"][0] = np.nan
    out["strong_fabric"] = out["weak_fabric"] = raw["fabric"]
    out["strong_fraction"] = np.full(n, 0.4)
    out["persistence_touching"] = np.ones((n, 4))
    return out


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("budget")
    raw, meta = synthetic_raw(150.0, n_cycles=2)
    write_raw(folder / "raw.npz", with_contacts(raw), meta)
    write_h5(folder / "raw.npz", folder / "run.h5", {"git_commit": "test", "sessions": []})
    return load(folder / "run.h5")


def test_the_measured_total_of_a_run_made_by_eq13_is_eq13s_total(run):
    """Where the samples resolve it (0.005 strain apart: from 0.05 on after the turn) the DEM's total rate on both
    components is Eq. 13's, evaluated on the measured states, to the forward step's error."""
    (group,) = budget.budget_groups([run], model.PAPER)
    assert group.events == 4  # two cycles, two turns each
    for w in group.windows:
        if w.lo < 0.05:
            continue
        for comp in (w.shear, w.memory):
            total, eq13 = comp["total"].mean, comp["eq13_total"].mean
            assert total == pytest.approx(eq13, rel=0.1, abs=0.05), (w.lo, w.hi)
            assert comp["exchange"].mean == 0.0 and comp["kept"].mean == pytest.approx(total)


def test_the_followed_fractions_start_at_one_and_the_memory_fades(run):
    (group,) = budget.budget_groups([run], model.PAPER)
    assert group.curves["component"] == "memory"
    memory = np.asarray(group.curves["A"])
    assert memory[0] == pytest.approx(1.0, abs=0.05) and memory[-1] < 0.5
    # the sum of the terms from the change is the fraction itself
    np.testing.assert_allclose(np.asarray(group.curves["kept"]) + np.asarray(group.curves["exchange"])
                               - memory[0], memory, atol=1e-9)
    last = group.windows[-1].state
    assert last["memory_strong"].mean == pytest.approx(0.4 * last["memory_A"].mean)


def test_a_laws_own_terms_on_its_cycle_are_the_run_it_made(run, tmp_path, capsys):
    """Eq. 13's parameters, given as a law's (``--laws``): on its own cycle its total is the run's measured total (the
    run is its cycle), its recovery the recovery the budget evaluates on the run's states, its input on the memory
    none; a file that is not a parameter set fails in one line before any work."""
    path = tmp_path / "params-rk2025.json"
    path.write_text(model.PAPER.to_json())
    laws, read = law_terms.fitted_laws([path], tmp_path)
    assert read == [path] and law_terms.fitted_laws(None, tmp_path) == ([], [])  # no make models here: no law
    (group,) = budget.budget_groups([run], model.PAPER, tuple(laws))
    (law,) = group.laws
    assert law.variant == "rk2025" and not law.error and len(law.windows) == len(group.windows)
    for w, own in zip(group.windows, law.windows, strict=True):
        if w.lo < 0.05:
            continue
        assert own.total == pytest.approx(w.memory["total"].mean, rel=0.1, abs=0.05), (w.lo, w.hi)
        assert own.recovery == pytest.approx(w.memory["recovery"].mean, rel=0.1, abs=0.05)
        assert own.input == pytest.approx(0.0, abs=1e-9) and own.own == 0.0
    (tmp_path / "bad.json").write_text("{}")
    assert budget.main(["--laws", str(tmp_path / "bad.json"), "--out", str(tmp_path)]) == 2
    assert "bad.json" in capsys.readouterr().err


def test_a_run_without_a_contact_budget_is_refused_in_one_line(tmp_path, capsys):
    raw, meta = synthetic_raw(180.0, n_cycles=1)
    write_raw(tmp_path / "raw.npz", raw, meta)
    write_h5(tmp_path / "raw.npz", tmp_path / "run.h5", {"git_commit": "test", "sessions": []})
    assert budget.main(["--spacing", str(tmp_path / "run.h5"), str(tmp_path / "run.h5"), "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == "error: --spacing needs two runs or more, each with a contact budget"
