"""Scene values with units (flexgen/units.py, docs/scene.md "Units"): unit strings and a units
choice give the same answer as the plain numbers converted by hand; every bad unit is a one-line
SceneError naming its key; a scene without units is untouched (and does not import pint); a bend
at an absurd load level warns to check the units."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import flexgen
from flexgen.scene import SceneError, scene_from_dict
from flexgen.units import Units, normalise, result_units

ROOT = Path(__file__).resolve().parents[1]

# One strip, by hand in SI: L = 20 mm, 10 mm x 0.3 mm steel, so
# EI = 200e9 N/m^2 x 0.010 m x (0.0003 m)^3 / 12 = 4.5e-3 N m^2; a 20 N tip force (load level
# F L^2/EI = 1.8: a clear bend), a 10 N mm moment, a root placed at (1 mm, 2 mm, 0.1 rad), and a
# link point 5 mm along and 1 mm off the tip.
SI = {
    "flexure": [
        {
            "name": "f",
            "length": 0.020,
            "E": 200e9,
            "width": 0.010,
            "thickness": 0.0003,
            "at": [0.001, 0.002, 0.1],
        }
    ],
    "link": [{"name": "k", "parent": "f", "points": {"p": [0.005, 0.001]}}],
    "load": [{"point": "k.p", "force": [0.0, -20.0], "moment": 0.010}],
}
STRINGS = {
    "flexure": [
        {
            "name": "f",
            "length": "20 mm",
            "E": "200 GPa",
            "width": "10 mm",
            "thickness": "0.3 mm",
            "at": ["1 mm", "2 mm", 0.1],  # a plain number: in the scene's system (SI: rad)
        }
    ],
    "link": [{"name": "k", "parent": "f", "points": {"p": ["5 mm", "1 mm"]}}],
    "load": [{"point": "k.p", "force": ["0 N", "-20 N"], "moment": "10 N*mm"}],
}
# the same in plain numbers in mm and N: E = 200e9 N/m^2 = 200e3 N/mm^2, moment 10 N mm
MM = {
    "units": {"length": "mm", "force": "N"},
    "flexure": [
        {
            "name": "f",
            "length": 20.0,
            "E": 200e3,
            "width": 10.0,
            "thickness": 0.3,
            "at": [1.0, 2.0, 0.1],
        }
    ],
    "link": [{"name": "k", "parent": "f", "points": {"p": [5.0, 1.0]}}],
    "load": [{"point": "k.p", "force": [0.0, -20.0], "moment": 10.0}],
}


def _close(a, b, rtol=1e-10):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert np.allclose(a, b, rtol=rtol, atol=rtol * np.max(np.abs(b))), (a, b)


def test_unit_strings_are_converted_into_si():
    sc = scene_from_dict(STRINGS)
    f = sc.flexures[0]
    assert f.length == pytest.approx(0.020, rel=1e-14)
    assert f.EI == pytest.approx(4.5e-3, rel=1e-12)
    assert f.at == pytest.approx((0.001, 0.002, 0.1), rel=1e-14)
    assert sc.links[0].points["p"] == pytest.approx((0.005, 0.001), rel=1e-14)
    assert sc.loads[0].force == (0.0, -20.0)
    assert sc.loads[0].moment == pytest.approx(0.010, rel=1e-14)
    assert sc.units == Units("m", "N")


def test_same_answer_in_si_in_unit_strings_and_in_mm():
    si, strings, mm = (flexgen.solve(d, estimate=False) for d in (SI, STRINGS, MM))
    for r in (si, strings, mm):
        assert r.converged
    assert 0.3 < abs(si.points["k.p"].pose[2]) < 1.5  # a clear bend: the test can tell
    p_si, p_str, p_mm = (r.points["k.p"] for r in (si, strings, mm))
    _close(p_str.pose, p_si.pose)
    _close(p_str.compliance, p_si.compliance)
    # mm: positions x 1000, the angle as it is; compliance m/N -> mm/N x 1000; the generalized
    # stiffness (force x length: q is dimensionless) N m -> N mm x 1000
    _close(p_mm.pose[:2], np.array(p_si.pose[:2]) * 1000.0)
    _close(p_mm.pose[2], p_si.pose[2])
    _close(p_mm.compliance, np.array(p_si.compliance) * 1000.0)
    _close(mm.stiffness, si.stiffness * 1000.0)
    _close(mm.q["f"], si.q["f"])


def test_a_plain_scene_is_untouched_and_does_not_import_pint():
    d = {"flexure": [{"name": "f", "length": 1.0, "EI": 1.0}]}
    assert normalise(d) == (d, None) and normalise(d)[0] is d
    assert scene_from_dict(d).units is None
    code = (
        "import sys, flexgen; "
        "r = flexgen.solve({'flexure': [{'name': 'f', 'length': 1.0, 'EI': 1.0}], "
        "'load': [{'point': 'f.tip', 'force': [0.0, -1.0]}]}, estimate=False); "
        "print(r.converged, 'pint' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=60
    )
    assert out.stdout.split() == ["True", "False"], out.stderr


def test_units_choice_labels_a_plain_scene():
    sc = scene_from_dict({"units": "SI", "flexure": [{"name": "f", "length": 1.0, "EI": 1.0}]})
    assert sc.flexures[0].length == 1.0 and sc.units == Units("m", "N")
    sc = scene_from_dict(MM)
    assert sc.flexures[0].length == 20.0  # plain numbers are read in the chosen mm
    assert sc.units == Units("mm", "N")
    # a unit string in a mm scene is converted into mm: 2 cm = 20 mm, 0.2 GPa = 200 N/mm^2
    d = {
        "units": {"length": "mm"},  # force: N, SI's
        "flexure": [{"name": "f", "length": "2 cm", "E": "0.2 GPa", "I": "1 mm^4"}],
    }
    f = scene_from_dict(d).flexures[0]
    assert f.length == pytest.approx(20.0, rel=1e-14)
    assert f.EI == pytest.approx(200.0, rel=1e-14)
    d["flexure"][0]["I"] = "1 cm⁴"  # a superscript exponent: 1e4 mm^4
    assert scene_from_dict(d).flexures[0].EI == pytest.approx(200.0 * 1e4, rel=1e-14)


def test_labels_and_the_json_units_object():
    assert Units("mm", "N").as_dict() == {
        "length": "mm",
        "force": "N",
        "moment": "N*mm",
        "angle": "rad",
        "compliance": "mm/N",
        "stress": "MPa",
        "curvature": "1/mm",
        "stiffness": "N*mm",
        "cross compliance": "1/N",
        "rotational compliance": "rad/(N*mm)",
    }
    si = Units("m", "N")
    assert [si.label(q) for q in ("stress", "compliance", "EI")] == ["Pa", "m/N", "N*m^2"]
    assert Units("um", "mN").label("stress") == "GPa"  # 1e-3 N / 1e-12 m^2
    assert Units("in", "lbf").label("stress") == "lbf/in^2"  # not a prefixed pascal
    with pytest.raises(ValueError, match="no label"):
        si.label("speed")
    assert result_units(scene_from_dict(MM))["compliance"] == "mm/N"
    assert result_units(scene_from_dict(SI)) is None
    assert scene_from_dict({"units": {"length": "µm"}, "flexure": SI["flexure"]}).units == Units(
        "um", "N"
    )


def test_degrees_in_at():
    d = {"flexure": [{"name": "f", "length": 1.0, "EI": 1.0, "at": [0, 0, "30 deg"]}]}
    assert scene_from_dict(d).flexures[0].at[2] == pytest.approx(math.pi / 6, rel=1e-14)
    d["flexure"][0]["at"] = ["1 m", 0, "-0.25 turn"]
    assert scene_from_dict(d).flexures[0].at == pytest.approx((1.0, 0.0, -math.pi / 2))


def _error(d) -> str:
    with pytest.raises(SceneError) as e:
        scene_from_dict(d)
    msg = str(e.value)
    assert "\n" not in msg and msg.isprintable()
    return msg


def _flexure(**kv) -> dict:
    return {"flexure": [{"name": "f", "length": 0.02, "EI": 1.0} | kv]}


@pytest.mark.parametrize(
    "d, key, words",
    [
        (_flexure(length="3 N"), "flexure[0].length", "dimension force, expected length"),
        (_flexure(length="20 foo"), "flexure[0].length", "unknown unit 'foo'"),
        (_flexure(length="20"), "flexure[0].length", "without a unit"),
        (_flexure(length="mm"), "flexure[0].length", "a number and a unit"),
        (_flexure(length="nan mm"), "flexure[0].length", "a number and a unit"),
        (_flexure(length="1e400 mm"), "flexure[0].length", "not a finite number"),
        (_flexure(length="1e98 pc"), "flexure[0].length", "beyond the limit 1e+100"),
        (  # the force unit alone, not "m^0*N"
            _flexure() | {"load": [{"point": "f.tip", "force": [0, "1e101 N"]}]},
            "load[0].force[1]",
            "is 1e+101 N, beyond",
        ),
        (_flexure(length="3 deg"), "flexure[0].length", "dimension angle, expected length"),
        (_flexure(EI="3 GPa"), "flexure[0].EI", "expected bending stiffness"),
        # pint counts angles and ratios as no dimension: they would rescale a length silently
        (_flexure(length="20 mm*deg"), "flexure[0].length", "cannot have the factor 'degree'"),
        (_flexure(length="20 mm*percent"), "flexure[0].length", "the factor 'percent'"),
        (_flexure(length="20 mm/turn"), "flexure[0].length", "the factor 'turn'"),
        (_flexure(EI="2 N*m^2*rad"), "flexure[0].EI", "the factor 'radian'"),
        (_flexure() | {"units": {"length": "mm*deg"}}, "units.length", "the factor 'degree'"),
        (_flexure(at=[0, 0, "3 mm"]), "flexure[0].at[2]", "expected angle"),
        (_flexure(at=[0, 0, "3 percent"]), "flexure[0].at[2]", "expected angle"),
        (_flexure(length="10**10**10 m"), "flexure[0].length", "cannot read the unit"),
        (_flexure(length="2 m**9**9"), "flexure[0].length", "cannot read the unit"),
        (_flexure(length="2 " + "m" * 200), "flexure[0].length", "too long"),
        (_flexure(modes="3 mm"), "flexure[0].modes", "must be an integer"),
        (_flexure(tolerance="1 %"), "flexure[0].tolerance", "must be a number"),
        (_flexure(yield_strength="3 N"), "flexure[0].yield_strength", "expected stress"),
        (
            {"model": {"fatigue_strength": "1 mm"}} | _flexure(),
            "model.fatigue_strength",
            "expected stress",
        ),
        (
            _flexure() | {"base": {"points": {"r0": [0, "1 N"]}}},
            "base.points.r0[1]",
            "expected length",
        ),
        (
            _flexure() | {"load": [{"point": "f.tip", "force": [0, 1], "moment": "1 N"}]},
            "load[0].moment",
            "dimension force, expected moment",
        ),
        (
            _flexure() | {"tendon": [{"tension": "1 mm", "route": ["base.a", "f.tip"]}]},
            "tendon[0].tension",
            "expected force",
        ),
        (_flexure() | {"units": "furlongs"}, "units", 'must be "SI" or a table'),
        (_flexure() | {"units": {"time": "s"}}, "units.time", "unknown key"),
        (_flexure() | {"units": {"length": "N"}}, "units.length", "expected length"),
        (_flexure() | {"units": {"force": "2 N"}}, "units.force", "cannot read the unit"),
    ],
)
def test_bad_units_are_one_line_errors_naming_the_key(d, key, words):
    msg = _error(d)
    assert msg.startswith(f"{key}: ") and words in msg, msg


@pytest.mark.parametrize(
    "d, message",
    [
        (
            _flexure(length="-20 mm"),
            "flexure[0].length: must be a positive number in [1e-100, 1e+100], "
            "got '-20 mm' (-0.02 m)",
        ),
        (
            _flexure()
            | {"units": {"length": "mm"}, "load": [{"point": "f.tip", "force": [0, 1]}]}
            | {"tendon": [{"tension": "-2 kN", "route": ["f.tip", "base.a"]}]}
            | {"base": {"points": {"a": [0, 1]}}},
            "tendon[0].tension: must be zero or a positive number <= 1e+100, got '-2 kN' (-2000 N)",
        ),
        (  # a value that conflicts, as written
            _flexure(E="200 GPa"),
            "flexure[0].E: conflicts with EI (give EI, or E and I, or E, width and thickness), "
            "got '200 GPa' (200000000000 Pa)",
        ),
    ],
)
def test_a_bad_value_with_a_unit_is_shown_as_written(d, message):
    """The message ends with the value as the user wrote it (and what it converts to), not with
    the converted number alone (it said "got -0.02" for "-20 mm")."""
    assert _error(d) == message


def test_no_converted_value_outlives_the_validation():
    s = scene_from_dict(_flexure(length="20 mm", at=["1 mm", 0, "30 deg"]))
    f = s.flexures[0]
    assert all(type(v) is float for v in (f.length, *f.at))


def test_cli_bad_unit_exits_2_with_one_line(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text('[[flexure]]\nname = "f"\nlength = "3 N"\nEI = 1.0\n')
    p = subprocess.run(
        [sys.executable, "-m", "flexgen", "solve", str(scene), "--json"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "flexure[0].length" in lines[0] and "Traceback" not in p.stderr


# E = 200 where 200 GPa was meant, SI otherwise: the load level is 1e9 times too large
E200 = {
    "flexure": [{"name": "f", "length": 0.020, "E": 200, "width": 0.010, "thickness": 0.0003}],
    "load": [{"point": "f.tip", "force": [0.0, -0.2]}],
}


def test_wrong_units_warn():
    r = flexgen.solve(E200, estimate=False)
    assert r.converged
    hits = [w for w in r.warnings if "check the units" in w]
    assert len(hits) == 1 and "flexure 'f'" in hits[0] and "1.78e+07" in hits[0], r.warnings
    good = flexgen.solve(E200 | {"flexure": [E200["flexure"][0] | {"E": 200e9}]}, estimate=False)
    assert good.converged and not any("units" in w for w in good.warnings)


def test_wrong_units_in_a_failed_solve_say_so_in_the_reason():
    r = flexgen.solve(E200, model="exact")  # the elastica gives up past a load of 1e3
    assert not r.converged and "check the units" in r.reason


def test_plot_axes_name_the_units(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib

    from flexgen.drawing import draw

    matplotlib.use("Agg")
    texts = {}
    with matplotlib.rc_context({"svg.fonttype": "none"}):  # text as text, to be read back
        for name, d in (("plain", SI), ("mm", MM)):
            sc = scene_from_dict(d)
            path = draw(sc, flexgen.solve(sc, estimate=False), tmp_path / f"{name}.svg")
            texts[name] = path.read_text()
    assert "x [mm]" in texts["mm"] and "y [mm]" in texts["mm"] and " N in every" in texts["mm"]
    assert "x [" not in texts["plain"] and "[m]" not in texts["plain"]


@pytest.mark.parametrize(
    ("path", "dimension"),
    [
        ("flexure.proximal.thickness", "length"),
        ("flexure.0.EI", "bending stiffness"),
        ("flexure.0.E", "stress"),
        ("flexure.distal.model.fatigue_strength", "stress"),
        ("flexure.0.at.2", "angle"),
        ("flexure.0.at.0", "length"),
        ("model.yield_strength", "stress"),
        ("load.0.force.1", "force"),
        ("load.0.moment", "moment"),
        ("tendon.0.tension", "force"),
        ("link.middle.points.pad.0", "length"),
        ("base.points.r0.1", "length"),
        ("flexure.0.modes", None),
        ("model.tolerance", None),
        # the other spellings a study takes (review: the plot's axis lost its unit)
        ("flexure[0].thickness", "length"),
        ("load[0].force[1]", "force"),
        ("tendon[0].tension", "force"),
        ("flexure.proximal.at.02", "angle"),
        ("load.0.force.01", "force"),
        ("flexure..0", None),
    ],
)
def test_a_study_key_has_the_dimension_of_its_scene_key(path, dimension):
    """What a study's plot labels its axes with (flexgen.sweep_plot): the units table's own
    dimension of that key in a scene (docs/scene.md, Units)."""
    from flexgen.units import key_dimension

    assert key_dimension(path) == dimension


def test_plain_numbers_read_in_si_that_look_like_another_system_warn():
    """One unit string ("1400 MPa") in a scene of plain mm numbers made the flexure 20 m long
    with E = 200 kPa: safety factor 5.26e6 instead of 5.26, unwarned (review)."""
    mm = {
        "model": {"yield_strength": "1400 MPa"},
        "flexure": [{"name": "a", "length": 20, "E": 200000, "width": 10, "thickness": 0.3}],
        "load": [{"point": "a.tip", "force": [0, -2]}],
    }
    r = flexgen.solve(mm)
    (mixed,) = [w for w in r.warnings if "plain number" in w]
    assert mixed.startswith("flexure[0].length = 20 is a plain number")
    # every such number is named, as scene errors name keys (review: the first only, and
    # an at coordinate as "flexure[0].at[0].0")
    assert "(so are flexure[0].E = 200000 Pa)" in mixed
    at = {**mm, "flexure": [{**mm["flexure"][0], "at": [11, 0, 0]}]}
    (mixed,) = [w for w in flexgen.solve(at).warnings if "plain number" in w]
    assert "flexure[0].at[0] = 11 m" in mixed and "at[0].0" not in mixed
    si = {**mm, "flexure": [{"name": "a", "length": 0.02, "E": 2e11, "width": 0.01,
                              "thickness": 0.0003}]}  # fmt: skip
    assert not [w for w in flexgen.solve(si).warnings if "plain number" in w]
    declared = {**mm, "units": {"length": "mm", "force": "N"}}
    assert not [w for w in flexgen.solve(declared).warnings if "plain number" in w]
    assert flexgen.solve(declared).flexures["a"].safety_factor == pytest.approx(
        flexgen.solve({**mm, "model": {"yield_strength": 1400}}).flexures["a"].safety_factor
    )


@pytest.mark.parametrize(
    "units, key, value, warned",
    [
        ({"length": "mm", "force": "N"}, "E", 200e9, True),  # Pa in an MPa scene: 2e17 Pa
        ({"length": "mm", "force": "N"}, "E", 200e3, False),  # 200 GPa in MPa
        ({"length": "mm", "force": "N"}, "yield_strength", 1.4e9, True),
        (None, "E", 200e9, False),  # SI: Pa
        (None, "E", 2.07e13, False),  # plain numbers: any consistent set (cgs steel: review)
    ],
)
def test_an_e_or_strength_beyond_any_material_is_a_warning(units, key, value, warned):
    # review: E = 200e9 in an mm/N scene (2e17 Pa) solved without a word
    length, width, thickness = (20.0, 10.0, 0.3) if units else (0.02, 0.01, 0.0003)
    E = value if key == "E" else (200e3 if units else 200e9)
    flexure = {"name": "b", "length": length, "E": E, "width": width, "thickness": thickness}
    if key != "E":
        flexure[key] = value
    scene = {"name": "s", "flexure": [flexure], "load": [{"point": "b.tip", "force": [0, -1e-3]}]}
    if units:
        scene["units"] = units
    r = flexgen.solve(scene_from_dict(scene))
    hits = [w for w in r.warnings if "beyond any material" in w]
    assert len(hits) == int(warned), r.warnings
    if warned:
        assert f"{key} = {value:g}" in hits[0]


def test_a_failed_solve_keeps_the_scenes_unit_warning():
    # review: the mixed-units warning (the likely cause) was dropped when no equilibrium was found
    scene = {
        "name": "mix",
        "model": {"kernel": "poly"},  # no Gauss fallback: the huge load fails
        "flexure": [
            {"name": "b", "length": "20 mm", "E": 200e3, "width": "10 mm", "thickness": "0.3 mm"}
        ],
        "load": [{"point": "b.tip", "force": ["0 N", "-5 N"]}],
    }
    r = flexgen.solve(scene_from_dict(scene))
    assert not r.converged
    assert any(
        "is a plain number in a scene whose other values carry units" in w for w in r.warnings
    )


def test_a_model_strength_beyond_any_material_is_said_once_with_every_bad_key():
    # review: a [model] strength gave one identical warning per flexure, and E beside it hid it
    section = {"length": 20.0, "E": 200e9, "width": 10.0, "thickness": 0.3}
    scene = {
        "name": "s",
        "units": {"length": "mm", "force": "N"},
        "model": {"yield_strength": 1.4e9},
        "flexure": [{"name": "a", **section}, {"name": "b", "parent": "a", **section}],
        "load": [{"point": "b.tip", "force": [0, -1e-3]}],
    }
    r = flexgen.solve(scene_from_dict(scene))
    hits = [w for w in r.warnings if "beyond any material" in w]
    assert len(hits) == 2, hits
    assert hits[0].startswith("flexures 'a', 'b': E = 2e+11 MPa")
    assert hits[1].startswith("flexures 'a', 'b': yield_strength = 1.4e+09 MPa")


def test_replacing_the_only_unit_string_keeps_the_scenes_units():
    """Review: with E the only value with a unit (plain numbers meant in mm, no ``units`` key),
    a study of E (``with_value``) lost the scene's units: the answers unlabelled and the warning
    that the plain numbers are read in SI gone, also at E's own value."""
    scene = flexgen.scene_from_dict(
        {
            "flexure": [
                {"name": "beam", "length": 20, "E": "200 GPa", "width": 10, "thickness": 0.3}
            ],
            "load": [{"point": "beam.tip", "force": [0, -0.2]}],
        }
    )
    base = flexgen.solve(scene)
    assert any("is a plain number" in w for w in base.warnings)
    for value in (200e9, 200e9 + 1, "200 GPa"):
        changed = scene.with_value("flexure.beam.E", value)
        assert changed.units == scene.units and changed.flexures[0].E == pytest.approx(
            float(value) if not isinstance(value, str) else 200e9, rel=1e-15
        )
        answer = flexgen.solve(changed).to_dict()
        assert answer["units"] == base.to_dict()["units"]
        assert answer["warnings"] == base.warnings
    # a plain scene stays plain
    plain = flexgen.scene_from_dict({"flexure": [{"name": "beam", "length": 1.0, "EI": 2.0}]})
    assert plain.with_value("flexure.beam.EI", 3.0).units is None


