"""One source for every number: the generated blocks of benchmarks/RESULTS.md and
workflows/paper/REPRODUCTION.md are what benchmarks/documents/ makes from the recorded
benchmarks (benchmarks/records/), and the switching calibration bkflow installs
(src/bkflow/model/switching.json) is what benchmarks/report/stiff_states.py makes from
the same records. A document or a calibration edited by hand, or records changed without the
documents regenerated, fail here."""

from __future__ import annotations

import json

import numpy as np
import pytest


@pytest.fixture(scope="module")
def blocks():
    from benchmarks.documents import results_blocks

    return results_blocks


def test_every_generated_block_is_its_records(blocks):
    for doc in blocks.DOCUMENTS:
        text = doc.read_text()
        names = {m[1] for m in blocks.BLOCK.findall(text)}
        assert names, f"{doc} has no generated block"
        assert not names - set(blocks.BLOCKS), f"{doc}: blocks no generator makes"
        assert blocks.render(text) == text, (
            f"{doc}: a generated block differs from its records; run python -m "
            "benchmarks.documents.results_blocks --write")


def test_a_block_edited_by_hand_is_caught(blocks):
    """The first block of RESULTS, edited by hand, is made anew (only that block is rendered:
    the whole documents are the test above's)."""
    doc = blocks.DOCUMENTS[0].read_text()
    m = blocks.BLOCK.search(doc)
    edited = m.group(1) + m.group(3).replace("|", "| 9", 1) + m.group(4)
    assert edited != m.group(0)
    assert blocks.render(edited) == m.group(0) != edited


def _close(a, b) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(
            _close(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(map(_close, a, b))
    if isinstance(a, float) or isinstance(b, float):
        return bool(np.isclose(a, b, rtol=1e-9, atol=0))
    return a == b


def test_the_installed_switching_calibration_is_the_records():
    from benchmarks.documents.stiff_end import states
    from bkflow.model.calibration import CALIBRATION_FILE

    sr, runs, means = states()
    made = json.loads(sr.calibration_text(runs, means))
    installed = json.loads(CALIBRATION_FILE.read_text())
    assert _close(made, installed), ("src/bkflow/model/switching.json differs from the "
                                     "records: run python -m benchmarks.report.stiff_states")


def test_the_long_run_curve_record_is_the_records():
    """benchmarks/records/long_run_curve.csv (which fig2a_protocols draws) is what the long
    runs' records give (benchmarks/report/stiff_states.py writes it)."""
    import pandas as pd

    from benchmarks.documents.stiff_end import states

    sr, runs, means = states()
    made = sr.curve_table(means)
    recorded = pd.read_csv(sr.CURVE)
    pd.testing.assert_frame_equal(made.reset_index(drop=True), recorded, check_dtype=False,
                                  rtol=1e-8)
