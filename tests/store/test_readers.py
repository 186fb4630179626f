"""bkflow.store.readers, tested directly on records written here with numpy in the layouts of
bkflow.observables.reduced (no LAMMPS): the reduced records read back at the threshold the
deck recorded them at, the raw series, Psi(t), the fronts and the dumps; a damaged record a
DamagedRunError naming the file, a missing one the file system's own error."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest

from bkflow.model.params import RunSpec
from bkflow.observables.reduced import blocks_dtype, extrema_dtype
from bkflow.store.errors import DamagedRunError
from bkflow.store.layout import (
    BLOCKS,
    DECK,
    EXTREMA,
    FRONTS,
    META,
    PHASE,
    PSI_RECORD,
    SERIES_STRESS,
    SLIPS,
    STRESS,
)
from bkflow.store.rundir import RunDir

SPEC = RunSpec(phi=1.0)


def _extrema() -> np.ndarray:
    ext = np.zeros(4, extrema_dtype(ledger=False))
    ext["step"] = [30, 90, 300, 330]
    ext["sigma"] = [0.5, 0.2, 0.6, 0.1]
    return ext


def _blocks() -> np.ndarray:
    blk = np.zeros(2, blocks_dtype(phase=True, ledger=False))
    blk["n"] = [228, 100]
    blk["n_phase"] = [19, 9]
    blk["sigma"] = [0.4 * 228, 0.3 * 100]
    for field, mean in (("R", 0.5), ("Z_re", 0.1), ("Z_im", -0.1), ("Z2", 0.02), ("R2", 0.3),
                        ("u_mean", 0.5), ("u_std", 0.2)):
        blk[field] = mean * blk["n_phase"]
    return blk


def _records(d, extrema=None, blocks=None) -> RunDir:
    d.mkdir(exist_ok=True)
    np.save(d / EXTREMA, _extrema() if extrema is None else extrema)
    np.save(d / BLOCKS, _blocks() if blocks is None else blocks)
    return RunDir(d)


def test_the_reduced_records_are_read_as_written(tmp_path):
    red = _records(tmp_path).read_reduced(SPEC)
    np.testing.assert_array_equal(red.extrema, _extrema())
    np.testing.assert_array_equal(red.blocks, _blocks())
    assert (red.nevery, red.block, red.dt) == (SPEC.stress_nevery, SPEC.block_nevery, SPEC.dt)
    assert red.threshold == SPEC.extrema_threshold_stress        # no deck: the spec's
    assert red.has_phase and not red.has_ledger and red.raw is None
    t, sigma, phase = red.series()
    np.testing.assert_allclose(sigma, [0.4, 0.3])
    np.testing.assert_allclose(phase["R"], [0.5, 0.5])


def test_the_threshold_is_the_one_the_deck_recorded_at(tmp_path):
    rd = _records(tmp_path)
    (tmp_path / DECK).write_text(
        "fix             reduce all bk/reduce 3 bk threshold 0.0025 block 684 extrema "
        "extrema.npy blocks blocks.npy\n")
    assert rd.recorded_threshold(SPEC) == 0.0025 and rd.read_reduced(SPEC).threshold == 0.0025
    (tmp_path / DECK).write_text("fix reduce all bk/reduce 3 bk threshold x block 684\n")
    assert rd.recorded_threshold(SPEC) == SPEC.extrema_threshold_stress


def test_a_companions_blocks_are_read_without_extrema(tmp_path):
    tmp_path.mkdir(exist_ok=True)
    np.save(tmp_path / BLOCKS, _blocks())
    red = RunDir(tmp_path).read_reduced(SPEC)
    assert not red.has_extrema and len(red.blocks) == 2


def _garbage(path):
    path.write_bytes(b"\x93NUMPY this is no array")


def _pickled(path):
    with open(path, "wb") as f:
        np.lib.format.write_array(f, np.array([{"a": 1}], dtype=object), allow_pickle=True)


@pytest.mark.parametrize("damage, detail", [
    ("steps that do not increase", "extrema.npy: its steps do not increase"),
    ("a float32 field", "extrema.npy: field sigma is <f4, not <f8"),
    ("a count below zero", "blocks.npy: n is negative"),
    ("an empty file", ""),
    ("garbage", ""),
    ("pickled objects", "pickle"),
])
def test_a_damaged_record_is_refused_naming_the_records(tmp_path, damage, detail):
    d = tmp_path / "run"
    if damage == "steps that do not increase":
        ext = _extrema()
        ext["step"][2] = 60
        _records(d, extrema=ext)
    elif damage == "a float32 field":
        _records(d, extrema=_extrema().astype([("step", "<i8"), ("sigma", "<f4")]))
    elif damage == "a count below zero":
        blk = _blocks()
        blk["n"][1] = -1
        _records(d, blocks=blk)
    else:
        _records(d)
        {"an empty file": lambda p: p.write_bytes(b""), "garbage": _garbage,
         "pickled objects": _pickled}[damage](d / BLOCKS)
    with pytest.raises(DamagedRunError) as exc:
        RunDir(d).read_reduced(SPEC)
    message = str(exc.value)
    assert message.startswith(f"{d}: its records (extrema.npy, blocks.npy) are damaged (")
    assert message.endswith("); run the run again") and detail in message


def test_a_missing_record_is_the_file_systems_error_not_damage(tmp_path):
    _records(tmp_path)
    (tmp_path / BLOCKS).unlink()
    with pytest.raises(FileNotFoundError):
        RunDir(tmp_path).read_reduced(SPEC)


def test_the_stress_series_of_a_run_before_0_5_is_read_from_its_csv(tmp_path):
    (tmp_path / STRESS).write_text("t,sigma_x\n0,0\n0.1,0.25\n")
    t, sigma = RunDir(tmp_path).read_stress(SPEC)
    np.testing.assert_array_equal(t, [0, 0.1])
    np.testing.assert_array_equal(sigma, [0, 0.25])
    assert RunDir(tmp_path).keeps_raw_stress() and RunDir(tmp_path).read_ledger(SPEC) is None
    (tmp_path / STRESS).write_text("t,sigma\n0,0\n")
    with pytest.raises(DamagedRunError, match=r"stress.csv is damaged \(.*no column\(s\) "
                                              r"sigma_x\)"):
        RunDir(tmp_path).read_stress(SPEC)


def test_the_raw_stress_series_is_read_in_time_units(tmp_path):
    series = np.zeros(3, [("step", "<i8"), ("sigma", "<f8")])
    series["step"], series["sigma"] = [0, 3, 6], [0.0, 0.5, 0.25]
    np.save(tmp_path / SERIES_STRESS, series)
    t, sigma = RunDir(tmp_path).read_stress(SPEC)
    np.testing.assert_array_equal(t, np.array([0, 3, 6]) * SPEC.dt)
    np.testing.assert_array_equal(sigma, series["sigma"])
    np.save(tmp_path / SERIES_STRESS, series[["step"]])
    with pytest.raises(DamagedRunError, match=r"stress.npy is damaged .* run the run again"):
        RunDir(tmp_path).read_stress(SPEC)


def test_phases_are_none_before_bkflow_recorded_them_and_damage_when_listed(tmp_path):
    rd = RunDir(tmp_path)
    assert rd.read_phase(SPEC) is None
    (tmp_path / META).write_text(json.dumps({"file_bytes": {PHASE: 100}}))
    with pytest.raises(DamagedRunError, match=r"phase.csv is missing \(meta.json lists it\)"):
        rd.read_phase(SPEC)
    (tmp_path / PHASE).write_text("t,R\n0,0.5\n")
    with pytest.raises(DamagedRunError, match=r"phase.csv is damaged \(.*Z_im, Z_re, u_mean"):
        rd.read_phase(SPEC)


def test_psi_is_read_and_one_outside_its_bounds_refused(tmp_path):
    rd = RunDir(tmp_path)
    assert rd.read_psi_record(SPEC) is None
    psi = np.zeros(2, [("step", "<i8"), ("psi", "<f8")])
    psi["step"], psi["psi"] = [0, 100], [0.9, 0.5]
    np.save(tmp_path / PSI_RECORD, psi)
    steps, values = rd.read_psi_record(SPEC)
    assert steps.dtype == np.int64 and list(steps) == [0, 100] and list(values) == [0.9, 0.5]
    psi["psi"][1] = 1.5
    np.save(tmp_path / PSI_RECORD, psi)
    with pytest.raises(DamagedRunError, match=r"psi.npy is damaged \(psi.npy: psi lies outside"):
        rd.read_psi_record(SPEC)


def test_fronts_missing_or_cut_are_damage_and_none_recorded_is_no_front(tmp_path):
    rd = RunDir(tmp_path)
    assert rd.read_fronts() == []                          # a scene that records none
    (tmp_path / META).write_text(json.dumps({"fronts": {"written": 3}}))
    with pytest.raises(DamagedRunError, match=r"fronts.bin is missing \(meta.json says 3 slips"):
        rd.read_fronts()
    (tmp_path / FRONTS).write_bytes(b"BKFRONT1" + np.array([4, 1, 2, 3], "<i8").tobytes())
    with pytest.raises(DamagedRunError, match=r"fronts.bin is cut or damaged \(.*fronts.bin: "
                                              r"cut inside an event header\)"):
        rd.read_fronts()


def test_a_damaged_dump_is_refused_naming_it_and_a_missing_one_is_not_damage(tmp_path):
    rd = RunDir(tmp_path)
    with pytest.raises(FileNotFoundError):
        rd.read_slip_frames(3)
    (tmp_path / SLIPS).write_text("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n3\n"
                                  "ITEM: BOX BOUNDS pp pp pp\n0 10\n0 5\n-0.5 0.5\n"
                                  "ITEM: ATOMS id type x y z ix iy iz brk\n1 1 0.5 0.5 0 0 0 0 1\n")
    with pytest.raises(DamagedRunError, match=r"slips.lammpstrj is cut or damaged \(ValueError"):
        rd.read_slip_frames(3)


def test_records_are_never_unpickled(tmp_path):
    """allow_pickle=False: a record that is a pickle is damage, never code run."""
    (tmp_path / PSI_RECORD).write_bytes(pickle.dumps({"step": [0]}))
    with pytest.raises(DamagedRunError, match="psi.npy is damaged"):
        RunDir(tmp_path).read_psi_record(SPEC)