@pytest.mark.parametrize(
    "angle, radians",
    [
        ("100 gradian", math.pi / 2),
        ("100 gon", math.pi / 2),
        ("500 mrad", 0.5),
        ("0.25 turn", math.pi / 2),
    ],
)
def test_every_plane_angle_unit_is_an_angle(angle, radians):
    """Review: angles were told by their name's ending, so "gradian" (pint's "grade") was
    refused."""
    scene = flexgen.scene_from_dict(
        {"flexure": [{"name": "beam", "length": 1.0, "EI": 1.0, "at": [0, 0, angle]}]}
    )
    assert scene.flexures[0].at[2] == pytest.approx(radians, rel=1e-15)


@pytest.mark.parametrize("angle", ["0.5 sr", "1 square_degree", "5 mil", "1 percent"])
def test_a_solid_angle_or_a_ratio_is_no_angle(angle):
    """Review: a steradian and a square degree ended in "radian" and "degree", and were read as
    plane angles without a word."""
    with pytest.raises(flexgen.SceneError, match=r"flexure\[0\]\.at\[2\]: .* expected angle"):
        flexgen.scene_from_dict(
            {"flexure": [{"name": "beam", "length": 1.0, "EI": 1.0, "at": [0, 0, angle]}]}
        )


@pytest.mark.parametrize("moment", ["10 Nm", "2 kNm", "300 Nmm"])
def test_a_newton_metre_written_nm_says_how_to_write_it(moment):
    """pint reads "Nm" as a yarn count: the message said "dimension [length] / [mass]"."""
    scene = {
        "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "beam.tip", "force": [0, 0], "moment": moment}],
    }
    with pytest.raises(flexgen.SceneError, match=r'load\[0\]\.moment: .*written "N\*m"$'):
        flexgen.scene_from_dict(scene)


def test_a_bad_value_for_the_only_unit_string_is_told_as_given():
    """Review: once the only unit string's replacement was rewritten in SI, 10**400 was a raw
    OverflowError, nan "'nan Pa': expected a number and a unit" and -5 "got '-5.0 Pa'"."""
    scene = flexgen.scene_from_dict(
        {
            "flexure": [
                {"name": "beam", "length": 1.0, "E": "200 GPa", "width": 0.01, "thickness": 0.001}
            ],
            "load": [{"point": "beam.tip", "force": [0.0, -1.0]}],
        }
    )
    for value, shown in (
        (10**400, "an integer of about 401 digits"),
        (math.nan, "nan"),
        (-5.0, "-5.0"),
    ):
        with pytest.raises(flexgen.SceneError) as err:
            scene.with_value("flexure.0.E", value)
        assert str(err.value) == (
            "flexure.0.E: flexure[0].E: must be a positive number in [1e-100, 1e+100], got " + shown
        )
