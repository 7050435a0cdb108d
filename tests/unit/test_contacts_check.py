"""The contact budget's values checked where a run file is read (``pipeline/dataset/contacts.py``): every
``/contacts`` field, damaged as its kind allows not, is refused in one line naming it."""

import shutil

import h5py
import numpy as np
import pytest

from dem.core.rawfile import write_raw
from dem.core.schema import contact_fields
from pipeline.dataset.dem_file import load, write_h5
from pipeline.errors import DemFileError
from tests.helpers.synthetic import synthetic_raw
from tests.unit.test_budget_study import with_contacts

#: per kind, the damages (a function of the stored value at one sample) and what the refusal says
DAMAGES = {
    "term": [(lambda v: v + np.nan, "is not finite after the first sample"),
             (lambda v: v + 0.05, "do not sum to the change of /raw/fabric")],
    "count": [(lambda v: v - 1 - v, "is not a whole number >= 0"), (lambda v: v + 0.5, "is not a whole number >= 0"),
              (lambda v: v + np.nan, "is not finite")],
    "share": [(lambda v: v * 0 + 7, "is outside [0, 1]"), (lambda v: v * 0 - 0.5, "is outside [0, 1]")],
    "fabric": [(lambda v: v * 0 + 0.9, "has a component outside a fabric's bounds")],
    "force": [(lambda v: v * 0 - 1, "is negative")],
}
CASES = [(name, k) for name, info in contact_fields().items() for k in range(len(DAMAGES[info["kind"]]))]


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    folder = tmp_path_factory.mktemp("contacts")
    raw, meta = synthetic_raw(150.0, n_cycles=1)
    write_raw(folder / "raw.npz", with_contacts(raw), meta)
    write_h5(folder / "raw.npz", folder / "run.h5", {"git_commit": "test", "sessions": []})
    assert load(folder / "run.h5").contacts is not None
    return folder / "run.h5"


def test_every_contact_field_declares_a_kind_the_reader_checks():
    assert {info["kind"] for info in contact_fields().values()} == set(DAMAGES)


@pytest.mark.parametrize("name, k", CASES)
def test_a_damaged_contact_field_is_refused_in_one_line_naming_it(good, tmp_path, name, k):
    damage, said = DAMAGES[contact_fields()[name]["kind"]][k]
    path = tmp_path / "damaged.h5"
    shutil.copy(good, path)
    with h5py.File(path, "r+") as f:
        data = f["contacts"][name]
        values = data[()].astype(float)
        values[3] = damage(values[3])
        del f["contacts"][name]
        f["contacts"].create_dataset(name, data=values).attrs["unit"] = contact_fields()[name]["unit"]
    with pytest.raises(DemFileError) as caught:
        load(path)
    message = str(caught.value)
    assert "\n" not in message and said in message and "sample 3" in message
    assert name in message or "budget_*" in message
