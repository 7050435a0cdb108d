"""Every record reader bounds the JSON it parses before parsing (nesting and size) and takes whole-number versions
only: a file or attribute nested 100 000 deep, or versioned 'abc', is one line naming it, never a traceback."""

import json

import h5py
import pytest

import model
from pipeline import io, schema
from pipeline.errors import PipelineError
from pipeline.schema.metrics import check_compare

DEEP = "[" * 100_000 + "]" * 100_000


def write(path, text):
    path.write_text(text)
    return path


#: each reader of a JSON file, by the file it reads
FILE_READERS = {
    "fit.json": schema.read_fit,
    "metrics.json": schema.read_metrics,
    "models.json": schema.read_models,
    "fit_from.json": lambda p: schema.read_fit_rows(p, "fit-from"),
    "params.json": schema.read_params,
    "params (model)": io.read_params,
}


@pytest.mark.parametrize("reader", FILE_READERS)
def test_a_file_nested_too_deep_is_one_line(tmp_path, reader):
    path = write(tmp_path / "file.json", DEEP)
    with pytest.raises(ValueError) as caught:  # PipelineError, or model's ParameterError for a parameter file
        FILE_READERS[reader](path)
    assert "nests deeper than" in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.parametrize("reader", ["fit.json", "metrics.json", "models.json"])
@pytest.mark.parametrize("version", ["abc", 2.5, True, None, [3]])
def test_a_record_whose_version_is_not_a_whole_number_is_one_line(tmp_path, reader, version):
    path = write(tmp_path / "file.json", json.dumps({"schema_version": version}))
    with pytest.raises(PipelineError, match="is not a whole number"):
        FILE_READERS[reader](path)


def test_json_text_bounds_depth_and_refuses_what_json_cannot_hold():
    assert model.json_text.loads("[[1]]", "x") == [[1]]
    with pytest.raises(ValueError, match="x nests deeper than 32 levels"):
        model.json_text.loads("[" * 33 + "]" * 33, "x")
    with pytest.raises(ValueError, match="y is not valid JSON"):
        model.json_text.loads("{", "y")
    with pytest.raises(model.params.ParameterError, match="not a parameter file"):
        model.Params.from_json('{"C": ' + "9" * 5000 + "}")


def test_hdf5_attributes_holding_json_are_bounded_too(tmp_path):
    path = tmp_path / "models.h5"
    with h5py.File(path, "w") as f:
        f.attrs.update(schema=schema.models.MODELS_SCHEMA, schema_version=schema.models.MODELS_VERSION, made_from=DEEP)
    with pytest.raises(PipelineError, match="nests deeper than"):
        schema.models.read_models_h5(path, "memory")
    with h5py.File(path, "w") as f:
        f.attrs.update(schema=schema.models.MODELS_SCHEMA, schema_version=schema.models.MODELS_VERSION,
                       made_from="not json")
    with pytest.raises(PipelineError, match="is not valid JSON"):
        schema.models.read_models_h5(path, "memory")
    with h5py.File(tmp_path / "compare.h5", "w") as f:
        f.attrs.update(schema=schema.metrics.COMPARE_SCHEMA, schema_version="abc")
        with pytest.raises(PipelineError, match="'abc' is not a whole number"):
            check_compare(f, tmp_path / "compare.h5")


@pytest.mark.parametrize("field, value", [("fit_from", "abc"), ("fit_from", True), ("notes", "one note"),
                                          ("notes", [1, 2])])
def test_a_plain_field_of_another_type_is_one_line_naming_it(tmp_path, field, value):
    """Fields that hold plain values are checked against their annotation where the file is read."""
    from tests.helpers import fit_summary

    data = fit_summary().to_dict()
    where = data["options"] if field == "fit_from" else data
    where[field] = value
    path = write(tmp_path / "fit.json", json.dumps(data))
    with pytest.raises(PipelineError, match=f"{field}=.* is not of its type"):
        schema.read_fit(path)
