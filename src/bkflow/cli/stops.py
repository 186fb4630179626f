"""What bkflow says of an adaptive run's stop (``bkflow.cli.report``'s part for it): the rule
and the values it was met with, or what had not met it when the cap came, and what the run
would need (the length from the calibration, its cost here, and the command that continues
the run to it), from meta.json's ``adaptive`` record (``bkflow.lammps.adaptive``).
"""

from __future__ import annotations

import math

from bkflow.model.params import STEADY_AGREEMENT, STEADY_DRIFT_BOUND
from bkflow.observables.states import SWITCHING


def _e(v: float) -> str:
    """An error as the report prints it everywhere (the stop line, the summary's lines)."""
    return format(v, ".4f") if abs(v) >= 1e-3 else format(v, ".2g")


def _pair(ad: dict) -> bool:
    return ad.get("estimate") == "pair"


def stop_rules(ad: dict, companion: str | None) -> str:
    """The stop rule of an adaptive run, in words."""
    rules = []
    if ad.get("target_error") is not None:
        rules.append(f"mu_bar error <= {ad['target_error']:g}"
                     + (" (of the mean of the run and its companion)" if _pair(ad) else ""))
    if companion and ad.get("target_error") is not None:
        rules.append(f"the companion run from the {companion} start agreeing within "
                     f"{100 * (ad.get('agreement_required') or math.nan):.2g}%")
    if ad.get("until_steady"):
        rules.append(f"steady (drift bound <= {STEADY_DRIFT_BOUND:g}"
                     + (", the pair's mean stress" if companion else "") + ")")
    return " and ".join(rules)


def _reached(ad: dict, companion: str | None) -> str:
    """The rule an adaptive run met, with the values it met it with."""
    parts = []
    state = ad.get("state_at_stop")
    err = ad.get("mu_bar_err_at_stop")
    if ad.get("target_error") is not None and err is not None:
        parts.append(f"mu_bar error {_e(err)} <= {ad['target_error']:g}"
                     + (" (of the mean of the run and its companion)" if _pair(ad) else ""))
    gap = ad.get("companion_gap_at_stop")
    if companion and ad.get("target_error") is not None and gap is not None:
        parts.append(f"the companion run from the {companion} start {-100 * gap:+.2f}% from it "
                     f"(within {100 * (ad.get('agreement_required') or math.nan):.2g}%)")
    if ad.get("until_steady") and state in SWITCHING:
        parts.append(f"in the states it visited ({state})")
    elif ad.get("until_steady"):
        parts.append(f"steady (drift bound <= {STEADY_DRIFT_BOUND:g}"
                     + (", the pair's mean stress" if companion else "") + ")")
    return " and ".join(parts)


def _error_missed(ad: dict) -> str | None:
    """How mu_bar's error missed its target at the cap (None: it did not)."""
    err = ad.get("mu_bar_err_at_stop")
    target = ad.get("target_error")
    if target is None or (err is not None and err <= target):
        return None
    if err is None or not math.isfinite(err):
        return "mu_bar error not measurable yet (too few slips after the transient)"
    return (f"mu_bar error {_e(err)} > {target:g}"
            + (" (of the mean of the run and its companion)" if _pair(ad) else ""))


def _state_missed(ad: dict, state: str | None) -> str | None:
    """How the run's state missed steady at the cap (None: it did not, or a layer that
    switches between states, whose error says how far it is)."""
    if state is None or ad.get("drift_at_stop") is None or \
            not math.isfinite(ad["drift_at_stop"]):
        return "the state not testable yet"
    if state in SWITCHING:
        return None
    if state == "drifting":
        return (f"drifting: the stress still drifts ({100 * ad['drift_at_stop']:+.2f}%"
                f" +- {100 * (ad.get('drift_err_at_stop') or math.nan):.2f}%)")
    if state == "metastable" and ad.get("pair_disagrees_at_stop") and not (
            (ad.get("phase_fluctuation_at_stop") or 0) > (ad.get("memory_chi") or math.inf)):
        return None   # the pair's disagreement: said by _pair_missed
    if state == "metastable":
        return (f"metastable: the contacts still hold the start's common phase "
                f"(phase fluctuation {ad.get('phase_fluctuation_at_stop', math.nan):.3g}"
                f" > {ad.get('memory_chi', math.nan):g})")
    if (ad.get("drift_bound_at_stop") or 0) > STEADY_DRIFT_BOUND:
        return (f"a drift up to {100 * ad['drift_bound_at_stop']:.2g}% not excluded "
                f"(> {100 * STEADY_DRIFT_BOUND:g}%)")
    return None


