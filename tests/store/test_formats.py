"""bkflow.store.formats, tested directly: floats written as the shortest text that reads back
as the same double, CSV tables and Parquet read back as written, LAMMPS text dumps (bkflow's
fast reader against MDAnalysis's, unwrapped, ordered by id, the first breaks), fix bk/fronts
files, JSON with NaN as null; each damaged input refused with the error its docstring
promises."""

from __future__ import annotations

import json
import os

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest

from bkflow.store import formats
from bkflow.store.files import NotRegularFileError

#: doubles that a fixed number of digits gets wrong one way or another
AWKWARD = [0.1, 0.1 + 0.2, 1 / 3, 2 / 3, 1e-300, 5e-324, 2.0 ** 60, 123456789.12345679,
           -0.0, 1e22, 4.35, float("inf"), -float("inf")]


def test_a_float_is_the_shortest_text_that_reads_back_as_the_same_double():
    assert formats.float_text(0.1) == "0.1"              # where %.17g writes 0.10000000000000001
    assert formats.float_text(0.1 + 0.2) == "0.30000000000000004"
    assert formats.float_text(np.float32(0.1)) == "0.10000000149011612"   # the float32's double
    assert formats.float_text(3) == "3.0" and formats.float_text(np.int64(7)) == "7.0"
    for x in AWKWARD:
        text = formats.float_text(x)
        assert float(text) == x and np.signbit(float(text)) == np.signbit(x), text
        digits = text.split("e")[0].lstrip("-").replace(".", "").strip("0")
        # and no fewer significant digits read back as x
        assert not np.isfinite(x) or all(float(f"{x:.{k}g}") != x
                                         for k in range(1, len(digits))), text
    assert formats.FLOAT_FORMAT is formats.float_text


