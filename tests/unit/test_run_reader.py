"""A run file is data that cannot reach outside itself (``pipeline/dataset/reader.py``): every dataset the schema names,
swapped for a link, a virtual dataset, external storage, the wrong type, shape or unit, is refused in one line before
its bytes are read; so are unbounded sizes, attributes and nesting."""

import shutil

import h5py
import numpy as np
import pytest

from dem.core.rawfile import write_raw
from dem.core.schema import contact_fields, sample_fields
from pipeline.dataset.dem_file import load, schema_shape, write_h5
from pipeline.dataset.reader import (
    MAX_ATTRIBUTE_BYTES,
    MAX_ATTRIBUTES,
    MAX_CHUNKS,
    MAX_JSON_DEPTH,
    MAX_SAMPLES,
    RunFileReader,
)
from pipeline.errors import DemFileError
from tests.helpers.synthetic import synthetic_raw


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """A valid run file with the contact budget, and a file outside it holding a secret."""
    folder = tmp_path_factory.mktemp("reader")
    raw, meta = synthetic_raw(180.0, n_cycles=1)
    write_raw(folder / "raw.npz", raw, meta)
    write_h5(folder / "raw.npz", folder / "run.h5", {"git_commit": "test", "sessions": []})
    with h5py.File(folder / "run.h5", "r+") as f:
        n = f["raw/strain"].shape[0]
        group = f.create_group("contacts")
        for key, info in contact_fields().items():
            group.create_dataset(key, data=np.zeros(schema_shape(info, n, 1))).attrs["unit"] = info["unit"]
        kept = np.full((n, 3, 3), np.nan)  # the budget's identity: every change of A by kept contacts
        kept[1:] = np.diff(f["raw/fabric"][()], axis=0)
        group["budget_kept"][...] = kept
        for term in ("made", "lost", "crossed"):
            group[f"budget_{term}"][0] = np.nan
    with h5py.File(folder / "outside.h5", "w") as f:
        f["secret"] = np.arange(10.0)
    (folder / "outside.bin").write_bytes(b"\0" * (1 << 20))
    assert load(folder / "run.h5").contacts is not None
    return folder


def datasets(path):
    """Every dataset a run file's reader opens, with the shape and unit it must have: ``{path: (shape, unit)}``."""
    with h5py.File(path) as f:
        n, bins = f["raw/strain"].shape[0], f["raw/profile_edges"].shape[1] - 1
        diameters = f["parameters/grain_diameter"].shape
    return ({f"/raw/{k}": (schema_shape(i, n, bins), i["unit"]) for k, i in sample_fields().items()}
            | {f"/contacts/{k}": (schema_shape(i, n, bins), i["unit"]) for k, i in contact_fields().items()}
            | {"/parameters/grain_diameter": (diameters, "d")})


def replace(f, name, **create):
    """Replace the dataset ``name`` by one made with ``create`` (its shape and unit kept unless given)."""
    old = f[name]
    shape, unit = old.shape, old.attrs["unit"]
    del f[name]
    if "data" not in create and "shape" not in create:
        create["shape"] = shape
    create.setdefault("dtype", float)
    f.create_dataset(name, **create).attrs["unit"] = create.pop("unit", unit)


def virtual(f, name, outside):
    shape, unit = f[name].shape, f[name].attrs["unit"]
    layout = h5py.VirtualLayout(shape=shape, dtype=float)
    layout[(0,) * len(shape)] = h5py.VirtualSource(str(outside / "outside.h5"), "secret", shape=(10,))[0]
    del f[name]
    f.create_virtual_dataset(name, layout).attrs["unit"] = unit


TAMPERINGS = {
    "an external link": (lambda f, name, out: (f.__delitem__(name), f.__setitem__(
        name, h5py.ExternalLink(str(out / "outside.h5"), "secret"))), "is a ExternalLink"),
    "a soft link": (lambda f, name, out: (f.__delitem__(name), f.__setitem__(name, h5py.SoftLink("/raw/time"))),
                    "is a SoftLink"),
    "a virtual dataset": (lambda f, name, out: virtual(f, name, out), "virtual dataset"),
    "external raw storage": (lambda f, name, out: replace(f, name, dtype=float, external=[(
        str(out / "outside.bin"), 0, 1 << 20)]), "external files"),
    "strings": (lambda f, name, out: replace(f, name, dtype=h5py.string_dtype()), "not real numbers"),
    "complex numbers": (lambda f, name, out: replace(f, name, dtype=complex), "not real numbers"),
    "another shape": (lambda f, name, out: replace(f, name, shape=f[name].shape[:-1] + (f[name].shape[-1] + 1,)),
                      "has shape"),
    "another unit": (lambda f, name, out: f[name].attrs.__setitem__("unit", "furlong"), "has unit 'furlong'"),
    "missing": (lambda f, name, out: f.__delitem__(name), "is missing"),
}


