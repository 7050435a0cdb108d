"""The raw-sample schema (``config/raw_schema.toml``), read by Yade's python and the project venv alike."""

import functools
import os
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCHEMA_FILE = os.path.join(ROOT, "config", "raw_schema.toml")


@functools.lru_cache(maxsize=1)
def sample_fields():
    """``{name: {"unit": str, "shape": list, "doc": str}}`` of every raw sample field, in file order."""
    with open(SCHEMA_FILE, "rb") as fh:
        return tomllib.load(fh)["samples"]


def check_row(row):
    """Raise ``KeyError`` naming the fields a sample row lacks or has beyond the schema."""
    names = set(sample_fields())
    missing, extra = sorted(names - set(row)), sorted(set(row) - names)
    if missing or extra:
        raise KeyError(f"sample row does not match {SCHEMA_FILE}: missing {missing}, unexpected {extra}")
