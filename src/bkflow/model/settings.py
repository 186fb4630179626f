"""The analysis settings (``AnalysisSettings``): every choice the analysis makes that
docs/model.md leaves open, beside ``RunSpec``, and the revision of the analysis code."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from bkflow.model.checks import (
    SpecError,
    check_fields,
    checked,
    choice,
    fraction,
    integer,
    interval,
    number,
)
from bkflow.model.params import (
    LARGE_DROP_FACTOR,
    PSI_CRYSTAL,
    PSI_LATE_FRACTION,
    REPORT_THRESHOLDS,
    S_X,
    SPAN_FRACTION,
    TRANSIENT_RULES,
    RunSpec,
)

#: revision of the analysis code: raised whenever a change to it changes a summary, so that
#: every summary made before is stale and redone (recorded in summary.json)
ANALYSIS_REVISION = 12


#: the most blocks the trend test takes (``--analysis n_blocks``)
MAX_BLOCKS = 100


@dataclass(frozen=True)
class AnalysisSettings:
    """Every choice the analysis makes that docs/model.md leaves open, beside ``RunSpec``.

    A summary records the settings it was made under (resolved for its run); one made under
    other settings is stale and is redone from the run's files, never by running LAMMPS
    again. ``slip_threshold`` and ``transient`` default to the run's own (None), which are
    also what fix bk/slips recorded; other values are allowed (slips without snapshots are
    then counted, not guessed).
    """

    #: slip threshold, fraction of mu_s sigma_n (None: the run's RunSpec.slip_threshold)
    slip_threshold: float | None = checked(None, number(gt=0, lt=1, optional=True,
                                                        noun="a number "))
    #: transient, fraction of the run (None: the run's RunSpec.transient); used by the
    #: transient_rule "fixed"
    transient: float | None = checked(None, fraction(optional=True))
    #: fixed: the first ``transient`` of the run; detect: from the stress series by
    #: equilibration detection (bkflow.observables.stationarity.equilibration_time)
    transient_rule: str = checked("fixed", choice(TRANSIENT_RULES))
    #: blocks and level of the trend test (bkflow.observables.stationarity); at most
    #: MAX_BLOCKS: blocks shorter than the stress's memory make the test's residuals
    #: correlated, and the summary carries every block's mean
    n_blocks: int = checked(10, integer(3, le=MAX_BLOCKS))
    alpha: float = checked(0.05, interval(0, 1))
    #: large drops: drop > large_drop_factor * mean drop after the transient
    large_drop_factor: float = checked(LARGE_DROP_FACTOR, number(gt=0, noun="a number "))
    s_x: float = checked(S_X, number(gt=0, noun="a number "))
    span_fraction: float = checked(SPAN_FRACTION, fraction(closed_high=True))
    psi_crystal: float = checked(PSI_CRYSTAL, fraction(closed_high=True))
    psi_late_fraction: float = checked(PSI_LATE_FRACTION, fraction(closed_high=True))
    report_thresholds: tuple = checked(REPORT_THRESHOLDS)
    #: lower cut of the stress-drop power law, as a multiple of the slip threshold (the
    #: smallest drop that counts as a slip); None = chosen by the KS rule of Clauset et al.
    drop_x_min_over_threshold: float | None = checked(1.0, number(gt=0, optional=True,
                                                                  noun="a number "))

    def __post_init__(self):
        try:
            thresholds = tuple(float(v) for v in self.report_thresholds)
        except (TypeError, ValueError):
            thresholds = ()
        if not thresholds or not all(math.isfinite(v) and 0 < v < 1 for v in thresholds):
            raise SpecError("analysis setting report_thresholds must be numbers in (0, 1) "
                            f"(fractions of mu_s sigma_n), got {self.report_thresholds!r}")
        object.__setattr__(self, "report_thresholds", thresholds)
        check_fields(self, "analysis setting ")

    def resolved(self, spec: RunSpec) -> AnalysisSettings:
        """These settings with the run's own values filled in where they defer to it."""
        return dataclasses.replace(
            self,
            slip_threshold=spec.slip_threshold if self.slip_threshold is None
            else self.slip_threshold,
            transient=spec.transient if self.transient is None else self.transient)

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["report_thresholds"] = list(self.report_thresholds)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> AnalysisSettings:
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(d) - names
        if unknown:
            raise SpecError(f"unknown analysis setting(s): {', '.join(sorted(unknown))}; "
                            f"known: {', '.join(sorted(names))}")
        return cls(**d)
