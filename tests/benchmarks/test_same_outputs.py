"""benchmarks/checks/same_outputs.py's normalizer, on made-up pairs of outputs: what two runs
of the same code write differently (times, rates, the process, the working directory) is made equal,
and nothing else is."""

from __future__ import annotations

from benchmarks.checks import same_outputs as so

ROOT_A, ROOT_B = "/tmp/x/w/b1", "/tmp/x/w/a1"


def _stream(text: str, root: str) -> str:
    return so.normalize_text(text, root, so.STREAM_RULES)


def test_messages_differ_only_in_time_rate_and_directory():
    a = (f"r: 6928 steps in 0.0 s (8.76e+06 atom-steps/s, fused path), 822 contact breaks\n"
         f"bkflow: error: {ROOT_A}/case/cwd/r already holds a finished run\n"
         "2 run(s) done in 0:00:05, 0 finished earlier\n")
    b = (a.replace("0.0 s (8.76e+06", "0.1 s (1.5e+07").replace(ROOT_A, ROOT_B)
         .replace("0:00:05", "0:00:04"))
    assert a != b and _stream(a, ROOT_A) == _stream(b, ROOT_B)
    for changed in (b.replace("822 contact", "823 contact"), b.replace("fused", "general"),
                    b.replace("/case/cwd/r", "/case/cwd/q")):
        assert _stream(a, ROOT_A) != _stream(changed, ROOT_B)


META = """{
  "atom_steps_per_s": 8761280.401646836,
  "bytes_written": 34507,
  "file_bytes": {
    "extrema.npy": 2320,
    "log.lammps": 14470
  },
  "process": {
    "pid": 432,
    "runs_before": 0
  },
  "provenance": {
    "git_commit": "97602cb",
    "git_dirty": false
  },
  "seed": 1,
  "started": "2026-11-28T15:05:18+0000",
  "wall_time_s": 0.037956095999106765
}
"""


def test_meta_json_differs_only_in_its_timings():
    other = (META.replace("8761280.401646836", "15015182.06").replace("34507", "34506")
             .replace("14470", "14469").replace("432", "889").replace("15:05:18", "15:06:43")
             .replace("0.037956095999106765", "0.02"))
    norm = lambda text, **kw: so.normalize_file(text.encode(), "r/meta.json", ROOT_A, **kw)
    assert norm(META) == norm(other)
    assert norm(META, rules=False) != norm(other, rules=False)
    for changed in (other.replace('"seed": 1', '"seed": 2'),
                    other.replace('"extrema.npy": 2320', '"extrema.npy": 2321'),
                    other.replace('"runs_before": 0', '"runs_before": 1'),
                    other.replace('"seed": 1', '"seed": 1.0'),      # as written, not parsed
                    other.replace('  "seed"', '   "seed"')):
        assert norm(META) != norm(changed), changed
    # the versions' commit: blanked only when asked (reported apart, never hidden)
    commit = other.replace("97602cb", "e0c9915").replace("false", "true")
    assert norm(META) != norm(commit)
    assert norm(META, identity=True) == norm(commit, identity=True)


def test_lammps_log_differs_only_in_its_timings():
    log = """thermo_style    custom step time f_bk[1] cpuremain
  read_data CPU = 0.002 seconds
   Step          Time         f_bk[1]        CPULeft
         0   0              0              0
        69   1.9918584      0.042811379    0.0031219239
Loop time of 0.00259086 on 1 procs for 3464 steps with 24 atoms

Total wall time: 0:00:00
"""
    other = (log.replace("0.002 seconds", "0.001 seconds")
             .replace("0.0031219239", "0.00335 ")                  # LAMMPS pads to a width
             .replace("0.00259086", "0.00165387"))
    norm = lambda text: so.normalize_file(text.encode(), "r/log.lammps", ROOT_A)
    assert log != other and norm(log) == norm(other)
    for changed in (other.replace("0.042811379", "0.042811378"),
                    other.replace("3464 steps", "3465 steps"),
                    other.replace("1.9918584 ", "1.9918584  "),            # the spacing
                    other.replace("0:00:00", "0:00:01")):   # never seen to differ: compared
        assert norm(log) != norm(changed), changed


def test_the_order_parallel_runs_finish_in():
    a = "x\n[1/2] phi=10, 12x3, seed 1: done\n[2/2] phi=1, 12x3, seed 1: done\ny\n"
    b = "x\n[1/2] phi=1, 12x3, seed 1: done\n[2/2] phi=10, 12x3, seed 1: done\ny\n"
    assert _stream(a, ROOT_A) == _stream(b, ROOT_A)
    assert _stream(a, ROOT_A) != _stream(b.replace("seed 1: done\ny", "seed 1: failed\ny"),
                                         ROOT_A)
    assert _stream(a, ROOT_A) != _stream(b.replace("[2/2]", "[2/3]"), ROOT_A)


def test_tables_figures_and_the_mark():
    csv = "job,bytes_written,mu_bar,wall_time_s\nab,38806,0.12,0.058\n"
    other = "job,bytes_written,mu_bar,wall_time_s\nab,38808,0.12,0.034\n"
    norm = lambda text, name: so.normalize_file(text.encode(), name, ROOT_A)
    assert norm(csv, "s/runs.csv") == norm(other, "s/runs.csv")
    assert norm(csv, "s/runs.csv") != norm(other.replace("0.12", "0.13"), "s/runs.csv")
    assert norm(csv, "s/results.csv") != norm(other, "s/results.csv")   # only runs.csv's
    quoted = 'job,bytes_written,mu_bar,wall_time_s\n"ab",38808,0.12,0.034\n'
    assert norm(csv, "s/runs.csv") != norm(quoted, "s/runs.csv")         # as written
    mark = '{\n  "began": 1795878317.97,\n  "bkflow": "0.6.0",\n  "directory": [\n    65024,' \
           '\n    2197771\n  ]\n}\n'
    assert norm(mark, "r/.bkflow-run") == norm(mark.replace("2197771", "2270150")
                                               .replace("17.97", "18.01"), "r/.bkflow-run")
    assert norm(mark, "r/.bkflow-run") != norm(mark.replace("0.6.0", "0.6.1"), "r/.bkflow-run")
    pdf = b"%PDF-1.4\n\xe2\xe3<< /CreationDate (D:20261128150617Z) >>\n"
    later = pdf.replace(b"150617", b"150740")
    assert so.normalize_file(pdf, "fig.pdf", ROOT_A) == so.normalize_file(later, "fig.pdf",
                                                                          ROOT_A)
    assert so.normalize_file(pdf, "fig.png", ROOT_A) != so.normalize_file(later, "fig.png",
                                                                          ROOT_A)
