"""The DEM presets of ``config/dem.toml``, read once for every stage: each preset merged onto ``[defaults]``.

Units as in ``config/dem.toml`` (lengths d, stresses p, densities rho; strain t*gamma_dot). Validation of a
run's full spec is ``pipeline.spec``'s; this module only reads the table.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from .errors import SpecError
from .paths import CONFIG_DIR

PRESETS_FILE = CONFIG_DIR / "dem.toml"


def check_presets(names: list[str]) -> list[str]:
    """``names`` if every one is a preset; a one-line error naming the unknown ones otherwise."""
    known = load_presets()
    bad = [p for p in names if p not in known]
    if bad:
        raise SpecError(f"unknown preset(s) {', '.join(bad)} (known: {', '.join(known)})")
    return names


def load_presets(path: Path = PRESETS_FILE) -> dict[str, dict]:
    """All presets of ``path``, each merged onto ``[defaults]``."""
    try:
        with open(path, "rb") as fh:
            table = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise SpecError(f"cannot read presets {path}: {exc}") from None
    defaults = table.pop("defaults", None)
    if not isinstance(defaults, dict):
        raise SpecError(f"{path}: no [defaults] table")
    presets = {}
    for name, values in table.items():
        unknown = sorted(set(values) - set(defaults))
        if unknown:
            raise SpecError(f"{path}: preset [{name}] has unknown key(s) {', '.join(unknown)}")
        presets[name] = {**defaults, **values}
    return presets


def protocol_defaults(path: Path = PRESETS_FILE) -> dict:
    """The protocol of Fig. 1 as ``[defaults]`` declares it: period, pre-strain, sampling (strain units)."""
    with open(path, "rb") as fh:
        defaults = tomllib.load(fh)["defaults"]
    return {k: defaults[k] for k in ("period_strain", "pre_strain", "sample_strain")}
