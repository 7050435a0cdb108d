"""How ``make models`` splits a data set's runs into the ones a law is fitted on and the ones that judge it, each
splitter declared once (as scikit-learn's are): ``LeaveAnglesOut`` (fit ``TRAIN_ANGLES``, predict the others and
Fig. 7's turns) and ``LeaveOneAngleOut`` (fit every angle but one, predict that one). The third test, across cells,
predicts another data set's runs from this one's and back (``judge.across``)."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import CalibrationError

#: the angles ``LeaveAnglesOut`` fits (the reversal among them); it predicts the others and Fig. 7's turns
TRAIN_ANGLES = (180.0, 30.0, 60.0, 90.0)


@dataclass(frozen=True)
class Split:
    """A fit on the runs ``train`` (indices) judged on the runs ``test``."""

    name: str
    train: tuple[int, ...]
    test: tuple[int, ...]


def protocol(run) -> str:
    """``theta`` or ``theta@rotate_at`` (Fig. 7's turns), for tables."""
    label = f"{run.theta_deg:g}"
    return label if run.default_rotation else f"{label}@{run.spec.rotate_at_strain:g}"


def _default(runs: list) -> list[int]:
    return [i for i, r in enumerate(runs) if r.default_rotation]


@dataclass(frozen=True)
class LeaveAnglesOut:
    """One split, ``angles``: the runs of the default protocol at ``train_angles`` fitted, every other run held
    out."""

    train_angles: tuple[float, ...] = TRAIN_ANGLES

    def split(self, runs: list) -> list[Split]:
        train = tuple(i for i in _default(runs) if runs[i].theta_deg in self.train_angles)
        return [Split("angles", train, tuple(i for i in range(len(runs)) if i not in train))]


@dataclass(frozen=True)
class LeaveOneAngleOut:
    """One split per angle of the default protocol, ``without <theta>``: every other angle fitted, its runs held
    out."""

    def split(self, runs: list) -> list[Split]:
        default = _default(runs)
        out = []
        for theta in sorted({runs[i].theta_deg for i in default}, reverse=True):
            left = tuple(i for i in default if runs[i].theta_deg == theta)
            out.append(Split(f"without {theta:g}", tuple(i for i in default if i not in left), left))
        return out


#: the splitters ``make models`` runs, in the order of its tables
SPLITTERS = (LeaveAnglesOut(), LeaveOneAngleOut())


def splits(runs: list, splitters=SPLITTERS) -> list[Split]:
    """Every splitter's splits of ``runs`` that have runs to fit and runs to predict (a data set of the training
    angles alone has no ``angles`` split, one angle no split at all); no split lets a test run train."""
    out = [s for splitter in splitters for s in splitter.split(runs)]
    for s in out:
        if set(s.train) & set(s.test):
            raise CalibrationError(f"split {s.name}: a held-out run is among the fitted ones")
    return [s for s in out if s.train and s.test]
