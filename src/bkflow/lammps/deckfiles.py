"""The deck files ``bkflow deck`` writes (in.bk, data.bk, params.json), signed so that it
replaces only its own (``written_by_bkflow``); where it may write them (``check_deck_target``);
and the standard decks checked in under lammps_inputs/. The texts are ``bkflow.lammps.deck``'s.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from bkflow.lammps.deck import DeckOptions, data_text, deck_text
from bkflow.model.checks import SpecError
from bkflow.model.params import RunSpec
from bkflow.store import formats
from bkflow.store.files import write_text_atomic
from bkflow.store.layout import DATA, DECK, EXTREMA, META, PARAMS, STRESS
from bkflow.store.rundir import RunDir

#: the decks checked in under lammps_inputs/ (regenerate: python -m bkflow.lammps.deckfiles
#: lammps_inputs)
STANDARD_DECKS = {
    "N100_phi10": RunSpec(phi=10.0, Lx=20, Ly=5, seed=1),
    "N900_phi10": RunSpec(phi=10.0, Lx=60, Ly=15, seed=1),
    # the random start of the contacts (the model's "Starting state"): a stiff layer that
    # reaches its steady state without the paper's long synchronized transient
    "N100_phi1000_random": RunSpec(phi=1000.0, Lx=20, Ly=5, seed=1, start="random"),
}


def write_standard_decks(root) -> list[str]:
    """Write every deck of ``STANDARD_DECKS`` into ``root/NAME/``."""
    return [write_deck(spec, Path(root) / name)["deck"] for name, spec in STANDARD_DECKS.items()]


#: how ``write_deck`` writes a deck unless told otherwise
DEFAULT_OPTIONS = DeckOptions()
#: the signature bkflow deck puts on the files it writes, so that it replaces only its own:
#: in.bk ends with this line, data.bk's title line ends with it, over a SHA-256 of the rest
SIGNATURE = "bkflow-sha256:"


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def _signed(name: str, text: str, params: str = "") -> str:
    if name == DECK:  # and params.json, which cannot carry a comment
        return text + f"# {SIGNATURE}{_digest(text)} {PARAMS}:{_digest(params)}\n"
    title, rest = text.split("\n", 1)
    return f"{title} {SIGNATURE}{_digest(text)}\n{rest}"


def _params_text(spec: RunSpec) -> str:
    return json.dumps(spec.to_dict(), indent=2, sort_keys=True) + "\n"


def written_by_bkflow(path) -> bool:
    """Whether ``path`` (an in.bk, data.bk or params.json) is exactly as bkflow deck wrote it:
    its signature matches its text (params.json: it is a RunSpec written the canonical way).
    A hand-written or hand-edited file is the user's, and bkflow deck does not replace it."""
    path = Path(path)
    try:
        text = formats.read_text(path)
    except (OSError, UnicodeDecodeError):
        return False
    if path.name == PARAMS:  # its digest is on in.bk's signature line
        deck = path.with_name(DECK)
        if deck.exists():
            return (written_by_bkflow(deck) and formats.read_text(deck).rstrip("\n").endswith(
                f" {PARAMS}:{_digest(text)}"))
        try:  # without its deck: at least written the way bkflow writes it
            return _params_text(RunSpec.from_dict(json.loads(text))) == text
        except Exception:  # anything unreadable is not provably ours
            return False
    if path.name == DECK:
        body, sep, last = text.rstrip("\n").rpartition("\n")
        return bool(sep) and last.startswith(f"# {SIGNATURE}{_digest(body + chr(10))} ")
    if path.name == DATA:  # the signature ends the title line, over the whole text
        title, sep, rest = text.partition("\n")
        plain, mark, sig = title.rpartition(f" {SIGNATURE}")
        return bool(sep and mark) and sig == _digest(f"{plain}\n{rest}")
    return False


def write_deck(spec: RunSpec, directory,
               options: DeckOptions = DEFAULT_OPTIONS) -> dict[str, str]:
    """Write ``in.bk`` (with ``options``), ``data.bk`` and ``params.json`` into
    ``directory``, each atomically and signed (``written_by_bkflow``); return
    {name: path}."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    params = _params_text(spec)
    write_text_atomic(d / DATA, _signed(DATA, data_text(spec)))
    write_text_atomic(d / PARAMS, params)
    write_text_atomic(d / DECK, _signed(DECK, deck_text(spec, options.replace()), params))
    return {"deck": str(d / DECK), "data": str(d / DATA), "params": str(d / PARAMS)}


def check_deck_target(spec: RunSpec, d: RunDir, shown) -> None:
    """Refuse what ``bkflow deck`` does not write: a run that needs the engine (an adaptive
    run, a companion), and a directory that is not empty or a deck of its own (``shown``: the
    directory as the message names it); a file it would replace must carry its signature."""
    if spec.adaptive:
        raise SpecError("an adaptive run (--until-steady, --target-error) needs the engine, "
                        "which checks between chunks (bkflow run); a deck runs exactly "
                        "--t-end")
    if spec.companion is not None:
        raise SpecError(f"companion {spec.companion} (--companion or --set): a deck is one run, "
                        "and a companion is a second run beside it, which bkflow run runs; "
                        f"write the companion's own deck with --start {spec.companion} --out "
                        "ANOTHER_DIR")
    made = META if d.meta() is not None else next(
        (n for n in (EXTREMA, STRESS) if d.file(n).exists()), None)
    if made is not None:
        raise SpecError(f"{shown} holds a run ({made}); a deck is written only into an empty "
                        "directory or over a deck: choose another --out")
    why = d.foreign()
    if why is not None and not why.startswith("holds a deck"):
        raise SpecError(f"{shown} {why}: choose another --out")
    for name in (DECK, DATA, PARAMS):  # replace only what bkflow deck wrote
        if d.file(name).exists() and not written_by_bkflow(d.file(name)):
            raise SpecError(f"{d.file(name)} was not written by bkflow deck, or was edited "
                            "since (its signature does not match): bkflow replaces only its "
                            "own decks; choose another --out")


if __name__ == "__main__":  # python -m bkflow.lammps.deckfiles lammps_inputs: the standard decks
    import sys

    for path in write_standard_decks(sys.argv[1] if len(sys.argv) > 1 else "lammps_inputs"):
        print("wrote", path)
