"""bkflow.model.protocols: the fields each protocol sets, and a deck's fixed length."""

from __future__ import annotations

from bkflow.model.params import STEADY_COMPANION, STEADY_START
from bkflow.model.protocols import protocol_fields
from bkflow.model.timestep import ACCURACY


def test_a_fixed_length_steady_run_keeps_the_start_and_drops_the_stop_rule():
    """A standalone deck of the steady protocol: its start, the preset's fixed t_end, no stop
    rule, and a companion or an error target only where given."""
    run = protocol_fields("steady", "fast")
    deck = protocol_fields("steady", "fast", fixed=True)
    assert run["until_steady"] and run["companion"] == STEADY_COMPANION
    assert run["t_end"] == ACCURACY["fast"].t_cap
    assert deck == {**run, "until_steady": False, "companion": None, "target_error": None,
                    "t_end": ACCURACY["fast"].t_end, "start": STEADY_START}
    given = protocol_fields("steady", companion="stratified", target_error=0.01, t_end=500.0,
                            fixed=True)
    assert (given["companion"], given["target_error"], given["t_end"]) == ("stratified", 0.01,
                                                                          500.0)
    # the stop rule asked for explicitly: the run's fields, fixed or not
    assert protocol_fields("steady", until_steady=True, fixed=True) == \
        protocol_fields("steady", until_steady=True)
    # the paper's protocol is of a fixed length already
    assert protocol_fields("paper", fixed=True) == protocol_fields("paper")
