"""Two versions of bkflow, the same command line: a list of cases of ``bkflow`` commands run
with version BEFORE and with version AFTER (e.g. before and after a refactoring), compared:
every command's exit code, stdout and stderr, and every file (bytes and mode) in the working
directory after it.

    python -m benchmarks.checks.same_outputs --before DIR --after DIR [--out /tmp/same_outputs]
        [--reps 2] [--jobs 1] [--only REGEX] [--compare-only] [--list] [--raw]

DIR: a source tree (``DIR/src/bkflow``: a ``sitecustomize.py`` putting that src first, the
editable install's finder dropped, is written to ``OUT/hooks/``) or a directory holding such a
``sitecustomize.py`` (a worktree's ``.hook``). Both run under one Python (``--python``: the
same libraries, LAMMPS and plugin) as ``python -m bkflow.cli ARGS``, i.e. ``bkflow.cli:main``
as the ``bkflow`` script calls it (pyproject.toml [project.scripts]), with ``PYTHONPATH`` at
the hook (checked: ``python -m inspect -d bkflow``), under ``nice -n 10``, stdin empty, output
to pipes (no progress bars), ``COLUMNS=80``, ``PYTHONHASHSEED=0``, ``TMPDIR`` and the bytecode
cache under ``OUT/``. Each case (``CASES``, ``--list``) runs its steps in a fresh directory
``OUT/w/<side><rep>/<case>/cwd`` (roots b1, b2, a1, a2: the same relative paths); the directory
after step k is copied to ``after<k>/`` beside it, the step's exit code and output kept in
``step<k>.json`` (``--compare-only`` compares them again).

Normalized is only what differs between two runs of the SAME code (``--raw`` with one version
on both sides shows it): the working root (``<W>``); in messages, wall times, rates, the memory
available and the order parallel sweep runs finish in (``STREAM_RULES``); the timings of
meta.json and summary.json, the mark's time and inode, the digests of runs.csv
(``JSON_VOLATILE``), runs.csv's wall time and bytes (``CSV_VOLATILE``), LAMMPS's timings
(``FILE_RULES``), a PDF's date (``BYTES_RULES``); PNGs and GIFs byte for byte. With ``--reps
2`` every item must be the same in both runs of a version ("varies within" if not). The commit
a run records (``IDENTITY``) differs between versions by what they are: counted apart, never
hidden. An item different as written between the versions, stable within each, is listed as
"normalized only", to be read. Prints a row per case (identical, or its first difference),
then every difference with a short diff (also ``OUT/report.txt``); exit 0 when all identical.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import csv
import difflib
import io
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

from benchmarks.checks.cli_cases import CASES
from benchmarks.harness import parser


# ------------------------------------------------------------------------- what may differ
def sub(pattern: str, repl: str):
    """A rule: ``pattern`` (multiline) replaced by ``repl``."""
    rx = re.compile(pattern, re.M)
    return lambda text: rx.sub(repl, text)


def cpu_left(text: str) -> str:
    """LAMMPS's thermo column CPULeft (``cpuremain``, the time left) blanked in the rows of
    every thermo table whose header names it, with the padding after it (its width's); the
    other columns' spacing kept."""
    out, col = [], None
    for line in text.split("\n"):
        parts = re.split(r"(\s+)", line)
        words = [i for i, p in enumerate(parts) if p and not p.isspace()]
        if "CPULeft" in parts:
            col = [parts[i] for i in words].index("CPULeft")
        elif col is not None and len(words) > col and parts[words[0]].isdigit():
            parts[words[col]:words[col] + 2] = ["<T>", " "]
        else:
            col = None
        out.append("".join(parts))
    return "\n".join(out)


def finishing_order(text: str) -> str:
    """A sweep's lines of finished runs (``[k/n] phi=...: done``, on stderr) without their
    count, sorted: the order parallel workers finish in varies from one sweep to the next."""
    out, block = [], []
    for line in text.split("\n") + [""]:
        m = re.match(r"\[\d+/(\d+)\] (.*)$", line)
        if m:
            block.append(f"[<k>/{m[1]}] {m[2]}")
            continue
        out += sorted(block) + [line]
        block = []
    return "\n".join(out[:-1])


#: (name, rule) on stdout and stderr
STREAM_RULES = [
    ("wall time and rate", sub(r" in \d+\.\d+ s \([\d.e+-]+ atom-steps/s",
                               " in <T> s (<R> atom-steps/s")),
    ("sweep's wall time", sub(r" done in \d+:\d\d:\d\d", " done in <T>")),
    ("memory available", sub(r"of the [\d.]+ GB available", "of the <M> GB available")),
    ("the order parallel runs finish in", finishing_order),
]
#: (name, rule) of text files by name (JSON and CSV apart)
FILE_RULES = {"log.lammps": [
    ("LAMMPS's loop times", sub(r"^(Loop time of )[\d.e+-]+", r"\1<T>")),
    ("LAMMPS's CPU times", sub(r"(CPU = )[\d.e+-]+( seconds)", r"\1<T>\2")),
    ("LAMMPS's CPULeft", cpu_left),
]}
#: JSON files' keys whose values differ from run to run (blanked in the text as written,
#: wherever the key stands: in these files these keys hold only those values)
JSON_VOLATILE = {
    # the timings, the process, and the size of log.lammps (which holds LAMMPS's timings)
    "meta.json": ["wall_time_s", "atom_steps_per_s", "started", "pid", "log.lammps",
                  "bytes_written"],
    "summary.json": ["wall_time_s", "bytes_written"],
    ".bkflow-run": ["began", "directory"],             # the mark: its time, the inode
    "analysis.json": ["bytes", "sha256"],              # of runs.csv (its wall times)
    "figures.json": ["tables_sha256"],                 # the same
}
#: CSV files' volatile columns
CSV_VOLATILE = {"runs.csv": ["wall_time_s", "bytes_written"]}
#: (file suffix, name, pattern, replacement) on binary files
BYTES_RULES = [(".pdf", "the PDF's date", re.compile(rb"/CreationDate \(D:\d+Z?\)"),
                b"/CreationDate (D:<T>)")]
#: what differs between two versions by what they are, not by what they do: the commit a
#: run records (meta.json's provenance); counted apart, never hidden
IDENTITY = {"meta.json": ["git_commit", "git_dirty"]}


def normalize_text(text: str, root: str, rules: list) -> str:
    """``text`` with the working root ``root`` (``<W>``), then each of ``rules`` replaced."""
    text = text.replace(root, "<W>")
    for _, rule in rules:
        text = rule(text)
    return text


def blank_json(text: str, keys: list[str]) -> str:
    """The JSON ``text`` with the value (number, string, flat list, literal) of every key of
    ``keys`` replaced by ``"<volatile>"``, the rest as written."""
    value = r'"(?:[^"\\]|\\.)*"|\[[^\[\]]*\]|[^,\s\}\]]+'
    rx = re.compile(r'("(?:' + "|".join(map(re.escape, keys)) + r')"\s*:\s*)(?:' + value + ")")
    return rx.sub(r'\1"<volatile>"', text)


def blank_csv(text: str, columns: list[str]) -> str:
    """The CSV ``text`` with the values of ``columns`` replaced by ``<volatile>``; as written
    where the csv module does not write it back byte for byte (no quoting hidden)."""
    def written(rows, buf=None) -> str:
        csv.writer(buf := io.StringIO(), lineterminator="\n").writerows(rows)
        return buf.getvalue()

    rows = list(csv.reader(io.StringIO(text)))
    if not rows or written(rows) != text:
        return text
    cols = [i for i, c in enumerate(rows[0]) if c in columns]
    return written([rows[0]] + [[("<volatile>" if i in cols else x) for i, x in enumerate(row)]
                                for row in rows[1:]])


def normalize_file(data: bytes, name: str, root: str, identity: bool = False,
                   rules: bool = True) -> bytes:
    """A file's bytes as compared: ``root`` replaced, and with ``rules`` what differs from run
    to run (``JSON_VOLATILE``, ``CSV_VOLATILE``, ``FILE_RULES``, ``BYTES_RULES``), with
    ``identity`` ``IDENTITY``'s fields too."""
    base = name.rsplit("/", 1)[-1]
    try:
        text = data.decode()
    except UnicodeDecodeError:
        for suffix, _, pattern, repl in BYTES_RULES if rules else []:
            data = pattern.sub(repl, data) if base.endswith(suffix) else data
        return data
    text = text.replace(root, "<W>")
    keys = [*(JSON_VOLATILE.get(base, []) if rules else []),
            *(IDENTITY.get(base, []) if identity else [])]
    if keys:
        return blank_json(text, keys).encode()
    if rules and base in CSV_VOLATILE:
        return blank_csv(text, CSV_VOLATILE[base]).encode()
    return normalize_text(text, root, FILE_RULES.get(base, []) if rules else []).encode()


# ------------------------------------------------------------------------- running
HOOK = """# bkflow from {src} over the editable install (benchmarks/checks/same_outputs.py)
import sys

sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in type(f).__module__.lower()
                    and "skbc" not in type(f).__module__.lower()]
sys.path.insert(0, {src!r})
"""


def hook_dir(given: Path, out: Path, side: str) -> tuple[Path, str | None]:
    """(the directory of a ``sitecustomize.py`` giving ``given``'s bkflow, the src it must
    come from: None for a hook given)."""
    if (given / "sitecustomize.py").is_file():
        return given.resolve(), None
    src = given.resolve() / "src"
    if not (src / "bkflow").is_dir():
        sys.exit(f"{given}: neither a hook (sitecustomize.py) nor a tree (src/bkflow)")
    hook = out / "hooks" / side
    hook.mkdir(parents=True, exist_ok=True)
    (hook / "sitecustomize.py").write_text(HOOK.format(src=str(src)))
    return hook, str(src)


def environment(hook: Path, out: Path, root: Path) -> dict:
    (root / "tmp").mkdir(parents=True, exist_ok=True)
    return {**{k: v for k, v in os.environ.items() if not k.startswith("PYTHON")},
            "PYTHONPATH": str(hook), "PYTHONHASHSEED": "0", "COLUMNS": "80", "LINES": "24",
            "TMPDIR": str(root / "tmp"), "PYTHONPYCACHEPREFIX": str(out / "pycache")}


def run_case(python: str, env: dict, root: Path, name: str, steps: list, timeout: float) -> float:
    """The case's steps in ``root/name/cwd``, each step's record and a copy of the directory
    after it beside; the seconds it took."""
    case, t0 = root / name, time.monotonic()
    shutil.rmtree(case, ignore_errors=True)
    (case / "cwd").mkdir(parents=True)
    for k, step in enumerate(steps):
        record = {"args": list(step), "rc": None, "stdout": "", "stderr": ""}
        if step[:1] == ("+write",):
            (case / "cwd" / step[1]).parent.mkdir(parents=True, exist_ok=True)
            (case / "cwd" / step[1]).write_text(step[2])
        else:
            proc = subprocess.run(["nice", "-n", "10", python, "-m", "bkflow.cli", *step],
                                  cwd=case / "cwd", env=env, stdin=subprocess.DEVNULL,
                                  capture_output=True, timeout=timeout)
            record.update(rc=proc.returncode, **{s: getattr(proc, s).decode(
                errors="backslashreplace") for s in ("stdout", "stderr")})
        shutil.copytree(case / "cwd", case / f"after{k}", symlinks=True)
        (case / f"step{k}.json").write_text(json.dumps(record, indent=1))
    return time.monotonic() - t0


# ------------------------------------------------------------------------- comparing
def listing(d: Path) -> dict[str, Path | None]:
    """Every entry under ``d`` by relative path: a file (its path), a directory (``/``
    appended) or a symbolic link (``@`` and its target appended; None for both)."""
    out: dict[str, Path | None] = {}
    for p in sorted(d.rglob("*")):
        rel, link = p.relative_to(d).as_posix(), p.is_symlink()
        out[f"{rel}@{os.readlink(p)}" if link else rel + "/" if p.is_dir() else rel] = \
            p if p.is_file() and not link else None
    return out


def items(case: Path, k: int, root: str) -> dict[str, tuple[bytes, bytes, bytes]]:
    """Step ``k`` of a case: {item: (as written, normalized, normalized and ``IDENTITY``
    blanked)} of its exit code, streams and every entry of the directory after it (a file's
    mode first); the working root ``<W>`` in all three."""
    rec = json.loads((case / f"step{k}.json").read_text())
    got = {"exit code": (str(rec["rc"]).encode(),) * 3}
    for s in ("stdout", "stderr"):
        norm = normalize_text(rec[s], root, STREAM_RULES).encode()
        got[s] = (normalize_text(rec[s], root, []).encode(), norm, norm)
    for rel, p in listing(case / f"after{k}").items():
        mode = f"[mode {p.stat().st_mode & 0o7777:o}]\n".encode() if p else b""
        data = p.read_bytes() if p else b""
        got[rel] = tuple(mode + (normalize_file(data, rel, root, **kw) if p else b"")
                         for kw in ({"rules": False}, {}, {"identity": True}))
    return got


def short_diff(a: bytes, b: bytes, n: int = 14) -> str:
    """A unified diff's first lines, or where two binaries part (after the mode line)."""
    try:
        ta, tb = a.decode(), b.decode()
    except UnicodeDecodeError:
        (ma, _, a), (mb, _, b) = a.partition(b"\n"), b.partition(b"\n")
        at = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
        png = [re.match(rb"\x89PNG\r\n\x1a\n.{4}IHDR(.{4})(.{4})", x, re.S) for x in (a, b)]
        size = "; PNG {} and {} pixels".format(*("x".join(
            str(int.from_bytes(g, "big")) for g in m.groups()) for m in png)) if all(png) else ""
        return f"    binary{'' if ma == mb else ', ' + ma.decode() + ' and ' + mb.decode()}: " \
            f"{len(a)} and {len(b)} bytes{size}, first difference at byte {at}"
    lines = list(difflib.unified_diff(ta.splitlines(), tb.splitlines(), "before", "after",
                                      n=1, lineterm=""))
    more = f"\n    ... ({len(lines) - n} more lines)" if len(lines) > n else ""
    return "\n".join("    " + line[:160] for line in lines[:n]) + more


def compare_step(runs: dict, case: str, k: int) -> tuple[list, list]:
    """Step ``k`` of ``case`` in every run ({label: root}: ``b1``, ``b2``, ``a1``, ...):
    (differences, notes), each (kind, item, diff). Kinds: "varies within before" (after: the
    normalized item differs between two runs of one version), "differs" (BEFORE against
    AFTER), "identity" (only in ``IDENTITY``'s fields); a note, "normalized only": as written
    the item is stable within each version but not between them."""
    got = {lab: items(Path(root) / case, k, root) for lab, root in runs.items()}
    names = sorted(set().union(*got.values()),
                   key=lambda s: (s not in ("exit code", "stdout", "stderr"), s))
    diffs, notes = [], []
    for item in names:
        v = {lab: g.get(item, (b"<absent>",) * 3) for lab, g in got.items()}
        for side, label in (("b", "before"), ("a", "after")):
            other = next((lab for lab in v if lab[0] == side and v[lab][1] != v[side + "1"][1]),
                         None)
            if other is not None:
                diffs.append((f"varies within {label}", item,
                              short_diff(v[side + "1"][1], v[other][1])))
        if v["b1"][2] != v["a1"][2]:
            diffs.append(("differs", item, short_diff(v["b1"][1], v["a1"][1])))
        elif v["b1"][1] != v["a1"][1]:
            diffs.append(("identity", item, short_diff(v["b1"][1], v["a1"][1], 8)))
        elif v["b1"][0] != v["a1"][0] and all(v[lab][0] == v[lab[0] + "1"][0] for lab in v):
            notes.append(("normalized only", item, short_diff(v["b1"][0], v["a1"][0], 8)))
    return diffs, notes


def compare(out: Path, cases: list) -> list[dict]:
    """Every case compared, over the runs there are: [{case, steps, diffs: [(step, command,
    kind, item, diff)], notes}]."""
    runs = {d.name: str(d) for d in sorted((out / "w").iterdir())
            if re.fullmatch(r"[ba]\d", d.name)}
    rows = []
    for name, steps in cases:
        rows.append(row := {"case": name, "steps": len(steps), "diffs": [], "notes": []})
        for k, step in enumerate(steps):
            cmd = f"(write {step[1]})" if step[:1] == ("+write",) else "bkflow " + " ".join(step)
            for key, found in zip(("diffs", "notes"), compare_step(runs, name, k)):
                row[key] += [(k, cmd, *d) for d in found]
    return rows


#: a case's differences but the versions' identity
real = lambda row: [d for d in row["diffs"] if d[2] != "identity"]


def report(rows: list[dict]) -> str:
    lines = [f"{'case':26s} result"]
    for r in rows:
        ident = len(r["diffs"]) - len(real(r))
        if not real(r):
            but = f"; the versions' identity in {ident} file(s)" if ident else ""
            lines.append(f"{r['case']:26s} identical ({r['steps']} step(s){but})")
        else:
            k, _, kind, item, _ = real(r)[0]
            lines.append(f"{r['case']:26s} {kind.upper()}: step {k}, {item} "
                         f"({len(real(r))} item(s))")
    for r in rows:
        for k, cmd, kind, item, diff in real(r):
            lines += ["", f"== {r['case']}, step {k}: {cmd}", f"  {kind}: {item}", diff]
    ident = [(r["case"], *d) for r in rows for d in r["diffs"] if d[2] == "identity"]
    if ident:
        case, k, _, _, item, diff = ident[0]
        lines += ["", f"The versions' identity ({IDENTITY}) differs in {len(ident)} file(s), "
                  f"as it must; the first, {case} step {k}, {item}:", diff]
    notes = [(r["case"], *n) for r in rows for n in r["notes"]]
    lines += ["", "Stable within each version, different between them only where normalized "
              "(read these):"] if notes else []
    for case, k, _, _, item, diff in notes:
        lines += [f"-- {case}, step {k}: {item}", diff]
    lines += ["", f"{sum(not real(r) for r in rows)} of {len(rows)} cases identical"]
    return "\n".join(lines)


# ------------------------------------------------------------------------- the command
def parse(argv=None) -> argparse.Namespace:
    p = parser(__doc__)
    for side in ("before", "after"):
        p.add_argument(f"--{side}", type=Path, help="a tree (src/bkflow) or a hook directory")
    p.add_argument("--out", type=Path, default=Path("/tmp/same_outputs"), help="work, report")
    p.add_argument("--python", default=sys.executable, help="the Python of both versions")
    p.add_argument("--reps", type=int, default=2, help="runs of each case with each version")
    p.add_argument("--jobs", type=int, default=1, help="cases run at a time")
    p.add_argument("--only", default=None, help="the cases whose name matches this regex")
    p.add_argument("--timeout", type=float, default=900, help="seconds a step may take")
    for flag, what in (("--compare-only", "compare the runs in --out"), ("--list", "list the "
                       "cases"), ("--raw", "normalize only the working root (--before and "
                                  "--after the same: what differs from run to run)")):
        p.add_argument(flag, action="store_true", help=what)
    return p.parse_args(argv)


def run_all(a, cases: list) -> None:
    """Every case with both versions, ``a.reps`` times, ``a.jobs`` at a time."""
    tasks = []
    shutil.rmtree(a.out / "w", ignore_errors=True)
    for side, given in (("b", a.before), ("a", a.after)):
        hook, src = hook_dir(given, a.out, side)
        for rep in range(1, a.reps + 1):
            root = a.out / "w" / f"{side}{rep}"
            env = environment(hook, a.out, root)
            proc = subprocess.run([a.python, "-m", "inspect", "-d", "bkflow"], env=env,
                                  cwd="/", capture_output=True, text=True)
            origin = next((line.split(": ", 1)[1] for line in proc.stdout.splitlines()
                           if line.startswith("Origin: ")), proc.stderr.strip())
            print(f"{side}{rep}: bkflow from {origin}", flush=True)
            if src is not None and not origin.startswith(src + os.sep):
                sys.exit(f"{given}: the hook imports {origin}, not {src}'s bkflow")
            tasks += [(env, root, name, steps) for name, steps in cases]
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futures = {pool.submit(run_case, a.python, env, root, name, steps, a.timeout):
                   f"{root.name}/{name}" for env, root, name, steps in tasks}
        for f in concurrent.futures.as_completed(futures):
            print(f"  ran {futures[f]} in {f.result():.1f} s", flush=True)


def main(argv=None) -> int:
    a = parse(argv)
    cases = [c for c in CASES if a.only is None or re.search(a.only, c[0])]
    if a.list:
        for name, steps in cases:
            print(name, *("bkflow " + " ".join(s) for s in steps), sep="\n  ")
        return 0
    if a.raw:
        for table in (STREAM_RULES, FILE_RULES, JSON_VOLATILE, CSV_VOLATILE, BYTES_RULES):
            table.clear()
    if not a.compare_only:
        if a.before is None or a.after is None:
            sys.exit("--before and --after are needed (or --compare-only)")
        t0 = time.monotonic()
        run_all(a, cases)
        print(f"ran {len(cases)} case(s) x {a.reps} x 2 in {time.monotonic() - t0:.0f} s\n")
    rows = compare(a.out, cases)
    (a.out / "report.txt").write_text(report(rows) + "\n")
    print(report(rows))
    return 0 if all(not real(r) for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
