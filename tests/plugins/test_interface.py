"""The plugin's interface, named once in its headers and mirrored by name in Python: the output
vector's slots, the path codes and the error tokens (plugins/bk_interface.h), the contact rules
and damping schemes (plugins/bk_model.h). Read from the header text: no LAMMPS needed."""

from __future__ import annotations

import re

from bkflow.lammps.deck import SLOTS
from bkflow.lammps.plugin import ERROR_TOKENS, PATH_CODES
from bkflow.model.params import CONTACT_RULES, DAMPING_MODES
from tests.support import ROOT

INTERFACE = (ROOT / "plugins" / "bk_interface.h").read_text()
MODEL = (ROOT / "plugins" / "bk_model.h").read_text()


def _enum(text: str, name: str) -> list[str]:
    """The enumerators of ``enum name {...}`` in order (comments dropped)."""
    body = re.search(rf"enum {name}\s*\{{(.*?)\}};", text, re.S).group(1)
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    return [e.strip() for e in body.split(",") if e.strip()]


def _names(text: str, table: str) -> list[str]:
    body = re.search(rf"{table}\[[A-Z_]+\] = \{{(.*?)\}};", text, re.S).group(1)
    return re.findall(r'"([^"]*)"', body)


def test_the_output_slots_are_named_alike():
    slots = _enum(INTERFACE, "bk_slot")
    assert slots[-1] == "BK_NSLOTS"
    want = {"BK_SLOT_SIGMA": "sigma_x", "BK_SLOT_BREAKS_STEP": "breaks_step",
            "BK_SLOT_BREAKS_TOTAL": "breaks_total", "BK_SLOT_PLATE": "plate",
            "BK_SLOT_BOND_MAX": "bond_max", "BK_SLOT_PATH": "path",
            "BK_SLOT_E_BOND": "e_bond", "BK_SLOT_E_DRIVE": "e_drive",
            "BK_SLOT_E_CONTACT": "e_contact", "BK_SLOT_E_KINETIC": "e_kinetic",
            "BK_SLOT_WORK": "work", "BK_SLOT_DISS_BREAK": "diss_break",
            "BK_SLOT_DISS_DAMP": "diss_damp", "BK_SLOT_IMAGE_BASE": "image_base",
            "BK_SLOT_OVERSHOOT": "overshoot"}
    assert {want[c]: i for i, c in enumerate(slots[:-1])} == SLOTS


def test_the_path_codes_are_named_alike():
    codes = _enum(INTERFACE, "bk_path_code")
    names = {"BK_PATH_GENERAL": ("general", None),
             "BK_PATH_FUSED_BASELINE": ("fused", "baseline"),
             "BK_PATH_FUSED_AVX2": ("fused", "avx2"), "BK_PATH_FUSED_AVX512": ("fused", "avx512")}
    assert {i: names[c] for i, c in enumerate(codes)} == PATH_CODES


def test_the_error_tokens_are_the_headers():
    defined = dict(re.findall(r'#define BK_ERR_([A-Z_]+) "([^"]+)"', INTERFACE))
    assert {k.lower(): v for k, v in defined.items()} == ERROR_TOKENS


def test_the_contact_rules_and_damping_schemes_are_named_alike():
    assert tuple(_names(MODEL, "BK_CONTACT_NAMES")[1:]) == CONTACT_RULES
    assert tuple(_names(MODEL, "BK_DAMPING_NAMES")[1:]) == DAMPING_MODES
    assert len(_enum(MODEL, "bk_contact_rule")) == len(CONTACT_RULES) + 2  # + none, count
