"""Where the memory lives (``pipeline/studies/near.py``) on a synthetic run with known near shells and gains."""

import numpy as np
import pytest

from dem.core.budget import LOAD_BINS
from dem.core.rawfile import write_raw
from pipeline.dataset.dem_file import load, write_h5
from pipeline.studies import near
from tests.helpers.synthetic import synthetic_raw
from tests.unit.test_budget_study import with_contacts

#: the gain per near pair per unit strain in each bin, and each shell's scale of A, that the run is made with
GAIN = np.linspace(10.0, 80.0, LOAD_BINS)
SCALE = (-0.2, -0.5, 0.3)
FED = (0.25, 0.5, 0.75)
PAIRS = 1e8


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("near")
    raw, meta = synthetic_raw(150.0, n_cycles=2)
    out = with_contacts(raw)
    n = len(raw["strain"])
    step = np.concatenate([[0.0], np.diff(raw["strain"])])
    out["near_fabric"] = np.stack([k * raw["fabric"] for k in SCALE], axis=1)
    out["near_by_load"] = np.full((n, 3, LOAD_BINS), PAIRS)  # counts are whole: so many that rounding is 1e-6
    out["made_by_load"] = np.round(PAIRS * GAIN[None, :] * step[:, None])
    out["made_count"] = out["made_by_load"].sum(axis=1)
    out["made_near_change"] = np.round(np.outer(out["made_count"], FED))
    out["contacts_by_load"] = np.full((n, LOAD_BINS), PAIRS)
    out["lost_by_load"] = np.round(PAIRS * 3.0 * np.ones(LOAD_BINS)[None, :] * step[:, None])
    out["lost_count"] = out["lost_by_load"].sum(axis=1)
    out["made_fabric"] = raw["fabric"]
    write_raw(folder / "raw.npz", out, meta)
    write_h5(folder / "raw.npz", folder / "run.h5", {"git_commit": "test", "sessions": []})
    return load(folder / "run.h5")


def test_shells_that_scale_the_fabric_hold_its_memory_and_the_known_gain_is_found(run):
    (group,) = near.near_groups([run])
    assert group.events == 4 and group.component == "memory"
    for k, g in enumerate(near.NEAR_GAPS):
        assert group.steady[f"x0 G{g:g} / a0"].mean == pytest.approx(SCALE[k])
    assert group.steady["x0 made / a0"].mean == pytest.approx(1.0, abs=0.05)
    for w in group.windows[1:]:
        for k, g in enumerate(near.NEAR_GAPS):  # a shell proportional to A holds that share of A's memory
            assert w.memory[f"G{g:g}"].mean == pytest.approx(SCALE[k] * w.memory["A"].mean, abs=1e-9)
        for k, g in enumerate(near.NEAR_GAPS):
            assert w.fed[f"G{g:g}"].mean == pytest.approx(FED[k], rel=1e-5)
        np.testing.assert_allclose([s.mean for s in w.gain_per_near], GAIN, rtol=1e-5)
        np.testing.assert_allclose([s.mean for s in w.loss_per_contact], 3.0, rtol=1e-5)
    np.testing.assert_allclose([s.mean for s in group.steady_gain_per_near], GAIN, rtol=1e-5)
    memory = [w.memory["A"].mean for w in group.windows[1:]]
    assert memory[0] > memory[-1]  # it fades
    made = [w.memory["made"].mean for w in group.windows[1:]]  # made with A's fabric: between A's at either end
    ends = [group.windows[0].memory["A"].mean] + memory
    for m, lo, hi in zip(made, ends[:-1], ends[1:], strict=True):
        assert min(lo, hi) - 0.05 <= m <= max(lo, hi) + 0.05


def test_a_run_of_an_older_file_has_no_near_record(run, tmp_path):
    raw, meta = synthetic_raw(150.0, n_cycles=1)
    write_raw(tmp_path / "raw.npz", raw, meta)
    write_h5(tmp_path / "raw.npz", tmp_path / "run.h5", {"git_commit": "test", "sessions": []})
    assert near.near_groups([load(tmp_path / "run.h5")]) == [] and near.markdown([]) == ""


def test_a_version_3_file_reads_its_persistence_under_the_new_name_and_has_no_near_pairs(run, tmp_path):
    import shutil

    import h5py

    from dem.core.schema import contact_fields

    old = tmp_path / "v3.h5"
    shutil.copy(run.path, old)
    with h5py.File(old, "r+") as f:
        f.attrs["schema_version"] = 3
        f["contacts"].move("persistence_touching", "persistence")
        for key, info in contact_fields().items():
            if info.get("since", 0) > 3:
                del f["contacts"][key]
    contacts = load(old).contacts
    np.testing.assert_array_equal(contacts["persistence_touching"], run.contacts["persistence_touching"])
    assert "near_fabric" not in contacts and "persistence" not in contacts
    assert near.near_groups([load(old)]) == []
