"""The files the stages hand each other (``pipeline/schema/``): what the writers write reads back as the same
typed object, and a file of another version, with a key missing or unknown, or not JSON, is refused in one line."""

import dataclasses
import json

import h5py
import pytest

import model
from pipeline import schema
from pipeline.errors import PipelineError
from tests.helpers import fit_summary


def metrics(**extra) -> schema.Metrics:
    errors = schema.Errors(["A12"], [schema.ErrorRow("theta180", 1, "Table 2", {"A12": 0.1})], [])
    return schema.Metrics(preset="p", data_set="p (yade)", definitions=schema.Definitions("nominal"),
                          param_sets=schema.ParamSets(model.Params(), model.Params().replace(C=-5.0)),
                          errors=errors, after_changes=schema.AfterChanges([], []), **extra)


REVERSAL = schema.Reversal(0.8, 0.6, [0.58, 0.61], {"Table 2": 0.88, "our fit": 0.8}, {"Table 2": 0.9, "our fit": 0.85})


def test_each_file_reads_back_as_written_and_names_its_version(tmp_path):
    path = tmp_path / "metrics.json"
    path.write_text(json.dumps(metrics(reversal=REVERSAL).to_dict()))
    back = schema.read_metrics(path)
    assert back == metrics(reversal=REVERSAL) and back.param_sets.our_fit.C == -5.0
    assert back.errors.rows[0].errors == {"A12": 0.1}
    written = json.loads(path.read_text())
    assert written["errors"]["rows"] == [{"run": "theta180", "seed": 1, "parameters": "Table 2",
                                          "A12": 0.1}]  # a table's columns beside its row's name
    assert written["param_sets"]["our fit"]["C"] == -5.0 and back.param_sets.labelled()["our fit"].C == -5.0
    assert json.loads(path.read_text())["schema_version"] == schema.METRICS_VERSION
    assert "relaxation" not in json.loads(path.read_text())  # none: not written, as before versions
    estimates = schema.Estimates({"C": -5.0}, ["C"], [-5.0], [None], None, None, None, 1.2, 30.0, 9, True, "ok", [])
    cell = schema.ResidualCell(180.0, 0.7, "A12", [0.0, 0.005], 2, 3.0, 0.4, 8.0)
    fit = fit_summary(notes=["a note"], estimates=estimates, runs=["theta180.h5"])
    fit = dataclasses.replace(fit, global_fit=dataclasses.replace(fit.global_fit, residual_map=[cell]))
    schema.write_fit(tmp_path / "fit.json", fit)
    written = json.loads((tmp_path / "fit.json").read_text())
    assert schema.read_fit(tmp_path / "fit.json") == fit and written["global"]["estimates"]["misfit"] == 1.2
    assert written["global"]["residual_map"][0]["window"] == [0.0, 0.005] and written["options"]["definitions"] == {
        "strain": "bulk", "phi": "central", "pressure": "target"}  # every group of the fit a record of its own
    written["options"]["definitions"]["strain"] = "sideways"
    (tmp_path / "fit.json").write_text(json.dumps(written))
    with pytest.raises(PipelineError, match="fit.json: options: definitions: strain='sideways' is not one of bulk"):
        schema.read_fit(tmp_path / "fit.json")
    schema.write_params(tmp_path / "params.json", model.Params(), {"definitions": {"strain": "bulk"}})
    found = schema.read_params(tmp_path / "params.json")
    assert found.params == model.Params() and found.definitions == {"strain": "bulk"}
    assert found.metadata["schema_version"] == schema.PARAMS_METADATA_VERSION
    assert model.Params.from_json((tmp_path / "params.json").read_text()) == model.Params()  # what continuum codes read


def test_a_fits_resamplings_read_back_as_records_under_the_files_keys(tmp_path):
    step = schema.StepwiseBootstrap(["C_eq15"], 4, 5, [0.1], [0.08], [-5.2], [-4.9], 0)
    boot = schema.Bootstrap(["C"], [[-5.0], [-5.1]], [0.07], 0.2, 0, [[-5.1, -4.9]], [[-5.2, -4.8]], step)
    jack = schema.Jackknife(["C"], ["seed 1", "seed 2", "seed 3"], [[-5.0], [-5.1], [-4.9]], [0.1], [1.2], [None],
                            [[0.5], [None], [-0.5]], "seeds")
    fit = fit_summary(bootstrap=boot, jackknife=jack)
    schema.write_fit(tmp_path / "fit.json", fit)
    written = json.loads((tmp_path / "fit.json").read_text())
    assert written["bootstrap"]["stepwise"]["percentile_97.5"] == [-4.9] and written["jackknife"]["over"] == "seeds"
    back = schema.read_fit(tmp_path / "fit.json")
    assert back == fit and back.bootstrap.stepwise.percentile_2_5 == [-5.2] and back.jackknife.shift_z[1] == [None]
    written["jackknife"]["colour"] = 1
    (tmp_path / "fit.json").write_text(json.dumps(written))
    with pytest.raises(PipelineError, match=r"is not a jackknife of this version: missing \[\], unknown \['colour'\]"):
        schema.read_fit(tmp_path / "fit.json")


@pytest.mark.parametrize("change, fragment", [
    (lambda d: {**d, "schema_version": 1}, "is a comparison of version 1; this code reads version 2"),
    (lambda d: {k: v for k, v in d.items() if k != "errors"}, "missing ['errors']"),
    (lambda d: {**d, "colour": 1}, "unknown ['colour']"),
    (lambda d: {**d, "param_sets": {**d["param_sets"], "our fit": {"C": 1.0}}}, "param_sets: our_fit: missing keys n"),
    (lambda d: {**d, "definitions": {"strain": "sideways"}}, "strain='sideways' is not one of"),
    (lambda d: [d], "not a comparison (not a JSON object)"),
])
def test_a_damaged_or_foreign_metrics_file_is_refused_in_one_line(tmp_path, change, fragment):
    path = tmp_path / "metrics.json"
    path.write_text(json.dumps(change(metrics().to_dict())))
    with pytest.raises(PipelineError) as err:
        schema.read_metrics(path)
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_a_file_from_before_versions_reads_as_version_one_and_others_are_refused(tmp_path):
    old = {k: v for k, v in fit_summary().to_dict().items() if k not in ("schema_version", "made_from")}
    (tmp_path / "fit.json").write_text(json.dumps(old))
    with pytest.raises(PipelineError, match="is a fit summary of version 1; this code reads version 3"):
        schema.read_fit(tmp_path / "fit.json")  # from before fits recorded what made them: refit
    (tmp_path / "fit.json").write_text(json.dumps(fit_summary().to_dict()))
    assert schema.read_fit(tmp_path / "fit.json") == fit_summary()
    (tmp_path / "fit.json").write_text("{not json")
    with pytest.raises(PipelineError, match="is not valid JSON"):
        schema.read_fit(tmp_path / "fit.json")
    with pytest.raises(PipelineError, match="not found: run `make fit` first"):
        schema.read_fit(tmp_path / "none.json")
    schema.write_params(tmp_path / "params.json", model.Params(), {"schema_version": 7})
    with pytest.raises(PipelineError, match="metadata of version 7"):
        schema.read_params(tmp_path / "params.json")
    with h5py.File(tmp_path / "compare.h5", "w") as f:
        schema.stamp_compare(f)
        schema.check_compare(f, "compare.h5")
        f.attrs["schema_version"] = 2
        with pytest.raises(PipelineError, match="not a comparison of this version"):
            schema.check_compare(f, "compare.h5")
