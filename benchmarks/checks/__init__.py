"""Checks of bkflow's behaviour that run as a user would and end in a verdict, not a number: the
fault fuzz (``faults``), two plugin builds compared bit for bit (``same_bits``) and two sweeps of
one grid compared run by run (``paths_agree``).
"""
