"""bkflow.lammps.engine's own checks (``claim``): the cost of a run that will run, a
directory that is not bkflow's refused before its lock is taken, whoever calls the engine."""

from __future__ import annotations

import pytest

from bkflow.lammps import limits
from bkflow.lammps.engine import RunExistsError, claim, run
from bkflow.lammps.limits import CostError
from bkflow.model.params import RunSpec
from bkflow.store.layout import LOCK


def _spec(**kw):
    return RunSpec(**{"phi": 10.0, "Lx": 8, "Ly": 3, "seed": 1, "t_end": 200.0,
                      "scene": "friction", **kw})


def _files(d):
    return sorted((p.relative_to(d).as_posix(), p.read_bytes()) for p in d.rglob("*")
                  if p.is_file())


def test_a_foreign_directory_is_refused_before_the_lock_from_python(tmp_path):
    """engine.run called from Python (not only through the CLI) leaves
    no lock file in a directory that is not its own, and changes nothing there."""
    d = tmp_path / "theirs"
    d.mkdir()
    (d / "notes.txt").write_text("someone's")
    before = _files(d)
    with pytest.raises(RunExistsError, match="writes only into an empty directory"):
        run(_spec(), d, progress=False)
    assert _files(d) == before and not (d / LOCK).exists()


def test_the_cost_is_checked_before_anything_is_created(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "MAX_ATOM_STEPS", 1.0)
    with pytest.raises(CostError, match="atom-steps"):
        run(_spec(), tmp_path / "new", progress=False)
    assert not (tmp_path / "new").exists()


@pytest.mark.usefixtures("lammps")
def test_a_run_already_there_is_answered_whatever_its_cost(tmp_path, monkeypatch):
    """A run that stopped by its rule, asked for again with a larger cap, runs nothing: no
    estimate refuses it (before, the engine's estimate did where the CLI's was skipped)."""
    from bkflow.model.protocols import protocol_fields

    spec = RunSpec(**{**protocol_fields("steady"), "phi": 10.0, "Lx": 12, "Ly": 3, "seed": 2,
                      "scene": "friction", "t_end": 50000.0, "target_error": 2e-3})
    assert run(spec, tmp_path / "r", progress=False).meta["adaptive"]["reached"]
    before = _files(tmp_path / "r")
    monkeypatch.setattr(limits, "MAX_ATOM_STEPS", 1.0)
    assert not run(spec.replace(t_end=90000.0), tmp_path / "r", progress=False).ran
    assert _files(tmp_path / "r") == before
    with pytest.raises(CostError):   # a stricter target would run on: its cost is checked
        run(spec.replace(target_error=1e-4), tmp_path / "r", progress=False)
    with pytest.raises(CostError):   # and so is a run asked to be redone
        run(spec, tmp_path / "r", overwrite=True, progress=False)
    assert _files(tmp_path / "r") == before


def test_a_claim_without_a_spec_checks_no_cost_and_is_reentrant(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "MAX_ATOM_STEPS", 1.0)
    with claim(tmp_path / "a") as rd, claim(tmp_path / "a"):
        assert rd.file(LOCK).exists()


def test_a_claim_inside_a_claim_for_the_same_run_checks_nothing_again(tmp_path, monkeypatch):
    """``bkflow run`` claims its directory around the run, which claims it again for the same
    request: the checks (the record read for the answer, the cost) are made once; a claim
    inside for another request, or one after the outer one has ended, is checked."""
    from bkflow.lammps import engine
    from bkflow.lammps.continuation import answers

    asked = []
    monkeypatch.setattr(engine, "answers", lambda *a, **k: asked.append(1) or answers(*a, **k))
    spec, d = _spec(), tmp_path / "a"
    with claim(d, spec):
        with claim(d, spec):            # the same request: nothing checked again
            pass
        assert len(asked) == 1
        with monkeypatch.context() as m:
            m.setattr(limits, "MAX_ATOM_STEPS", 1.0)
            with pytest.raises(CostError):   # another request inside: checked
                with claim(d, spec.replace(t_end=400.0)):
                    pass
        assert len(asked) == 2
        with claim(d, None):            # no run asked: no record read, no cost
            with claim(d, spec):        # a run inside it: checked
                pass
        assert len(asked) == 3
    monkeypatch.setattr(limits, "MAX_ATOM_STEPS", 1.0)
    with pytest.raises(CostError):      # after the outer claim: checked
        with claim(d, spec):
            pass
    assert len(asked) == 4
