"""What the benchmarks share: where the records are, the arguments every script takes alike, the
timing of alternated rounds, and the commands of this environment (bkflow, lmp, mpirun).

A benchmark runs as a module from the repository's root (``python -m
benchmarks.measure.throughput``), so that it imports this one, and any other part of the
package, by its name: no script changes ``sys.path``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

#: the repository's root, and the folder of RESULTS.md and its figures
ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"
#: every record a benchmark writes (JSON, CSV, or a folder of Parquet files per study)
RECORDS = BENCH / "records"


# ------------------------------------------------------------------------ the commands
def tool(name: str) -> str:
    """The command ``name`` of this environment: the one beside this Python (bkflow, lmp,
    mpirun), as a user's shell would find it after activating the environment."""
    return str(Path(sys.executable).with_name(name))


BKFLOW = tool("bkflow")


def run_bkflow(*args, **kw) -> subprocess.CompletedProcess:
    """``bkflow ARGS`` as a process of its own, which must succeed (its output captured; a
    timeout of two hours unless ``timeout`` says otherwise)."""
    kw.setdefault("timeout", 7200)
    return subprocess.run([BKFLOW, *map(str, args)], check=True, capture_output=True, **kw)


# ------------------------------------------------------------------------ the arguments
def parser(doc: str, **kw) -> argparse.ArgumentParser:
    """A script's parser: its description the first line of ``doc`` (its module docstring),
    and no abbreviated options (an option a later version adds cannot change what an
    abbreviation meant)."""
    return argparse.ArgumentParser(description=doc.splitlines()[0], allow_abbrev=False, **kw)


def floats(text: str) -> list[float]:
    """``--phi 30,100,1000``: a comma-separated list of numbers."""
    return [float(v) for v in text.split(",")]


def ints(text: str) -> list[int]:
    """``--seeds 1,2,3``: a comma-separated list of whole numbers."""
    return [int(v) for v in text.split(",")]


def add_shard(ap: argparse.ArgumentParser) -> None:
    """``--shard I/K``: this process takes every K-th case from the I-th (one process per
    core: I = 0 .. K-1)."""
    ap.add_argument("--shard", default="0/1", help="I/K: every K-th case from the I-th")


def shard(items: Sequence, spec: str) -> list:
    """The cases of ``items`` that ``--shard I/K`` gives this process."""
    i, k = (int(v) for v in spec.split("/"))
    return list(items)[i::k]


def print_progress(message: str) -> None:
    """A long measurement's progress line, shown as it comes (the log of ``LongRun``)."""
    print(message, flush=True)


# ------------------------------------------------------------------------ the timing
def timed(fn: Callable[..., Any], *args, **kw) -> tuple[Any, float]:
    """(what ``fn(*args, **kw)`` returns, its wall time in seconds)."""
    t0 = time.perf_counter()
    out = fn(*args, **kw)
    return out, time.perf_counter() - t0


def timed_process(cmd: Sequence, **kw) -> float:
    """The wall time of the command ``cmd`` as a process of its own, which must succeed (its
    output captured)."""
    kw.setdefault("capture_output", True)
    return timed(subprocess.run, [str(c) for c in cmd], check=True, **kw)[1]


def alternated(cases: Mapping[str, Callable[[int], float]],
               rounds: int) -> dict[str, list[float]]:
    """Each case's measurement ``rounds`` times, the cases in turn within each round, so that
    a shared machine's drift and noise hit every case alike: {case: [one value a round]}. A
    case is called with the round's number (0, 1, ...)."""
    out = {name: [] for name in cases}
    for k in range(rounds):
        for name, measure in cases.items():
            out[name].append(measure(k))
    return out


def medians(values: Mapping[str, Sequence[float]]) -> dict[str, float]:
    """The median of each case's values (``alternated``'s rounds)."""
    return {name: statistics.median(v) for name, v in values.items()}


# ------------------------------------------------------------------------ the records
def read_json(path: Path) -> Any:
    """A JSON record, or None where it has not been measured yet."""
    path = Path(path)
    return json.loads(path.read_text()) if path.exists() else None


def write_json(path: Path, data: Any, *, sort_keys: bool = False) -> Path:
    """Write a JSON record (one space of indent, a final newline), its folder made."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1, sort_keys=sort_keys) + "\n")
    return path
