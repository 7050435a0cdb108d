"""Which runs fit, compare and figures read: the data set of a preset, its folder, and Make's view of it."""

import dataclasses

import pytest

import model
from pipeline import spec as run_spec
from pipeline.calibration import naming
from pipeline.calibration.naming import fit_folder
from pipeline.dataset import lookup, selection
from pipeline.dataset.selection import DataSet
from pipeline.errors import PipelineError
from tests.helpers import synthetic_file

DECLARED = '[reduced]\nengine = "lammps"\nset = { inertial_number = 0.002 }\n'


def declared(tmp_path, text=DECLARED):
    path = tmp_path / "datasets.toml"
    path.write_text(text)
    return path


def reversal(root, folder, preset="reduced", **kw):
    (root / folder / "dem").mkdir(parents=True, exist_ok=True)
    return synthetic_file(root / folder / "dem", name="theta180", n_cycles=1, preset=preset, **kw)


def test_a_data_set_lives_in_the_folder_its_first_seeds_runs_go_to():
    spec = run_spec.resolve(180, "paper", overrides={"inertial_number": 0.001}, engine="lammps")
    chosen = selection.data_set("paper", "lammps", {"inertial_number": 0.001, "seed": 3})
    assert chosen.folder == spec.folder and chosen.overrides == (("inertial_number", 0.001),)
    assert (chosen.folder, chosen.settings) == (spec.folder, ["inertial_number=0.001"])
    assert selection.data_set("reduced", "lammps").folder == "reduced-lammps"
    assert chosen.label == "paper (lammps, inertial_number=0.001)"


def test_the_preset_as_it_is_comes_first_then_the_declared_data_set(tmp_path):
    file = declared(tmp_path)
    other = DataSet("reduced", "lammps", (("inertial_number", 0.002),))
    # neither has a reversal run: the declared one, the one to make (the stage then says so)
    assert selection.data_set("reduced", roots=(tmp_path,), datasets_file=file) == other
    assert selection.data_set("reduced", "yade", roots=(tmp_path,), datasets_file=file) == DataSet("reduced")
    reversal(tmp_path, other.folder, engine="lammps", overrides={"inertial_number": 0.002})
    assert selection.data_set("reduced", roots=(tmp_path,), datasets_file=file) == other
    assert selection.data_set("reduced", "lammps", roots=(tmp_path,), datasets_file=file) == other
    assert selection.data_set("reduced", "yade", roots=(tmp_path,), datasets_file=file) == DataSet("reduced")
    reversal(tmp_path, "reduced")
    assert selection.data_set("reduced", roots=(tmp_path,), datasets_file=file) == DataSet("reduced")
    # an explicit choice is taken as it is, seeds dropped
    assert selection.data_set("reduced", overrides={"seed": 2}, roots=(tmp_path,), datasets_file=file) \
        == DataSet("reduced")


def test_the_most_faithful_preset_counts_a_declared_data_sets_runs(tmp_path, monkeypatch):
    monkeypatch.setattr(selection, "DATASETS_FILE", declared(tmp_path))
    assert selection.most_faithful_preset((tmp_path,)) == "quick"
    reversal(tmp_path, run_spec.run_folder("reduced", "lammps", {"inertial_number": 0.002}), engine="lammps",
             overrides={"inertial_number": 0.002})
    assert selection.most_faithful_preset((tmp_path,)) == "reduced"


def test_a_data_sets_seeds_are_its_variants_with_the_same_overrides_besides_the_seed(tmp_path):
    i = {"inertial_number": 0.002}
    for overrides in (i, {**i, "seed": 2}, {"seed": 2}, {**i, "friction_deg": 30.0}):
        reversal(tmp_path, run_spec.run_folder("reduced", "lammps", overrides), engine="lammps", overrides=overrides)
    chosen = DataSet("reduced", "lammps", (("inertial_number", 0.002),))
    assert sorted(r.overrides.get("seed", 1) for r in lookup.reversal_seeds(chosen, (tmp_path,))) == [1, 2]
    assert [r.overrides for r in lookup.preset_runs(chosen, (tmp_path,))] == [i]
    assert [r.overrides for r in lookup.reversal_seeds(DataSet("reduced", "lammps"), (tmp_path,))] == [{"seed": 2}]


