"""The fuzz's machinery: a scratch directory with a finished run and a finished sweep that no
case may change, the ``bkflow`` command run as a user runs it, and the verdict on each case.

A case is CLEAN when

- the exit code is the one expected (README, "Exit codes"),
- stderr has no traceback and, on failure, exactly one line (a warning line may precede it),
- nothing finished changed: the finished run and the finished sweep made at the start keep
  every byte of every file, and no directory the case wrote into looks finished unless it is.

The cases themselves are the parts of ``benchmarks.checks.faults.run.PARTS``, each a function
of a ``Fuzz``.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

from benchmarks.harness import BKFLOW

#: a short run of the friction scene, quiet
SHORT = ["--t-end", "100", "--scene", "friction", "--quiet"]


@dataclass
class Result:
    case: str
    code: int | None
    first: str
    verdict: str


def bk(*args, cwd=None, timeout=300, **kw):
    """``bkflow ARGS`` as a user runs it: its exit code and output, whatever they are."""
    return subprocess.run([BKFLOW, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=timeout, **kw)


def digest(root: Path) -> dict:
    """Every file under ``root`` (lock files left out) by its SHA-256."""
    out = {}
    for p in sorted(root.rglob("*")):
        if p.is_file() and not p.name.endswith(".lock"):
            out[str(p.relative_to(root))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def row_cut(data: bytes) -> int:
    """Where a .npy file holding half its rows whole ends: its header and rows up to the
    middle (a binary table's cut at a line)."""
    import io

    import numpy as np

    f = io.BytesIO(data)
    version = np.lib.format.read_magic(f)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
        np.lib.format.read_array_header_2_0
    shape, _, dtype = read(f)
    row = dtype.itemsize * int(np.prod(shape[1:], dtype=int))
    return f.tell() + (shape[0] // 2 if shape else 0) * row


def complete(d: Path) -> bool:
    """Whether ``d`` holds a run that says it finished."""
    try:
        return json.loads((d / "meta.json").read_text()).get("status") == "complete"
    except (OSError, ValueError):
        return False


def whole_figure(path: Path) -> bool:
    """A PNG that Pillow reads to its end, or a PDF that ends as a PDF does."""
    data = path.read_bytes()
    if path.suffix == ".pdf":
        return data.startswith(b"%PDF") and b"%%EOF" in data[-64:]
    from io import BytesIO

    from PIL import Image

    try:
        Image.open(BytesIO(data)).load()
        return True
    except Exception:
        return False


def stderr_problems(proc, expected) -> list[str]:
    """What is wrong with a case's exit code and stderr (module doc)."""
    code = proc.returncode if proc is not None else None
    err = (proc.stderr if proc is not None else "") or ""
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    problems = []
    if code not in expected:
        problems.append(f"exit {code}, expected {sorted(expected)}")
    if "Traceback" in err:
        problems.append("traceback")
    if code not in (0, None) and len([ln for ln in lines if "warning" not in ln]) != 1:
        problems.append(f"{len(lines)} stderr lines")
    return problems


class Fuzz:
    """The scratch directory ``root`` of one fuzz, its finished run (``base``, the full scene:
    every derived file exists) and sweep (``sweep``) that no case may change, and the
    results so far."""

    def __init__(self, root: Path):
        self.root = root
        self.results: list[Result] = []
        self.base = root / "base"          # a finished run nothing may change
        self.sweep = root / "sweep"        # a finished sweep nothing may change
        # the full scene: every derived file (fronts for the movie, the ledger) exists
        p = bk("run", "--phi", "10", "--t-end", "200", "--scene", "full", "--out", self.base,
               "--quiet")
        assert p.returncode == 0, p.stderr
        p = bk("sweep", "--phi", "1,10", "--seeds", "1", "--t-end", "100", "--scene", "friction",
               "--jobs", "2", "--out", self.sweep, "--quiet")
        assert p.returncode == 0, p.stderr
        self.before = {d: digest(d) for d in (self.base, self.sweep)}
        self.n = 0

    @staticmethod
    def tmpfs(where: Path, options: str) -> bool:
        """Mount a tmpfs at ``where`` (root only); False where mounting is not allowed."""
        where.mkdir(parents=True, exist_ok=True)
        return subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)],
                              capture_output=True).returncode == 0

    def scratch(self) -> Path:
        """A new empty directory of this fuzz."""
        self.n += 1
        d = self.root / f"case{self.n:03d}"
        d.mkdir()
        return d

    def sweep_copy(self) -> Path:
        """A copy of the finished sweep (its symbolic links as links), to damage."""
        import shutil

        d = self.scratch() / "s"
        shutil.copytree(self.sweep, d, symlinks=True)
        return d

    def check(self, case: str, proc, expected, not_finished=(), note="") -> None:
        """Judge one case: ``proc`` (a finished process, or None where none ran) against the
        exit codes ``expected``, the finished run and sweep, and the directories
        ``not_finished`` that must not look finished."""
        problems = stderr_problems(proc, expected)
        for d in self.before:
            if digest(d) != self.before[d]:
                problems.append(f"{d.name} changed")
                self.before[d] = digest(d)
        problems += [f"{Path(d).name} looks finished" for d in not_finished if complete(Path(d))]
        err = (proc.stderr if proc is not None else "") or ""
        lines = [ln for ln in err.strip().splitlines() if ln.strip()]
        first = lines[-1] if lines else (proc.stdout.strip().splitlines()[:1] or [""])[0] \
            if proc is not None else note
        self.results.append(Result(case, proc.returncode if proc is not None else None,
                                   first[:110], "CLEAN" if not problems else "; ".join(problems)))

    def skip(self, case: str, why: str) -> None:
        self.results.append(Result(case, None, why, "SKIPPED"))
