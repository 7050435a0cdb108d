"""Debian's LAMMPS (python3-lammps, in Debian's python3): the contact law matched to Yade's."""

import json
import subprocess

import pytest

from pipeline.runs import spec as run_spec
from pipeline.runs import yade as yade_command
from tests.helpers import assert_contact_law

pytestmark = pytest.mark.lammps


def test_lammps_collisions_match_the_contact_law_as_yade_does(tmp_path):
    """Same checks, same tolerances as Yade's (``test_collisions_restitution_stiffness_ratio_and_sliding``):
    restitution of the smallest, mean and largest pairs, k_t/k_n, k_n, and sliding at tan 24 degrees."""
    spec = run_spec.resolve(90, "paper").to_dict()
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    proc = subprocess.run(["/usr/bin/python3", "-m", "dem.lammps_collision", tmp_path / "spec.json",
                           tmp_path / "out.json"], capture_output=True, text=True, cwd=tmp_path,
                          env=yade_command.environment())
    assert proc.returncode == 0, "LAMMPS is missing? `make system-lammps` installs it\n" + proc.stderr
    assert_contact_law(json.loads((tmp_path / "out.json").read_text()), spec)
