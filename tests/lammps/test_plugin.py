"""The plugin refuses a LAMMPS it was not built for, and a missing plugin is a clear error."""

import json
import os
import re
import shutil
import subprocess
import sys

import pytest

from bkflow.lammps.plugin import PLUGIN_FILE, PluginError, build_info, check_plugin, open_lammps
from bkflow.model.params import CONTACT_RULES, DAMPING_MODES
from tests.support import ROOT, tool


def test_installed_plugin_matches_installed_lammps(lammps):
    assert check_plugin().name == PLUGIN_FILE
    assert build_info()["lammps_git"].startswith("stable_")


def test_missing_plugin_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("BKFLOW_PLUGIN_DIR", str(tmp_path))
    with pytest.raises(PluginError, match="plugin not found"):
        check_plugin()
    proc = subprocess.run([tool("bkflow"), "run", "--phi", "1", "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, env=os.environ.copy())
    assert proc.returncode == 2 and "plugin not found" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


@pytest.fixture(scope="module")
def mismatched_plugin(tmp_path_factory):
    """The same sources built as if for another LAMMPS (cmake -DBK_LAMMPS_GIT=...)."""
    cmake = shutil.which("cmake")
    if cmake is None:
        pytest.fail("cmake is needed to build the mismatched plugin")
    build = tmp_path_factory.mktemp("badplugin")
    subprocess.run([cmake, "-S", str(ROOT / "plugins"), "-B", str(build),
                    f"-DPython_EXECUTABLE={sys.executable}",
                    "-DBK_LAMMPS_GIT=stable_2Aug2023_update9",
                    # unoptimised: only its version stamp is tested, and -O0 builds in a third
                    # of the time
                    "-DCMAKE_BUILD_TYPE=Debug", "-DCMAKE_CXX_FLAGS_DEBUG=-O0"],
                   check=True, capture_output=True)
    subprocess.run([cmake, "--build", str(build), "--parallel", "2"], check=True,
                   capture_output=True)
    return build


@pytest.mark.slow
def test_python_side_refuses_mismatched_plugin(mismatched_plugin, monkeypatch, tmp_path):
    assert json.loads((mismatched_plugin / "build_info.json").read_text())["lammps_git"] == \
        "stable_2Aug2023_update9"
    monkeypatch.setenv("BKFLOW_PLUGIN_DIR", str(mismatched_plugin))
    proc = subprocess.run([tool("bkflow"), "run", "--phi", "1", "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, env=os.environ.copy())
    assert proc.returncode == 2
    assert "built for lammps" in proc.stderr and "stable_2Aug2023_update9" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_plugin_itself_refuses_another_lammps(lammps, mismatched_plugin, tmp_path):
    """Loaded by hand into LAMMPS (which only warns), the fix refuses to run, loudly."""
    deck = tmp_path / "in.t"
    deck.write_text(f"plugin load {mismatched_plugin / PLUGIN_FILE}\n"
                    "units lj\ndimension 2\natom_style bond\n"
                    "region b block 0 4 0 4 -0.5 0.5\ncreate_box 1 b\n"
                    "fix bk all bk/substrate damp 0.2\n")
    env = {k: v for k, v in os.environ.items() if k != "LAMMPS_PLUGIN_PATH"}
    env["BKFLOW_PLUGIN_DIR"] = str(tmp_path)  # keep the installed plugin out of auto-load
    proc = subprocess.run([tool("lmp"), "-in", str(deck), "-log", "none"], capture_output=True,
                          text=True, env=env)
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert "bkflow plugin MISMATCH" in out
    assert "ERROR: fix bk/substrate: the bkflow plugin was built for LAMMPS" in out


@pytest.mark.parametrize("args, needle", [
    ("friction 10 0.2 5 1 sticky", "friction mode must be reset, reset/step or coulomb"),
    ("friction -1 0.2 5 1 reset", "k_e must be > 0"),
    ("damp -0.5", "gamma must be >= 0"),
    ("wobble 3", "Unknown fix bk/substrate keyword wobble"),
    ("wobble 3", re.escape(f"[friction k_e mu_s sigma_n A {'|'.join(CONTACT_RULES)}] "
                           f"[damp gamma [{'|'.join(DAMPING_MODES)}]] [start dr_property]")),
    ("bonds 1.0", "bonds needs: bonds k_b r0"),
])
def test_bad_fix_arguments_are_clear_lammps_errors(lammps, args, needle):
    lmp = open_lammps()
    lmp.commands_string("units lj\ndimension 2\natom_style bond\n"
                        "region b block 0 4 0 4 -0.5 0.5\ncreate_box 1 b\n")
    with pytest.raises(Exception, match=needle):
        lmp.command(f"fix bk all bk/substrate {args}")
    lmp.close()


@pytest.mark.parametrize("reader", ["bk/stress 7 SUB file {out}/s.csv",
                                    "bk/slips 7 SUB 0.01 file {out}/s.lammpstrj"])
@pytest.mark.parametrize("deck, needle", [
    ("fix r all {reader}", "no fix with ID sub"),                     # no substrate at all
    ("fix sub all nve\nfix r all {reader}", "fix sub is nve, not bk/substrate"),
    ("fix r all {reader}\nfix sub all bk/substrate damp 0.2", "must be defined after fix sub"),
])
def test_stress_and_slips_fixes_check_the_substrate_they_read(
        lammps, reader, deck, needle, tmp_path):
    lmp = open_lammps()
    lmp.commands_string("units lj\ndimension 2\natom_style bond\n"
                        "region b block 0 4 0 4 -0.5 0.5\ncreate_box 1 b\nmass 1 1.0\n"
                        "create_atoms 1 single 1 1 0\n")
    reader = reader.replace("SUB", "sub").format(out=tmp_path)
    lmp.commands_string(deck.format(reader=reader))
    with pytest.raises(Exception, match=needle):
        lmp.command("run 0")
    lmp.close()


#: a command (``interrupts``) whose signal lands while Python runs a weakref callback, where an
#: exception is dropped ("Exception ignored"); the argument: SIGTERM or SIGINT
_DROPPED_CTRL_C = """
import os, signal, sys, threading, time, weakref
from bkflow.lammps.plugin import interrupts

class A:
    pass

def callback(ref):                    # the garbage collector's: where the signal lands
    t = time.time()
    while time.time() - t < 0.5:
        pass

sig = getattr(signal, sys.argv[1])
try:
    with interrupts((signal.SIGTERM,)):
        a = A()
        w = weakref.ref(a, callback)
        threading.Timer(0.2, os.kill, (os.getpid(), sig)).start()
        del a
        t = time.time()
        while time.time() - t < 5:
            pass
    print("ran on")
except KeyboardInterrupt as exc:
    print("stopped", repr(exc))
"""


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
def test_a_ctrl_c_that_lands_where_python_drops_exceptions_still_stops_the_command(sig):
    """A signal taken as Ctrl-C that arrives in a weakref callback (bkflow plot's garbage
    collection) is delivered again once the callback returns: the command stops, silently,
    where before it printed "Exception ignored" and ran on to its end."""
    proc = subprocess.run([sys.executable, "-c", _DROPPED_CTRL_C, sig], capture_output=True,
                          text=True, timeout=60)
    assert proc.stdout.startswith("stopped KeyboardInterrupt("), proc.stdout + proc.stderr
    assert "Exception ignored" not in proc.stderr
