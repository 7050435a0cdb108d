"""The raw-sample schema (``config/raw_schema.toml``), read by the engines' python3 and the project venv alike."""

import functools
import os
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCHEMA_FILE = os.path.join(ROOT, "config", "raw_schema.toml")


@functools.lru_cache(maxsize=1)
def _tables():
    with open(SCHEMA_FILE, "rb") as fh:
        return tomllib.load(fh)


def sample_fields():
    """``{name: {"unit": str, "shape": list, "doc": str}}`` of every raw sample field, in file order."""
    return _tables()["samples"]


def contact_fields():
    """The contact budget's fields (``[contacts]``), recorded by runs that track their contacts."""
    return _tables()["contacts"]


def contact_fields_of(version):
    """``{name: (stored name, info)}`` of the contact fields a run file of schema ``version`` holds: those whose
    ``since`` is not later, each under the name it had in that version (``was`` before version 4)."""
    return {name: (info.get("was", name) if version < 4 else name, info)
            for name, info in contact_fields().items() if info.get("since", 0) <= version}


def check_row(row, contacts=False):
    """Raise ``KeyError`` naming the fields a sample row lacks or has beyond the schema (with the contact budget's
    where ``contacts``)."""
    names = set(sample_fields()) | (set(contact_fields()) if contacts else set())
    missing, extra = sorted(names - set(row)), sorted(set(row) - names)
    if missing or extra:
        raise KeyError(f"sample row does not match {SCHEMA_FILE}: missing {missing}, unexpected {extra}")
