"""The protocols of a run (``PROTOCOLS``): the RunSpec fields each sets from an accuracy preset."""

from __future__ import annotations

from bkflow.model.checks import SpecError
from bkflow.model.params import PROTOCOLS, STEADY_COMPANION, STEADY_START
from bkflow.model.timestep import ACCURACY


def protocol_fields(protocol: str = "steady", accuracy: str = "default", *,
                    start: str | None = None, t_end: float | None = None,
                    dt_factor: float | None = None, until_steady: bool = False,
                    target_error: float | None = None, companion: str | None = "",
                    fixed: bool = False) -> dict:
    """The RunSpec fields a protocol sets (start, companion, until_steady, t_end, accuracy,
    dt_factor, target_error) from an accuracy preset (``ACCURACY``) and what is given explicitly
    (None: the protocol's or the preset's; ``companion`` "" for the protocol's, None for
    none). ``steady``: from STEADY_START with a companion from STEADY_COMPANION (or, when
    ``start`` is that, STEADY_START) until the pair is steady and mu_bar's error is below the
    preset's target, at most the preset's t_cap; ``paper``: from the synchronized start, a
    fixed run of the preset's t_end, no companion (``until_steady`` adds the steady rule,
    t_end is then its cap). ``fixed``: a run of a fixed length (a standalone deck, which has
    no stop rule): the steady protocol then gives its start and the preset's t_end, without
    its stop rule, and a companion or an error target only where given (the analysis of the
    run says whether it was steady).

    >>> f = protocol_fields()
    >>> f["start"], f["companion"], f["until_steady"]
    ('random', 'partial', True)
    >>> protocol_fields("paper")["start"], protocol_fields("paper")["companion"]
    ('synchronized', None)
    """
    _check(protocol, accuracy)
    preset = ACCURACY[accuracy]
    if fixed and protocol == "steady" and not until_steady:
        return _fixed_steady(accuracy, start, t_end, dt_factor, target_error, companion)
    steady = protocol == "steady" or bool(until_steady)
    default_start = STEADY_START if protocol == "steady" else "synchronized"
    default_t = preset.t_cap if protocol == "steady" else preset.t_end
    start = default_start if start is None else start
    if companion == "":
        companion = None if protocol != "steady" else (
            STEADY_COMPANION if start != STEADY_COMPANION else STEADY_START)
    return {"start": start, "companion": companion,
            "until_steady": steady,
            "t_end": default_t if t_end is None else t_end,
            "accuracy": accuracy, "dt_factor": dt_factor,
            "target_error": target_error if target_error is not None
            else preset.target_error if protocol == "steady" else None}


def _check(protocol: str, accuracy: str) -> None:
    if protocol not in PROTOCOLS:
        raise SpecError(f"protocol must be one of {', '.join(PROTOCOLS)}, got {protocol!r}")
    if accuracy not in ACCURACY:
        raise SpecError(f"accuracy must be one of {', '.join(ACCURACY)}, got {accuracy!r}")


def _fixed_steady(accuracy: str, start, t_end, dt_factor, target_error, companion) -> dict:
    """The steady protocol's fields for a run of a fixed length (``protocol_fields``'s
    ``fixed``): its start, the preset's t_end, no stop rule, a companion and an error target
    only where given."""
    return {"start": STEADY_START if start is None else start,
            "companion": None if companion == "" else companion, "until_steady": False,
            "t_end": ACCURACY[accuracy].t_end if t_end is None else t_end,
            "accuracy": accuracy, "dt_factor": dt_factor, "target_error": target_error}