def _pair_missed(ad: dict, companion: str | None) -> str | None:
    """How the companion run missed agreeing at the cap (None: it did not)."""
    gap = ad.get("companion_gap_at_stop")
    if not companion:
        return None
    if gap is None or not math.isfinite(gap):
        return f"the companion run ({companion} start) not comparable yet"
    agree = ad.get("agreement_required") if ad.get("target_error") is not None else None
    if ad.get("pair_disagrees_at_stop"):
        return (f"the companion run ({companion} start) disagrees: its mean stress "
                f"{-100 * gap:+.2f}% off, beyond {100 * STEADY_AGREEMENT:g}% and both errors "
                "(a start is remembered)")
    if agree is not None and abs(gap) > agree:
        return (f"the companion run ({companion} start) {-100 * gap:+.2f}% off, not yet within "
                f"{100 * agree:.2g}%")
    return None


def stop_line(ad: dict, companion: str | None = None) -> str:
    """Why an adaptive run stopped where it did (meta.json's ``adaptive`` record): the rule
    and the values it was met with, or what had not met it when the cap came."""
    head = f"ran to t = {ad['t_run']:.0f} of at most {ad['t_cap']:g}: "
    if ad.get("reached"):
        return head + f"stopped because {_reached(ad, companion)} at t = {ad['t_run']:g}"
    state = ad.get("state_at_stop")
    missed = [_error_missed(ad)]
    if ad.get("until_steady"):
        missed += [_state_missed(ad, state), _pair_missed(ad, companion)]
    missed = [m for m in missed if m is not None]
    return head + "the cap came first: " + "; ".join(
        missed or [f"not {stop_rules(ad, companion)}"])


def with_t_end(command: str, t_end: float) -> str:
    """``command`` (a bkflow command line, as meta.json records it) with ``--t-end t_end``
    in place of its own."""
    import shlex

    words, out, skip = shlex.split(command), [], 0
    for i, w in enumerate(words):
        if skip:
            skip -= 1
        elif w == "--t-end":
            skip = 1
        elif w == "--set" and i + 1 < len(words) and words[i + 1].startswith("t_end="):
            skip = 1
        elif w.startswith(("--t-end=", "--set=t_end=")) or w == "--overwrite":
            continue   # (--overwrite would redo the run the advice continues)
        else:
            out.append(w)
    return shlex.join(out + ["--t-end", f"{t_end:g}"])


def _hours(atom_steps: float, rate: float | None) -> str:
    seconds = atom_steps / rate if rate else math.nan
    if not math.isfinite(seconds):
        return "n/a"
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.2g} h"


def advice_line(ad: dict, command: str | None, rate: float | None) -> str | None:
    """What a run that missed its error target would need (``bkflow.lammps.adaptive.advice``):
    the length from the calibration of the layer's switching, its cost here, and the command
    that continues the run in place; where one run that long is above this machine's limits,
    the longest that is not, and the error it gives."""
    adv = ad.get("advice")
    if not adv:
        return None
    what = "the mean of the run and its companion" if _pair(ad) else "the run's mean"
    head = (f"  for mu_bar error <= {ad['target_error']:g} ({what}, covering the layer's "
            f"switching as calibrated on long runs) a run needs about t = {adv['t_end']:g}, "
            f"{adv['atom_steps']:.2g} atom-steps (about {_hours(adv['atom_steps'], rate)} "
            "here)")
    if adv.get("above_limits") is None:
        return head + (f": {with_t_end(command, adv['t_end'])} continues this run to it"
                       if command else ": continue the run with that t_end")
    head += f", beyond what one run may take here ({adv['above_limits']})"
    top = adv.get("t_end_max")
    if top is None:
        return head
    return (head + f"; the longest that may, t = {top:g}, gives about "
            f"{adv.get('err_at_max') or math.nan:.2g}"
            + (f": {with_t_end(command, top)} continues this run to it" if command else ""))


def answered_line(out, meta: dict, t_end: float) -> str:
    """A request that the finished run in ``out`` already answers (it stopped by its rule
    before the requested cap, where the request's rule stops too): nothing ran."""
    ad = meta.get("adaptive") or {}
    return (f"{out}: the run there already answers this request: it stopped by its rule at "
            f"t = {ad.get('t_run', math.nan):g}, and a run asked for this way (cap "
            f"{t_end:g}) stops at the same check; nothing was run (its record keeps the "
            "request it was run for; a smaller --target-error continues it where that is not "
            "met yet)")


def adaptive_lines(ad: dict, companion: str | None, command: str | None = None,
                   rate: float | None = None) -> list[str]:
    """The stop of an adaptive run, and what it would need where its cap came first: the
    length the calibration gives for its error target (``advice_line``), else a longer
    --t-end."""
    lines = ["  adaptive: " + stop_line(ad, companion)]
    if ad["reached"]:
        return lines
    more = advice_line(ad, command, rate)
    if more is None:
        more = ("  to go on: " + with_t_end(command, 2 * ad["t_cap"])
                + " continues this run in place" if command else
                "  to go on: raise t_end (a longer run continues this one in place)")
    return lines + [more]