@pytest.mark.parametrize("how", sorted(TAMPERINGS))
def test_every_dataset_of_the_schema_is_refused_in_one_line_when_tampered(base, tmp_path, how):
    """Each dataset of the schema tampered in one copy: the reader refuses each, naming it, before reading it; and
    ``load`` refuses the file."""
    tamper, message = TAMPERINGS[how]
    path = tmp_path / "run.h5"
    shutil.copy(base / "run.h5", path)
    wanted = datasets(path)
    with h5py.File(path, "r+") as f:
        for name in wanted:
            tamper(f, name, base)
    with RunFileReader(path) as reader:
        for name, (shape, unit) in wanted.items():
            with pytest.raises(DemFileError) as err:
                reader.check_dataset(name, shape, unit)
            assert message in str(err.value) and name in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(DemFileError, match=message):
        load(path)


@pytest.mark.parametrize("group", ["/raw", "/contacts", "/provenance", "/parameters"])
def test_a_group_that_is_a_link_to_another_file_is_refused(base, tmp_path, group):
    path = tmp_path / "run.h5"
    shutil.copy(base / "run.h5", path)
    with h5py.File(base / "run.h5") as src, h5py.File(tmp_path / "other.h5", "w") as dst:
        src.copy(src[group], dst, name="g")
    with h5py.File(path, "r+") as f:
        del f[group]
        f[group] = h5py.ExternalLink(str(tmp_path / "other.h5"), "g")
    with pytest.raises(DemFileError, match=f"{group} is a ExternalLink"):
        load(path)


def edit(base, tmp_path, change):
    path = tmp_path / "run.h5"
    shutil.copy(base / "run.h5", path)
    with h5py.File(path, "r+", libver="latest") as f:
        change(f)
    return path


def declare(f, name, shape, chunks=True):
    """Replace ``name`` by a chunked dataset declaring ``shape`` (nothing written: the file stays small)."""
    unit = f[name].attrs["unit"]
    del f[name]
    f.create_dataset(name, shape=shape, dtype=float, chunks=chunks).attrs["unit"] = unit


def declare_all(f, n, bins):
    """Every dataset of the schema declared for ``n`` samples and ``bins`` profile bins, nothing written."""
    for group, fields in (("raw", sample_fields()), ("contacts", contact_fields())):
        for key, info in fields.items():
            declare(f, f"/{group}/{key}", schema_shape(info, n, bins))


def dense_attribute(f, size):
    """A ``size``-byte attribute of ``/provenance``, held in dense storage (the only way past 64 KiB)."""
    gcpl = h5py.h5p.create(h5py.h5p.GROUP_CREATE)
    gcpl.set_attr_phase_change(0, 0)
    h5py.h5g.create(f.id, b"dense", gcpl=gcpl)
    for key, value in f["provenance"].attrs.items():
        f["dense"].attrs[key] = value
    f["dense"].attrs["notes"] = np.zeros(size // 8)
    del f["provenance"]
    f.move("dense", "provenance")


@pytest.mark.parametrize("change, message", [
    (lambda f: declare(f, "/raw/strain", (MAX_SAMPLES + 1,)), f"samples (at most {MAX_SAMPLES})"),
    (lambda f: declare(f, "/raw/profile_edges", (f["raw/strain"].shape[0], 20_000)), "bins (1 to"),
    (lambda f: declare_all(f, 2_000, 9_999), "bytes of data (at most"),  # 3.7 GB declared
    (lambda f: declare(f, "/raw/strain", (MAX_CHUNKS + 1,), chunks=(1,)), f"more than {MAX_CHUNKS} chunks of (1,)"),
    (lambda f: f["provenance"].attrs.__setitem__("spec_json", "[" * 100_000 + "]" * 100_000),
     f"nests deeper than {MAX_JSON_DEPTH}"),
    (lambda f: f["provenance"].attrs.__setitem__("spec_json", "{not json"), "is not valid JSON"),
    (lambda f: f["provenance"].attrs.__setitem__("spec_json", 3.0), "is missing or not text"),
    (lambda f: dense_attribute(f, MAX_ATTRIBUTE_BYTES + 8), f"holds {MAX_ATTRIBUTE_BYTES + 8} bytes"),
    (lambda f: [f["parameters"].attrs.__setitem__(f"x{i}", i) for i in range(MAX_ATTRIBUTES + 1)],
     f"attributes (at most {MAX_ATTRIBUTES})"),
    (lambda f: f["parameters"].attrs.__setitem__("kn_pd", 1 + 2j), "is of type"),
    (lambda f: f.attrs.__setitem__("schema", np.array(["a", "b"], dtype=h5py.string_dtype())), "is of type"),
    (lambda f: f.attrs.__setitem__("schema_version", 2.5), "has schema version 2.5"),
])
def test_sizes_attributes_and_nesting_are_bounded_before_anything_is_read(base, tmp_path, change, message):
    with pytest.raises(DemFileError) as err:
        load(edit(base, tmp_path, change))
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_run_file_that_is_not_a_regular_file_is_refused(tmp_path):
    with pytest.raises(DemFileError, match="is not a regular file"):
        load(tmp_path)
