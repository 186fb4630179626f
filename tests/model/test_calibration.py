"""The model's switching calibration (bkflow.model.calibration): the installed table is read
once from its file, another can be put in its place for a while, and the observables that use
it read no file of their own."""

from __future__ import annotations

import ast
import json
from pathlib import Path

from bkflow.model import calibration
from bkflow.observables import states

SRC = Path(__file__).resolve().parents[2] / "src" / "bkflow"


def test_the_installed_calibration_is_the_file():
    assert calibration.switching() == json.loads(calibration.CALIBRATION_FILE.read_text())
    assert {"100", "400"} <= set(calibration.switching()["sizes"])


def test_a_calibration_in_place_is_the_one_in_force_and_then_gone():
    installed = calibration.switching()
    made = {"sizes": {"100": {**installed["sizes"]["100"], "memory_chi": 1234.0}}}
    with calibration.in_place(made):
        assert calibration.switching() is made
        assert states.memory_chi(100) == 1234.0
        with calibration.in_place({}):
            assert states.memory_chi(100) == states.MEMORY_CHI_DEFAULT
        assert states.memory_chi(100) == 1234.0
    assert calibration.switching() is installed
    assert states.memory_chi(100) == installed["sizes"]["100"]["memory_chi"]


def test_a_calibration_in_place_is_its_threads_own():
    """Two threads, each with its own calibration in place at the same time, each see theirs
    (a list of tables shared by the process gave one of them the other's)."""
    import threading

    seen, barrier = {}, threading.Barrier(2)

    def hold(name, table):
        with calibration.in_place(table):
            barrier.wait()            # both in place now
            seen[name] = calibration.switching()
            barrier.wait()            # both have looked before either leaves

    a, b = {"sizes": {"a": 1}}, {"sizes": {"b": 2}}
    threads = [threading.Thread(target=hold, args=("a", a)),
               threading.Thread(target=hold, args=("b", b))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=30)
    assert seen == {"a": a, "b": b}
    assert calibration.switching() == json.loads(calibration.CALIBRATION_FILE.read_text())


def test_an_absent_or_unreadable_calibration_is_none(tmp_path, monkeypatch):
    for text in (None, "{not json"):
        path = tmp_path / "switching.json"
        if text is not None:
            path.write_text(text)
        monkeypatch.setattr(calibration, "CALIBRATION_FILE", path)
        calibration.reread()
        try:
            assert calibration.switching() == {}
            assert states.calibrated(states_spec()) == "no calibration of the switching is " \
                                                       "installed"
        finally:
            monkeypatch.undo()
            calibration.reread()
    assert calibration.switching()


def states_spec():
    from bkflow.model.params import RunSpec

    return RunSpec(phi=100.0)


def test_the_observables_read_no_file():
    """bkflow.observables is numerics on arrays: no open, read_text, json.load or Path in it."""
    for path in (SRC / "observables").glob("*.py"):
        tree = ast.parse(path.read_text())
        names = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)} | {
            n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
        assert not names & {"open", "read_text", "read_bytes", "load", "loads", "Path"}, \
            (path.name, names & {"open", "read_text", "read_bytes", "load", "loads", "Path"})
    assert not list((SRC / "observables").glob("*.json"))
