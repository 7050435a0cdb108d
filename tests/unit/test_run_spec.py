"""Run specifications: presets, overrides, validation with one-line messages, names and paths."""

import dataclasses
import math

import pytest

from pipeline import spec as run_spec
from pipeline.config import load_presets
from pipeline.errors import SpecError
from pipeline.spec import resolve


def test_every_preset_resolves_and_the_paper_preset_is_section_2():
    presets = load_presets()
    assert {"paper", "reduced", "quick", "tiny"} <= set(presets)
    for name in presets:
        resolve(90, name)
    paper = resolve(90, "paper")
    assert (paper.width_d, paper.gap_d, paper.overlap_ratio, paper.kt_over_kn) == (20, 17, 0.0005, 0.5)
    assert (paper.friction_deg, paper.restitution, paper.inertial_number) == (24, 0.5, 2.9e-4)
    assert (paper.period_strain, paper.rotate_at_strain, paper.n_cycles) == (1.4, 0.7, 5)
    reduced = resolve(90, "reduced")
    assert (reduced.width_d, reduced.gap_d, reduced.inertial_number, reduced.n_cycles) == (10, 8.5, 1e-3, 2)


def test_names_and_paths():
    assert resolve(90, "quick").name == "theta090"
    assert resolve(180, "quick", rotate_at=0.7).name == "theta180"
    assert resolve(90, "quick", rotate_at=0.1).name == "theta090_rot0.10"
    assert resolve(92.5, "quick").name == "theta092.5"
    spec = resolve(30, "reduced")
    assert run_spec.output_path(spec).parts[-3:] == ("reduced", "dem", "theta030.h5")
    assert run_spec.work_dir(spec).name == "theta030.run"


def test_overrides_change_the_folder_and_are_validated():
    spec = resolve(90, "quick", overrides=run_spec.parse_overrides(["friction_deg=30", "seed=4"]))
    assert spec.friction_deg == 30 and spec.seed == 4 and isinstance(spec.seed, int)
    assert spec.folder.startswith("quick-") and spec.folder != "quick"
    assert spec.to_dict()["seed"] == 4 and spec.to_dict()["overrides"] == {"friction_deg": 30.0, "seed": 4.0}
    with pytest.raises(AttributeError, match="has no attribute 'colour'"):
        spec.colour  # noqa: B018


@pytest.mark.parametrize("kwargs, message", [
    ({"theta_deg": "abc"}, "theta='abc' is not a number"),
    ({"theta_deg": "nan"}, "theta='nan' is not a number"),
    ({"theta_deg": 90, "preset": "huge"}, "unknown preset 'huge'"),
    ({"theta_deg": 90, "overrides": {"frction_deg": 1.0}}, "unknown override key(s) frction_deg"),
    ({"theta_deg": 90, "overrides": {"gap_d": -3.0}}, "gap_d=-3.0 must be > 0"),
    ({"theta_deg": 90, "overrides": {"width_d": 9.0}}, "width_d=9.0 must be an even integer"),
    ({"theta_deg": 90, "overrides": {"n_cycles": 1.5}}, "n_cycles=1.5 must be an integer"),
    ({"theta_deg": 90, "overrides": {"restitution": math.inf}}, "restitution=inf is not finite"),
    ({"theta_deg": 90, "rotate_at": 1.4}, "rotate_at=1.4 must lie strictly between 0 and period_strain=1.4"),
    ({"theta_deg": 90, "rotate_at": "x"}, "rotate_at='x' is not a number"),
])
def test_bad_input_is_a_one_line_error_naming_the_value(kwargs, message):
    with pytest.raises(SpecError) as err:
        resolve(**{"preset": "quick", **kwargs})
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_malformed_override():
    with pytest.raises(SpecError, match="not of the form key=value"):
        run_spec.parse_overrides(["gap_d"])
    with pytest.raises(SpecError, match="gap_d='big' is not a number"):
        run_spec.parse_overrides(["gap_d=big"])