@pytest.mark.parametrize("text, message", [
    ('[reduced]\nengine = "foo"\n', "engine='foo' is not a DEM engine"),
    ('[reduced]\nset = { nosuch = 1 }\n', "unknown override key(s) nosuch"),
    ('[reduced]\nengines = "lammps"\n', "[reduced] has unknown key(s) engines"),
    ('[reduced\n', "cannot read"),
])
def test_a_bad_declaration_is_one_line(tmp_path, text, message):
    with pytest.raises(PipelineError, match=message.replace("[", r"\[").replace("(", r"\(").replace(")", r"\)")):
        selection.data_set("reduced", roots=(tmp_path,), datasets_file=declared(tmp_path, text))


def test_each_fit_writes_a_folder_of_its_own_named_by_what_sets_its_numbers():
    """Jackknives over angles and over seeds, fits on some angles, past the jump, with every stress component, per
    angle, of another law, without the first cycles: each its own folder, so that one does not replace another's
    files; the defaults name nothing."""
    names = [fit_folder(None, "angles"), fit_folder(None, "angles", fit_from=0.005),
             fit_folder(None, "seeds", stress="all"), fit_folder([180.0, 90.0], fit_from=0.005),
             fit_folder([180.0, 90.0], stress="all"),
             fit_folder([180.0, 90.0, 60.0, 30.0], fit_from=0.01, stress="all"),
             fit_folder(), fit_folder(variant="jump"), fit_folder(None, "seeds", variant="loading"),
             fit_folder(weight="angles", skip_cycles=1), fit_folder(stress="shear", weight="runs", variant="rk2025")]
    assert names == ["fit-jackknife-angles", "fit-jackknife-angles-from0.005", "fit-jackknife-seeds-all",
                     "fit-angles-180-90-from0.005", "fit-angles-180-90-all", "fit-angles-180-90-60-30-from0.01-all",
                     "fit", "fit-jump", "fit-jackknife-seeds-loading", "fit-per-angle-skip1", "fit"]


def test_the_tables_of_fits_go_beside_the_fit_of_the_same_weighting_and_cycles():
    """``make fit-definitions``, ``fit-from`` and ``fit-profile`` write into the folder ``make fit`` with the same
    WEIGHT and SKIP_CYCLES writes: a table of one never replaces another's."""
    from pipeline.calibration.options import table_folder

    chosen = DataSet("paper", "lammps")
    folders = [table_folder(chosen, "runs"), table_folder(chosen, "angles"),
               table_folder(dataclasses.replace(chosen, skip_cycles=1), "angles")]
    assert [f.name for f in folders] == ["fit", "fit-per-angle", "fit-per-angle-skip1"]
    assert len({f.parent for f in folders}) == 1 and folders[0].parent.name == chosen.folder


def test_the_names_defaults_are_the_stages_defaults():
    from pipeline.calibration import global_fit

    assert naming.LAW_DEFAULT == model.params.DEFAULT_VARIANT
    assert (naming.STRESS_DEFAULT, naming.WEIGHT_DEFAULT) == (global_fit.STRESS_DEFAULT, global_fit.WEIGHT_DEFAULT)
    assert naming.STRESS_DEFAULT in global_fit.STRESS_FITS and naming.WEIGHT_DEFAULT in global_fit.WEIGHTS


def test_a_data_set_given_its_presets_own_value_is_the_presets_own():
    assert selection.data_set("paper", "lammps", {"inertial_number": 2.9e-4}) == DataSet("paper", "lammps")
    assert selection.data_set("paper", "lammps", {"inertial_number": 1e-3}).folder == "paper-lammps-e29c082a"
