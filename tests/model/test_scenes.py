"""bkflow.model.scenes: one table of what each scene records, which the run's parameters,
the observables' needs and the docs read."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from bkflow.analysis.summary_keys import OBSERVABLES, Key, Observable
from bkflow.model.params import RunSpec
from bkflow.model.scenes import RECORDS, SCENE_RECORDS, SCENES, records, scenes_with

ROOT = Path(__file__).resolve().parents[2]


def test_a_runs_writes_follow_the_table():
    for scene in SCENES:
        spec = RunSpec(phi=1.0, scene=scene)
        for record in RECORDS:
            assert getattr(spec, f"writes_{record}") == (record in SCENE_RECORDS[scene])
    assert scenes_with("energy") == ("events", "full")
    assert SCENE_RECORDS["full"] == tuple(RECORDS)   # full keeps everything
    with pytest.raises(KeyError, match="not a record"):
        records("full", "ledger")


def test_every_observables_need_is_a_record_a_scene_keeps():
    assert {o.needs for o in OBSERVABLES} - {None} <= set(RECORDS)
    with pytest.raises(ValueError, match="not a record a scene keeps"):
        Observable("x", (Key("x", "", "made up"),), needs="ledger")


def test_the_docs_scene_table_lists_the_scenes_in_order():
    """docs/running.md's table of --scene: one row per scene, in the CLI's order."""
    text = (ROOT / "docs" / "running.md").read_text()
    text = text[text.index("| scene | adds | for |"):].split("\n\n")[0]
    rows = re.findall(r"^  \| `(\w+)`(?: \(default\))? \|", text, flags=re.M)
    assert tuple(rows) == SCENES
