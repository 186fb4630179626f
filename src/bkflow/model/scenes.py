"""What each scene records: one table, read by the run's parameters (``RunSpec.writes_*``),
the deck (``bkflow.lammps.deck``), the cost estimate (``bkflow.lammps.limits``), the
observables that need a record (``bkflow.analysis.summary_keys``) and the benchmarks.

Every scene keeps the records of ``fix bk/reduce`` (``extrema.npy``, ``blocks.npy``: the
stress and the contacts' phases reduced in the run); a scene adds the ``RECORDS`` it lists in
``SCENE_RECORDS`` and nothing else (docs/running.md, ``--scene``).
"""

from __future__ import annotations

#: what a scene can add to the reduced records (the files that keep each:
#: bkflow.store.layout's table)
RECORDS = {
    "series": "the raw stress and phase series",
    "snapshots": "Psi(t), computed in the run by fix bk/psi",
    "frames": "whole position frames every snapshot_every",
    "slips": "the slips followed by fix bk/slips, their catalogue rows and clusters found "
             "in the run or from their frames",
    "slip_frames": "the positions at each slip's maximum and minimum, from which the "
                   "analysis finds the clusters at any s_x",
    "energy": "the energy ledger in the records and each contact's first break in a slip "
              "(the event catalogue)",
    "fronts": "the x velocity of every particle through each slip",
}

#: each scene and what it adds, in the order the CLI lists them
SCENE_RECORDS = {
    "friction": (),
    "series": ("series",),
    "order": ("snapshots",),
    "clusters": ("slips", "slip_frames"),
    "figures": ("snapshots", "slips"),
    "events": ("slips", "slip_frames", "energy"),
    "fronts": ("fronts",),
    "full": tuple(RECORDS),
}

#: the scenes (``--scene``)
SCENES = tuple(SCENE_RECORDS)
#: the default scene: what bkflow sweep's table and bkflow plot's figures show (the stress and
#: phase series, Psi(t)'s snapshots, the slips' clusters), nothing more
DEFAULT_SCENE = "figures"

#: rupture fronts recorded by the full scene (the first slips after the transient; the fronts
#: scene records them all): the slip rate of every particle at every stress sample through a
#: slip costs ~4 bytes x N x samples, ~56 MB for all the slips of an N = 900 run of 8000
#: time units, so the full scene keeps a sample of them for the figures and the movie
FRONTS_IN_FULL = 20


def records(scene: str, record: str) -> bool:
    """Whether ``scene`` keeps ``record`` (a name of ``RECORDS``)."""
    if record not in RECORDS:
        raise KeyError(f"{record!r} is not a record a scene keeps ({', '.join(RECORDS)})")
    return record in SCENE_RECORDS[scene]


def scenes_with(record: str) -> tuple[str, ...]:
    """The scenes that keep ``record``."""
    return tuple(s for s in SCENES if records(s, record))
