"""The exact solver near a critical load: its compliance's error grows as 1/margin (the
shooting Jacobian's error over the margin), and the answer says so.

Reference: a cantilever column under an axial tip force P below its Euler load P_cr =
pi^2 EI / (4 L^2) stays straight, and its lateral tip compliance is the closed form
L^3/EI (tan kL - kL) / (kL)^3, k = sqrt(P / EI) (Timoshenko & Gere, beam-columns)."""

from __future__ import annotations

import math
import re

import pytest

import flexgen
from flexgen.models.exact import COMPLIANCE_NOISE, COMPLIANCE_RESOLVED

L, EI = 1.3, 0.7
P_CR = math.pi**2 * EI / (4 * L**2)


def column(ratio: float):
    scene = {
        "name": "column",
        "model": {"kind": "exact"},
        "flexure": [{"name": "b", "length": L, "EI": EI}],
        "load": [{"point": "b.tip", "force": [-ratio * P_CR, 0.0]}],
        "output": {"points": ["b.tip"]},
    }
    return flexgen.solve(scene)


def lateral_compliance(ratio: float) -> float:
    kl = math.sqrt(ratio * P_CR / EI) * L
    return L**3 / EI * (math.tan(kl) - kl) / kl**3


def stated_error(message: str) -> float:
    return float(re.search(r"off by ([0-9.e+-]+) relative", message).group(1))


def near_messages(result) -> tuple[list[str], list[str]]:
    pick = [m for m in result.warnings if m.startswith("near a critical load")]
    return pick, [m for m in result.notes if m.startswith("near a critical load")]


@pytest.mark.parametrize("ratio", [0.5, 0.9])
def test_far_from_critical_the_compliance_is_the_closed_form_without_a_message(ratio):
    r = column(ratio)
    c = r.points["b.tip"].compliance[1][1]
    assert abs(c / lateral_compliance(ratio) - 1.0) < COMPLIANCE_NOISE / 0.05
    assert near_messages(r) == ([], [])


def test_close_to_critical_a_note_states_the_compliance_error_which_holds():
    r = column(0.97)
    warnings, notes = near_messages(r)
    assert warnings == [] and len(notes) == 1, (r.warnings, r.notes)
    stated = float(re.search(r"about ([0-9.e+-]+) relative", notes[0]).group(1))
    assert stated < COMPLIANCE_RESOLVED
    true = abs(r.points["b.tip"].compliance[1][1] / lateral_compliance(0.97) - 1.0)
    assert true <= stated


def stated_bound(result) -> tuple[float, bool]:
    """The compliance error the answer's one near-critical message states, and whether that
    message is a warning."""
    warnings, notes = near_messages(result)
    assert len(warnings) + len(notes) == 1, (result.warnings, result.notes)
    if warnings:
        return stated_error(warnings[0]), True
    return float(re.search(r"about ([0-9.e+-]+) relative", notes[0]).group(1)), False


@pytest.mark.parametrize("ratio", [0.9999, 0.999999, 0.9999999, 0.99999999])
def test_closer_the_stated_error_bound_holds_and_warns_past_resolved(ratio):
    r = column(ratio)
    stated, warned = stated_bound(r)
    true = abs(r.points["b.tip"].compliance[1][1] / lateral_compliance(ratio) - 1.0)
    # the bound holds and is not loose by more than 10 times (4.4x to 6x on a lone column); a
    # warning exactly where it passes COMPLIANCE_RESOLVED (margin below about 1e-7: the
    # complex-step Jacobian; central differences warned from 1e-2)
    assert stated / 10 <= true <= stated
    assert warned == (stated > COMPLIANCE_RESOLVED)
    assert warned == (ratio >= 0.9999999)
    assert not warned or "not resolved" not in r.warnings[0]


def test_at_the_euler_load_neither_compliance_nor_stability_is_claimed():
    r = column(1.0)
    warnings, _ = near_messages(r)
    assert len(warnings) == 1, r.warnings
    assert stated_error(warnings[0]) > 0.1 and "whether it is stable is not resolved" in warnings[0]


def test_the_bound_holds_for_a_column_in_a_tree():
    # review: the column beside an unloaded second branch, its root turned by pi, was 1.19x
    # off the first constant (3e-9)
    P = 0.9999 * P_CR
    scene = {
        "name": "tree",
        "model": {"kind": "exact"},
        "flexure": [
            {"name": "b", "length": L, "EI": EI, "at": [0.0, 0.0, math.pi]},
            {"name": "side", "parent": "base", "length": 0.5, "EI": 1.0, "at": [0.0, 0.3, 0.5]},
        ],
        "load": [{"point": "b.tip", "force": [P, 0.0]}],
        "output": {"points": ["b.tip"]},
    }
    r = flexgen.solve(scene)
    stated, _ = stated_bound(r)
    true = abs(r.points["b.tip"].compliance[1][1] / lateral_compliance(0.9999) - 1.0)
    assert true <= stated