def test_a_table_reads_back_every_double_it_was_written_with(tmp_path):
    x = np.array(AWKWARD + [float("nan")])
    table = {"x": x, "n": np.arange(len(x)), "ok": [True, False] * (len(x) // 2)}
    formats.write_table(tmp_path / "t.csv", table)
    text = (tmp_path / "t.csv").read_text()
    assert text.startswith("x,n,ok\n0.1,0,True\n0.30000000000000004,1,False\n"), text
    back = formats.read_table(tmp_path / "t.csv")
    assert list(back.columns) == ["x", "n", "ok"]
    np.testing.assert_array_equal(back["x"].to_numpy(), x)        # bit for bit, NaN included
    assert np.signbit(back["x"].to_numpy()[AWKWARD.index(-0.0)])
    assert back["n"].dtype == np.int64 and back["ok"].dtype == bool
    # a DataFrame is written as the dict of its columns is
    formats.write_table(tmp_path / "df.csv", pd.DataFrame(table))
    assert (tmp_path / "df.csv").read_text() == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["df.csv", "t.csv"]   # no temporary


def test_named_columns_are_read_as_floats_and_a_missing_one_is_named(tmp_path):
    p = tmp_path / "stress.csv"
    p.write_text("t,sigma_x,n\n0,0.5,1\n0.1,0.25,2\n")
    cols = formats.read_columns(p, ("t", "n"))
    assert list(cols) == ["t", "n"] and cols["n"].dtype == float
    np.testing.assert_array_equal(cols["t"], [0.0, 0.1])
    with pytest.raises(ValueError, match=r"stress.csv: no column\(s\) R, Z_re$"):
        formats.read_columns(p, ("t", "Z_re", "R"))


def test_a_table_that_is_no_regular_file_or_empty_is_refused(tmp_path):
    os.mkfifo(tmp_path / "fifo.csv")
    with pytest.raises(NotRegularFileError, match="not a regular file"):
        formats.read_table(tmp_path / "fifo.csv")              # would wait for a writer
    with pytest.raises(NotRegularFileError):
        formats.read_columns(tmp_path / "fifo.csv", ("t",))
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(pd.errors.EmptyDataError):
        formats.read_table(tmp_path / "empty.csv")


def test_parquet_keeps_every_column_its_type_and_value(tmp_path):
    df = pd.DataFrame({"t": np.array(AWKWARD), "n": np.arange(len(AWKWARD), dtype=np.int64),
                       "late": np.arange(len(AWKWARD)) % 2 == 0,
                       "name": [f"e{k}" for k in range(len(AWKWARD))]})
    formats.write_parquet(tmp_path / "e.parquet", df)
    back = pd.read_parquet(tmp_path / "e.parquet", engine="pyarrow")
    pd.testing.assert_frame_equal(back, df, check_exact=True)
    assert list(back.index) == list(range(len(df)))              # the index is not a column


def test_a_parquet_that_cannot_be_written_leaves_the_old_one_whole(tmp_path):
    p = tmp_path / "e.parquet"
    formats.write_parquet(p, pd.DataFrame({"a": [1.0]}))
    before = p.read_bytes()
    with pytest.raises(pa.ArrowException):
        formats.write_parquet(p, pd.DataFrame({"a": [1, "x"]}))   # no one Arrow type
    assert p.read_bytes() == before
    assert [q.name for q in tmp_path.iterdir()] == ["e.parquet"]


# ------------------------------------------------------------------------ LAMMPS dumps
def dump_text(frames, breaks: bool = False) -> str:
    """A LAMMPS text dump as bkflow's deck writes it (columns id type x y z ix iy iz, and brk
    where ``breaks``): ``frames`` of (step, ((xlo, xhi), (ylo, yhi)), rows)."""
    lines = []
    for step, box, rows in frames:
        lines += ["ITEM: TIMESTEP", str(step), "ITEM: NUMBER OF ATOMS", str(len(rows)),
                  "ITEM: BOX BOUNDS pp pp pp", "{} {}".format(*box[0]), "{} {}".format(*box[1]),
                  "-0.5 0.5", "ITEM: ATOMS id type x y z ix iy iz" + (" brk" if breaks else "")]
        lines += [" ".join(str(v) for v in row) for row in rows]
    return "\n".join(lines) + "\n"


BOX = ((0, 10), (0, 5))
#: three atoms out of id order, wrapped, with image flags; 9 significant digits as the deck
#: writes them (dump_modify format float %.9g)
FRAMES = [
    (0, BOX, [(2, 1, 9.5, 4.5, 0, 0, 0, 0), (1, 1, 0.25, 1.0, 0, 1, -1, 0),
              (3, 1, 5.12345679, 2.0, 0, -2, 0, 0)]),
    (100, ((0, 12), (0, 5)), [(1, 1, 0.5, 1.25, 0, 1, -1, 0), (3, 1, 5.0, 2.5, 0, -2, 0, 0),
                              (2, 1, 0.1, 4.75, 0, 1, 0, 0)]),
]
#: the same frames unwrapped (x + ix Lx, y + iy Ly, each frame's own box), by atom id
UNWRAPPED = [[[10.25, -4.0], [9.5, 4.5], [5.12345679 - 20, 2.0]],
             [[12.5, -3.75], [12.1, 4.75], [5.0 - 24, 2.5]]]


def test_a_dump_is_read_unwrapped_by_atom_id(tmp_path):
    p = tmp_path / "snapshots.lammpstrj"
    p.write_text(dump_text(FRAMES))
    fast = formats.read_regular_frames(p)
    assert len(fast) == 2 and fast.breaks is None
    np.testing.assert_array_equal(fast.steps, [0, 100])
    assert fast.steps.dtype == np.int64 and fast.positions.shape == (2, 3, 2)
    np.testing.assert_array_equal(fast.positions, UNWRAPPED)     # in double precision
    read = formats.read_frames(p, 3)
    np.testing.assert_array_equal(read.steps, fast.steps)
    np.testing.assert_array_equal(read.positions, fast.positions)


def test_the_fast_reader_agrees_with_mdanalysis(tmp_path):
    p = tmp_path / "slips.lammpstrj"
    p.write_text(dump_text(FRAMES))
    fast = formats.read_regular_frames(p)
    lib = formats.read_frames_mdanalysis(p, 3)
    np.testing.assert_array_equal(lib.steps, fast.steps)
    # MDAnalysis keeps single precision
    np.testing.assert_allclose(lib.positions, fast.positions, rtol=0, atol=3e-6)
    assert lib.breaks is None


@pytest.mark.parametrize("what", ["cut inside a frame", "a frame of other atoms",
                                  "no image flags", "not a number", "another column line",
                                  "too short"])
def test_a_dump_of_another_layout_is_left_to_mdanalysis(tmp_path, what):
    text = dump_text(FRAMES)
    lines = text.splitlines()
    other = {
        "cut inside a frame": "\n".join(lines[:-1]) + "\n",
        "a frame of other atoms": dump_text([FRAMES[0], (100, BOX, FRAMES[1][2][:2])]),
        "no image flags": "\n".join(
            ln.replace(" ix iy iz", "") if ln.startswith("ITEM: ATOMS")
            else " ".join(ln.split()[:5]) if k % 12 >= 9 else ln
            for k, ln in enumerate(lines)) + "\n",
        "not a number": text.replace("0.25 1.0", "0.25 x", 1),
        # the second frame's atoms with a column more
        "another column line": "\n".join(lines[:20] + [lines[20] + " vx"]
                                         + [ln + " 0" for ln in lines[21:]]) + "\n",
        "too short": "\n".join(lines[:8]) + "\n",
    }[what]
    p = tmp_path / "d.lammpstrj"
    p.write_text(other)
    assert formats.read_regular_frames(p) is None


def test_an_empty_dump_is_zero_frames_of_the_atoms_asked_for(tmp_path):
    (tmp_path / "slips.lammpstrj").write_text("")           # a scene that recorded no event
    f = formats.read_frames(tmp_path / "slips.lammpstrj", 7)
    assert len(f) == 0 and f.steps.dtype == np.int64 and f.positions.shape == (0, 7, 2)


def test_a_dump_of_other_atoms_than_expected_is_refused(tmp_path):
    p = tmp_path / "snapshots.lammpstrj"
    p.write_text(dump_text(FRAMES))
    with pytest.raises(ValueError, match=r"snapshots.lammpstrj: 3 atoms, expected 4"):
        formats.read_frames(p, 4)
    with pytest.raises(ValueError, match=r"snapshots.lammpstrj: 3 atoms, expected 4"):
        formats.read_frames_mdanalysis(p, 4)
    assert len(formats.read_frames(p)) == 2                   # no number asked: any


def test_the_first_breaks_are_read_by_atom_id_and_a_cut_file_of_them_is_refused(tmp_path):
    frames = [(step, box, [(*row, 10 * row[0] + k) for row in rows])
              for k, (step, box, rows) in enumerate(FRAMES)]
    p = tmp_path / "slips.lammpstrj"
    p.write_text(dump_text(frames, breaks=True))
    f = formats.read_frames(p, 3)
    np.testing.assert_array_equal(f.breaks, [[10, 20, 30], [11, 21, 31]])
    np.testing.assert_array_equal(f.positions, UNWRAPPED)
    p.write_text("\n".join(dump_text(frames, breaks=True).splitlines()[:-1]) + "\n")
    with pytest.raises(ValueError, match="slips.lammpstrj: a frame or its column brk cannot"):
        formats.read_frames(p, 3)            # MDAnalysis would drop the column: not read


# ------------------------------------------------------------------------ rupture fronts
def fronts_bytes(n: int, events) -> bytes:
    """A fix bk/fronts file (plugins/fix_bk_fronts.cpp): magic, the number of atoms, then per
    event its steps of maximum and minimum, the number of samples and the flags (int64), the
    samples' steps (int64) and v_x (float32, samples x atoms)."""
    out = b"BKFRONT1" + np.array([n], "<i8").tobytes()
    for step_max, step_min, steps, vx, flags in events:
        out += np.array([step_max, step_min, len(steps), flags], "<i8").tobytes()
        out += np.asarray(steps, "<i8").tobytes() + np.asarray(vx, "<f4").tobytes()
    return out


EVENTS = [(100, 160, [100, 120, 140], np.arange(12).reshape(3, 4) / 8, 0),
          (500, 520, [510, 520], -np.ones((2, 4)), 1),
          (900, 990, [], np.zeros((0, 4)), 2)]


def test_fronts_are_read_event_by_event(tmp_path):
    p = tmp_path / "fronts.bin"
    p.write_bytes(fronts_bytes(4, EVENTS))
    fronts = formats.read_fronts(p)
    assert [(f.step_max, f.step_min, f.truncated) for f in fronts] == [
        (100, 160, False), (500, 520, True), (900, 990, False)]    # truncated: flag bit 0
    for f, (_, _, steps, vx, _) in zip(fronts, EVENTS):
        np.testing.assert_array_equal(f.steps, steps)
        assert f.vx.dtype == np.float32 and f.vx.shape == (len(steps), 4)
        np.testing.assert_array_equal(f.vx, vx)
    p.write_bytes(fronts_bytes(4, []))
    assert formats.read_fronts(p) == []                 # a run that recorded no slip


@pytest.mark.parametrize("damage, message", [
    ("empty", "not a fix bk/fronts file"),
    ("another magic", "not a fix bk/fronts file"),
    ("cut in the header", "not a fix bk/fronts file"),
    ("cut in an event's header", "cut inside an event header"),
    ("cut in an event", r"cut inside an event \(40 of 72 bytes\)"),
    ("negative samples", r"cut inside an event \(72 of -24 bytes\)"),   # refused at once
])
def test_a_cut_or_foreign_fronts_file_is_refused(tmp_path, damage, message):
    whole = fronts_bytes(4, EVENTS[:1])       # 16 + 32 + 3 * 8 + 3 * 4 * 4 bytes
    assert len(whole) == 16 + 32 + 72
    data = {"empty": b"",
            "another magic": b"BKFRONT2" + whole[8:],
            "cut in the header": whole[:12],
            "cut in an event's header": whole[:16 + 20],
            "cut in an event": whole[:16 + 32 + 40],
            "negative samples": whole[:32] + np.array([-1], "<i8").tobytes() + whole[40:],
            }[damage]
    p = tmp_path / "fronts.bin"
    p.write_bytes(data)
    with pytest.raises(ValueError, match="fronts.bin: " + message):
        formats.read_fronts(p)


# ------------------------------------------------------------------------ JSON
def test_nan_and_infinity_become_null_wherever_they_are():
    nan, inf = float("nan"), float("inf")
    obj = {"a": nan, 2: (inf, -inf, 1.5), "c": [np.float32("nan"), np.float64(2.5), {"d": nan}],
           "n": np.int64(3), "ok": np.bool_(True), "s": "nan"}
    ready = formats.json_ready(obj)
    assert ready == {"a": None, "2": [None, None, 1.5], "c": [None, 2.5, {"d": None}],
                     "n": 3, "ok": True, "s": "nan"}
    assert type(ready["n"]) is int and type(ready["ok"]) is bool    # no numpy scalar left
    assert formats.json_ready(np.float64("inf")) is None


def _strict(text: str):
    """JSON as a strict reader reads it: NaN and Infinity are no numbers of JSON's."""
    def refuse(name):
        raise ValueError(f"{name} is not JSON")
    return json.loads(text, parse_constant=refuse)


def test_json_is_written_strict_sorted_and_read_back(tmp_path):
    p = tmp_path / "summary.json"
    obj = {"mu_bar": np.float64(0.1), "b": [float("nan"), 1], 3: {"inf": float("inf")}}
    formats.write_json_atomic(p, obj)
    text = p.read_text()
    assert _strict(text) == {"3": {"inf": None}, "b": [None, 1], "mu_bar": 0.1}
    assert text == json.dumps(_strict(text), indent=2, sort_keys=True) + "\n"
    assert formats.read_json(p) == formats.json_ready(obj)
    assert [q.name for q in tmp_path.iterdir()] == ["summary.json"]   # no temporary left


def test_what_json_cannot_hold_is_refused_and_the_old_file_kept(tmp_path):
    p = tmp_path / "meta.json"
    formats.write_json_atomic(p, {"status": "complete"})
    before = p.read_bytes()
    with pytest.raises(TypeError, match="ndarray"):
        formats.write_json_atomic(p, {"status": "running", "x": np.zeros(2)})
    assert p.read_bytes() == before
    assert [q.name for q in tmp_path.iterdir()] == ["meta.json"]