def test_a_runs_cost_is_known_from_its_spec():
    """Steps of shear = strain / (gamma_dot dt), dt = dt_safety sqrt(m_min / k_n); the samples of the protocol."""
    from dem.core.protocol import sample_strains

    spec = run_spec.resolve(180, "paper")
    cost = run_spec.cost(spec)
    dt = spec.dt_safety * math.sqrt(math.pi / 6 * spec.diameter_min_d**3 * spec.overlap_ratio)
    assert cost["steps"] == pytest.approx((0.7 + 5 * 1.4) / (2.9e-4 * dt))
    assert 2.2e7 < cost["steps"] < 2.4e7  # the paper's cell: about 23 M steps
    assert cost["samples"] == len(sample_strains(spec)) and cost["grains"] > 5000
    faster = run_spec.cost(run_spec.resolve(180, "paper", overrides={"inertial_number": 1e-3}))
    assert faster["steps"] == pytest.approx(cost["steps"] * 2.9e-4 / 1e-3)


def test_the_engine_names_the_folder_and_a_spec_without_one_is_yades():
    yade, lammps = resolve(90, "reduced"), resolve(90, "reduced", engine="lammps")
    assert (yade.folder, lammps.folder) == ("reduced", "reduced-lammps")
    assert resolve(90, "reduced", overrides={"seed": 2.0}, engine="lammps").folder.startswith("reduced-lammps-")
    assert lammps.to_dict()["engine"] == "lammps" and lammps.to_dict()["seed"] == yade.to_dict()["seed"]
    older = {k: v for k, v in yade.to_dict().items() if k != "engine"}  # a spec.json written before engines
    assert run_spec.same_spec(older, yade) and not run_spec.same_spec(older, lammps)
    assert not run_spec.same_spec(None, yade)
    with pytest.raises(SpecError) as err:
        resolve(90, "reduced", engine="foo")
    assert str(err.value) == "engine='foo' is not a DEM engine here (known: yade, lammps)"


def test_a_presets_own_value_is_no_override_and_names_no_other_folder():
    """`SET="seed=1"` on the paper preset is the paper preset's run: the same spec and folder as without it (not a
    second copy of the same run under a hash); a value that differs stays an override."""
    plain, given = resolve(180, "paper", engine="lammps"), resolve(180, "paper", overrides={"seed": 1}, engine="lammps")
    assert given.overrides == {} and given.folder == plain.folder == "paper-lammps"
    reduced = resolve(180, "reduced", overrides={"inertial_number": 1e-3, "seed": 2})
    assert reduced.overrides == {"seed": 2} and reduced.folder == run_spec.run_folder("reduced", "yade", {"seed": 2})
    with pytest.raises(SpecError, match="seed='one' is not a number"):
        resolve(180, "paper", overrides={"seed": "one"})


def test_the_spec_has_one_typed_field_per_key_of_the_presets_and_reads_older_files():
    """``DemSpec`` (``dem/core/spec.py``) lists exactly ``config/dem.toml``'s keys, in its order; a spec written before
    engines and dense samples existed reads as Yade's without dense samples; an unknown or missing key is refused."""
    import tomllib

    from dem.core.spec import DemSpec
    from pipeline.config import PRESETS_FILE

    with open(PRESETS_FILE, "rb") as fh:
        assert DemSpec.value_keys() == tuple(tomllib.load(fh)["defaults"])
    spec = resolve(90, "reduced")
    assert DemSpec.from_dict(spec.to_dict()) == spec and isinstance(spec.n_cycles, int)
    legacy = ("engine", "dense_window_strain", "dense_sample_strain", "contact_track_strain")
    older = {k: v for k, v in spec.to_dict().items() if k not in legacy}
    assert DemSpec.from_dict(older) == dataclasses.replace(spec, dense_window_strain=0.0, dense_sample_strain=0.0,
                                                           contact_track_strain=0.0)  # no contact budget
    with pytest.raises(ValueError, match=r"unknown \['colour'\]"):
        DemSpec.from_dict({**spec.to_dict(), "colour": 3})
    with pytest.raises(ValueError, match=r"missing \['gap_d'\]"):
        DemSpec.from_dict({k: v for k, v in spec.to_dict().items() if k != "gap_d"})
