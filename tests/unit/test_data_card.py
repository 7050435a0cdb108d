"""The data card's inventory: one row per committed run file, read from the file, and a check that fails when the
card and the files part."""

import h5py
import pytest

from pipeline.dataset import card, lookup, manifest
from pipeline.dataset.selection import DataSet
from pipeline.errors import DemFileError
from pipeline.paths import ROOT
from tests.helpers import run_main, synthetic_file

MARKED = f"# card\n\nbefore\n\n{card.BEGIN}\n{card.END}\n\nafter\n"


def run_file(folder, **kw):
    folder.mkdir(parents=True, exist_ok=True)
    return synthetic_file(folder, **kw)


@pytest.mark.slow  # reads every committed run (1 GB): its cost grows with the data, not the code
def test_the_committed_card_lists_every_committed_run_as_its_file_says():
    result = run_main(card.main, ["--check"])
    assert result.returncode == 0, result.stderr
    block = (ROOT / "data/reference/README.md").read_text().split(card.BEGIN)[1].split(card.END)[0]
    inventory, drifts = block.split("Drift over the cycles")
    files = len(list((ROOT / "data/reference").glob("*/dem/*.h5")))
    assert inventory.count("\n| `") == files and drifts.count("\n| `") == files


def test_the_inventory_follows_the_files_and_the_check_fails_when_they_part(tmp_path):
    root = tmp_path / "reference"
    run_file(root / "p" / "dem", theta=90.0, name="theta090", n_cycles=3, preset="p")
    (root / "README.md").write_text(MARKED)
    assert run_main(card.main, ["--root", str(root), "--check"]).returncode == 1  # an empty table
    assert run_main(card.main, ["--root", str(root)]).returncode == 0
    text = (root / "README.md").read_text()
    assert text.startswith("# card\n\nbefore\n") and text.endswith("\nafter\n")
    row = next(line for line in text.splitlines() if line.startswith("| `p/dem/theta090.h5`"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1].startswith("yade") and cells[2] == "90" and cells[3] == "0.7" and cells[6] == "3"
    assert run_main(card.main, ["--root", str(root), "--check"]).returncode == 0
    run_file(root / "p-1234abcd" / "dem", theta=180.0, name="theta180", preset="p")
    result = run_main(card.main, ["--root", str(root), "--check"])
    assert result.returncode == 1 and "out of date: make data-card" in result.stderr


def test_a_card_without_its_markers_is_a_one_line_error(tmp_path):
    root = tmp_path / "reference"
    run_file(root / "p" / "dem", name="theta180", preset="p")
    (root / "README.md").write_text("# a card with no markers\n")
    result = run_main(card.main, ["--root", str(root)])
    assert result.returncode == 2 and "needs the two markers" in result.stderr and len(result.stderr.splitlines()) == 1
    assert (root / "README.md").read_text() == "# a card with no markers\n"

def committed(tmp_path, monkeypatch):
    """A committed data folder (the reference folder, by ``manifest.REFERENCE_DIR``) with one run and its card."""
    root = tmp_path / "reference"
    path = run_file(root / "p" / "dem", name="theta180", n_cycles=2, preset="p")
    (root / "README.md").write_text(MARKED)
    assert run_main(card.main, ["--root", str(root)]).returncode == 0
    monkeypatch.setattr(manifest, "REFERENCE_DIR", root)
    return root, path


def test_a_committed_run_changed_after_its_card_is_refused_before_it_is_fitted(tmp_path, monkeypatch):
    """The manifest keeps each file's SHA-256; a data set's file that no longer matches it (ten samples of tau set to
    37 p, say) is a one-line error when the stages look the data set up, not a fit that silently moves."""
    root, path = committed(tmp_path, monkeypatch)
    assert manifest.read(root) == {"p/dem/theta180.h5": manifest.sha256(path)}
    assert len(lookup.preset_runs(DataSet("p"), (root,))) == 1
    with h5py.File(path, "r+") as f:
        f["raw/stress_contact"][10:20, 0, 1] = 37.0
    with pytest.raises(DemFileError) as err:
        lookup.preset_runs(DataSet("p"), (root,))
    assert "does not match its SHA-256" in str(err.value) and "\n" not in str(err.value)


def rewrite(edit):
    """A change of the manifest's text by ``edit``."""
    def change(root, path):
        (root / manifest.MANIFEST).write_text(edit((root / manifest.MANIFEST).read_text()))
    return change


def replace_by_link(root, path):
    kept = path.with_name("kept.bin")
    path.rename(kept)
    path.symlink_to(kept)


def replace_manifest_by_link(root, path):
    (root / manifest.MANIFEST).rename(root / "kept.sha256")
    (root / manifest.MANIFEST).symlink_to(root / "kept.sha256")


#: every way the checks used to turn themselves off, each now an error: (what is done, the error's words)
FAIL_OPEN = {
    "the manifest deleted": (lambda root, path: (root / manifest.MANIFEST).unlink(), "cannot be read"),
    "the manifest a link": (replace_manifest_by_link, "cannot be read"),
    "the card's marker changed": (lambda root, path: (root / "README.md").write_text(
        (root / "README.md").read_text().replace("inventory", "inventroy")), None),
    "the row deleted": (rewrite(lambda text: ""), "has no row"),
    "a stray bar in the row": (rewrite(lambda text: text.replace("  ", "  |")), "is not a row"),
    "./ in the row's path": (rewrite(lambda text: text.replace("  ", "  ./")), "is not a row"),
    "../ in the row's path": (rewrite(lambda text: text.replace("  ", "  p/../")), "is not a row"),
    "a short digest": (rewrite(lambda text: text[:16] + text[64:]), "is not a row"),
    "the row twice": (rewrite(lambda text: text + text), "a second time"),
    "another file's row": (rewrite(lambda text: text.replace("theta180", "theta090")), "has no row"),
    "the file a link": (replace_by_link, "is not a regular file"),
}


@pytest.mark.parametrize("how", sorted(FAIL_OPEN))
def test_the_integrity_check_fails_closed(tmp_path, monkeypatch, how):
    root, path = committed(tmp_path, monkeypatch)
    with h5py.File(path, "r+") as f:  # a change the check must see, whatever else happens
        f["raw/stress_contact"][10:20, 0, 1] = 37.0
    change, message = FAIL_OPEN[how]
    change(root, path)
    with pytest.raises(DemFileError) as err:
        lookup.preset_runs(DataSet("p"), (root,))
    assert (message or "does not match its SHA-256") in str(err.value) and "\n" not in str(err.value)


def test_a_run_file_the_manifest_does_not_list_is_refused(tmp_path, monkeypatch):
    root, _ = committed(tmp_path, monkeypatch)
    run_file(root / "p" / "dem", theta=90.0, name="theta090", n_cycles=2, preset="p")
    with pytest.raises(DemFileError, match="theta090.h5 has no row in"):
        lookup.preset_runs(DataSet("p"), (root,))
    assert run_main(card.main, ["--root", str(root), "--check"]).returncode == 1
    assert run_main(card.main, ["--root", str(root)]).returncode == 0
    assert len(lookup.preset_runs(DataSet("p"), (root,))) == 2
