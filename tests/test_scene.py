"""Tests for flexgen.scene: loading, defaults, frames/topology helpers and one-line validation."""

from __future__ import annotations

import ast
import copy
import math
from pathlib import Path

import pytest

import flexgen.scene as scene_mod
from flexgen.scene import KERNELS, MODEL_KINDS, ModelSpec, SceneError, load_scene, scene_from_dict

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"

CONTRACT_TOML = """\
name = "two-link finger"

[model]
kind = "scm"
modes = 3
elements = 16

[base]
points = { r0 = [0.0, 0.004] }

[[flexure]]
name = "proximal"
length = 0.020
EI = 2.5e-5
parent = "base"
at = [0.0, 0.0, 0.0]

[[link]]
name = "middle"
parent = "proximal"
points = { pad = [0.020, 0.004], hole = [0.002, 0.003], joint = [0.045, 0.0] }

[[flexure]]
name = "distal"
parent = "middle"
at = [0.045, 0.0, 0.0]
length = 0.015
EI = 2.5e-5

[[link]]
name = "fingertip"
parent = "distal"
points = { pad = [0.015, 0.004], anchor = [0.025, 0.003] }

[[load]]
point = "fingertip.pad"
force = [0.0, -1.0]
moment = 0.0

[[tendon]]
tension = 10.0
route = ["base.r0", "middle.hole", "fingertip.anchor"]

[output]
points = ["middle.pad", "fingertip.pad"]
"""

# The same scene as a dict, every parent explicit (so no declaration order is needed).
VALID = {
    "name": "two-link finger",
    "model": {"kind": "scm", "modes": 3, "elements": 16},
    "base": {"points": {"r0": [0.0, 0.004]}},
    "flexure": [
        {
            "name": "proximal",
            "length": 0.020,
            "EI": 2.5e-5,
            "parent": "base",
            "at": [0.0, 0.0, 0.0],
        },
        {
            "name": "distal",
            "parent": "middle",
            "at": [0.045, 0.0, 0.0],
            "length": 0.015,
            "EI": 2.5e-5,
        },
    ],
    "link": [
        {
            "name": "middle",
            "parent": "proximal",
            "points": {"pad": [0.020, 0.004], "hole": [0.002, 0.003], "joint": [0.045, 0.0]},
        },
        {
            "name": "fingertip",
            "parent": "distal",
            "points": {"pad": [0.015, 0.004], "anchor": [0.025, 0.003]},
        },
    ],
    "load": [{"point": "fingertip.pad", "force": [0.0, -1.0], "moment": 0.0}],
    "tendon": [{"tension": 10.0, "route": ["base.r0", "middle.hole", "fingertip.anchor"]}],
    "output": {"points": ["middle.pad", "fingertip.pad"]},
}


def valid() -> dict:
    return copy.deepcopy(VALID)


# -- valid scenes ----------------------------------------------------------------------------


def test_contract_scene_loads_from_file(tmp_path: Path):
    p = tmp_path / "finger.toml"
    p.write_text(CONTRACT_TOML)
    s = load_scene(p)
    assert s.name == "two-link finger"
    assert s.model == ModelSpec(kind="scm", modes=3, elements=16, kernel="auto", tolerance=None)
    assert dict(s.base_points) == {"r0": (0.0, 0.004)}
    prox, dist = s.flexures
    assert (prox.name, prox.parent, prox.at, prox.length, prox.EI) == (
        "proximal",
        "base",
        (0.0, 0.0, 0.0),
        0.020,
        2.5e-5,
    )
    assert (dist.name, dist.parent, dist.at, dist.length) == (
        "distal",
        "middle",
        (0.045, 0.0, 0.0),
        0.015,
    )
    assert dist.model == s.model
    assert [(lk.name, lk.parent) for lk in s.links] == [
        ("middle", "proximal"),
        ("fingertip", "distal"),
    ]
    assert s.links[0].points["hole"] == (0.002, 0.003)
    assert s.loads[0].point == "fingertip.pad"
    assert s.loads[0].force == (0.0, -1.0)
    assert s.tendons[0].tension == 10.0
    assert s.tendons[0].route == ("base.r0", "middle.hole", "fingertip.anchor")
    assert s.outputs == ("middle.pad", "fingertip.pad")
    assert s.declaration_order == ("proximal", "middle", "distal", "fingertip")
    assert s == scene_from_dict(valid(), order=["flexure", "link", "flexure", "link"])


def test_defaults_follow_file_order(tmp_path: Path):
    p = tmp_path / "defaults.toml"
    p.write_text("""
[[flexure]]
name = "a"
length = 0.01
EI = 1e-5

[[link]]
name = "L"
points = { p = [0.01, 0.0] }

[[flexure]]
name = "b"
length = 0.02
EI = 2e-5

[[flexure]]
name = "c"
length = 0.03
EI = 3e-5

[[link]]
name = "M"

[[load]]
point = "c.tip"
force = [1.0, 0.0]

[[load]]
point = "L.p"
force = [0.0, 1.0]

[[load]]
point = "c.tip"
force = [0.0, 2.0]
moment = 0.5
""")
    s = load_scene(p)
    assert s.name == "defaults"  # file stem when no name is given
    assert s.model == ModelSpec()
    assert [(f.name, f.parent) for f in s.flexures] == [("a", "base"), ("b", "L"), ("c", "b")]
    assert [(lk.name, lk.parent) for lk in s.links] == [("L", "a"), ("M", "c")]
    assert s.flexures[1].at == (0.0, 0.0, 0.0)
    assert dict(s.links[1].points) == {}
    assert s.loads[0].moment == 0.0 and s.loads[2].moment == 0.5
    assert s.outputs == ("c.tip", "L.p")  # loaded points, load order, deduplicated
    assert dict(s.base_points) == {}
    assert s.tendons == ()


def test_scene_from_dict_order_argument():
    d = {
        "flexure": [
            {"name": "a", "length": 1.0, "EI": 1.0},
            {"name": "b", "length": 1.0, "EI": 1.0},
        ],
        "link": [{"name": "L"}],
    }
    s = scene_from_dict(d, order=["flexure", "link", "flexure"])
    assert [f.parent for f in s.flexures] == ["base", "L"]
    assert s.links[0].parent == "a"
    s2 = scene_from_dict(d, order=["flexure", "flexure", "link"])
    assert [f.parent for f in s2.flexures] == ["base", "a"]
    assert s2.links[0].parent == "b"
    with pytest.raises(SceneError, match=r"flexure\[1\]\.parent"):
        scene_from_dict(d)  # interleaving unknown
    with pytest.raises(SceneError, match=r"^order:"):
        scene_from_dict(d, order=["flexure", "link"])


def test_flexures_only_dict_needs_no_order():
    d = {"flexure": [{"name": n, "length": 1.0, "EI": 1.0} for n in "abc"]}
    s = scene_from_dict(d)
    assert [f.parent for f in s.flexures] == ["base", "a", "b"]
    assert s.name == "scene"
    assert s.outputs == ()


def test_first_link_without_flexure_before_it():
    d = {"flexure": [{"name": "a", "length": 1.0, "EI": 1.0}], "link": [{"name": "L"}]}
    with pytest.raises(SceneError, match=r"link\[0\]\.parent: missing"):
        scene_from_dict(d, order=["link", "flexure"])


def test_E_width_thickness_gives_EI():
    d = valid()
    f = d["flexure"][0]
    del f["EI"]
    f.update(E=2.0e9, width=0.01, thickness=0.0005)
    s = scene_from_dict(d)
    assert s.flexures[0].EI == pytest.approx(2.0e9 * 0.01 * 0.0005**3 / 12)
    assert s.flexures[0].EI == pytest.approx(2.0833333e-4, rel=1e-6)


def test_E_and_I_gives_EI():
    d = valid()
    f = d["flexure"][1]
    del f["EI"]
    f.update(E=1.5e9, I=4e-14)
    assert scene_from_dict(d).flexures[1].EI == pytest.approx(6e-5)


def test_per_flexure_overrides_direct_and_subtable():
    d = valid()
    d["model"] = {"kind": "scm", "modes": 4, "kernel": "poly", "elements": 12}
    d["flexure"][0].update(kind="fem", elements=8, kernel="gauss")
    d["flexure"][1]["model"] = {"modes": 6}
    s = scene_from_dict(d)
    assert s.model == ModelSpec(kind="scm", modes=4, elements=12, kernel="poly")
    # [model] counts are defaults: each flexure reads the one its kind uses
    assert s.flexures[0].model == ModelSpec(kind="fem", modes=4, elements=8, kernel="gauss")
    assert s.flexures[1].model == ModelSpec(kind="scm", modes=6, elements=12, kernel="poly")
    del d["model"]["modes"], d["flexure"][1]["model"]
    d["flexure"][0] = {k: v for k, v in d["flexure"][0].items() if k not in ("kind", "elements")}
    d["model"]["tolerance"] = 1e-3
    d["flexure"][1]["model"] = {"tolerance": 1e-6}
    s = scene_from_dict(d)
    assert [f.model.tolerance for f in s.flexures] == [1e-3, 1e-6]


def test_a_model_count_is_a_default_of_the_kinds_that_read_it():
    """[model] modes and elements are defaults: a flexure whose kind does not read them is not
    an error (a study may vary model.kind of a scene that gives modes), one that gives its own
    is (as --model cc --modes 3)."""
    d = valid()
    d["model"] = {"kind": "cc", "modes": 5, "elements": 4}
    assert {f.model.kind for f in scene_from_dict(d).flexures} == {"cc"}
    d["flexure"][1]["kind"] = "scm"
    assert scene_from_dict(d).flexures[1].model.modes == 5
    d["flexure"][1]["modes"] = 2
    d["flexure"][0]["model"] = {"kind": "fem", "elements": 7}
    s = scene_from_dict(d)
    assert (s.flexures[0].model.elements, s.flexures[1].model.modes) == (7, 2)
    s = load_scene(EXAMPLES / "two_link_finger.toml")
    assert s.with_value("model.kind", "fem").flexures[0].model.kind == "fem"


@pytest.mark.parametrize("kind", MODEL_KINDS)
@pytest.mark.parametrize("kernel", KERNELS)
def test_every_kind_and_kernel_accepted(kind, kernel):
    d = valid()
    d["model"] = {"kind": kind, "kernel": kernel}
    s = scene_from_dict(d)
    assert (s.flexures[0].model.kind, s.flexures[0].model.kernel) == (kind, kernel)


def test_zero_tension_is_allowed():
    d = valid()
    d["tendon"][0]["tension"] = 0
    assert scene_from_dict(d).tendons[0].tension == 0.0


def test_integers_accepted_as_numbers():
    d = valid()
    d["flexure"][0]["at"] = [0, 1, 0]
    d["load"][0]["force"] = [0, -2]
    s = scene_from_dict(d)
    assert s.flexures[0].at == (0.0, 1.0, 0.0)
    assert s.loads[0].force == (0.0, -2.0)


def test_output_defaults_to_loaded_points_and_dedups_explicit():
    d = valid()
    del d["output"]
    d["load"].append({"point": "middle.pad", "force": [1.0, 0.0]})
    d["load"].append({"point": "fingertip.pad", "force": [1.0, 0.0]})
    assert scene_from_dict(d).outputs == ("fingertip.pad", "middle.pad")
    d["output"] = {"points": ["proximal.tip", "middle.pad", "proximal.tip"]}
    assert scene_from_dict(d).outputs == ("proximal.tip", "middle.pad")
    d["output"] = {"points": []}  # no point at all: refused, not silently the default
    with pytest.raises(SceneError, match=r"^output\.points: must name at least one point"):
        scene_from_dict(d)


def test_output_points_without_loads_are_the_free_tips():
    """No [output] and no load: every flexure tip that carries no other flexure (directly or
    through a link), the same points for the chain models and the exact solver."""
    d = {
        "flexure": [
            {"name": "a", "length": 1.0, "EI": 1.0},
            {"name": "b", "length": 1.0, "EI": 1.0, "parent": "l"},
            {"name": "c", "length": 1.0, "EI": 1.0, "parent": "base"},
            {"name": "d", "length": 1.0, "EI": 1.0, "parent": "c"},
        ],
        "link": [{"name": "l", "parent": "a"}],
    }
    s = scene_from_dict(d)
    assert s.outputs == ()
    assert s.output_points() == ("b.tip", "d.tip")
    d["load"] = [{"point": "a.tip", "force": [0.0, 1.0]}] * 2
    assert scene_from_dict(d).output_points() == ("a.tip",)


# -- Scene helpers ---------------------------------------------------------------------------


def hand():
    """Two fingers on the base; a flexure declared before its parent."""
    return scene_from_dict(
        {
            "base": {"points": {"o": [0.0, 0.0]}},
            "flexure": [
                {"name": "f2b", "parent": "L2", "length": 1.0, "EI": 1.0, "at": [0.5, 0.0, 0.0]},
                {"name": "f1", "parent": "base", "length": 1.0, "EI": 1.0, "at": [0.0, 1.0, 0.0]},
                {"name": "f2", "parent": "base", "length": 1.0, "EI": 1.0, "at": [0.0, -1.0, 0.0]},
                {"name": "f1b", "parent": "f1", "length": 1.0, "EI": 1.0},
            ],
            "link": [
                {"name": "L2", "parent": "f2", "points": {"p": [0.1, 0.2]}},
                {"name": "L1", "parent": "f1"},
            ],
        }
    )


def test_flexure_order_parents_first():
    s = hand()
    order = [f.name for f in s.flexure_order()]
    assert order == ["f1", "f1b", "f2", "f2b"]
    pos = {n: i for i, n in enumerate(order)}
    for f in s.flexures:
        for anc in s.flexure_path(f.name)[:-1]:
            assert pos[anc] < pos[f.name]


def test_parent_children_and_paths():
    s = hand()
    assert s.body_parent("base") is None
    assert s.body_parent("f2b") == "L2"
    assert s.body_parent("L2") == "f2"
    assert s.children("base") == ("f1", "f2")
    assert s.children("f1") == ("f1b", "L1")  # declaration order: flexures, then links
    assert s.children("L2") == ("f2b",)
    assert s.children("f1b") == ()
    assert s.flexure_path("f2b") == ("f2", "f2b")
    assert s.flexure_path("L2") == ("f2",)
    assert s.flexure_path("base") == ()
    assert s.body_kind("L1") == "link" and s.body_kind("f1") == "flexure"
    assert s.bodies()[0] == "base"
    assert s.flexure("f1").at == (0.0, 1.0, 0.0)
    assert s.link("L2").parent == "f2"
    with pytest.raises(SceneError, match="unknown body 'nope'"):
        s.body_parent("nope")
    with pytest.raises(SceneError):
        s.children("nope")


def test_children_in_file_declaration_order(tmp_path: Path):
    s = load_scene(
        _write(
            tmp_path,
            CONTRACT_TOML.replace(
                "[[tendon]]",
                '[[flexure]]\nname = "side"\nparent = "proximal"\nlength = 0.01\n'
                "EI = 1e-5\n\n[[tendon]]",
            ),
        )
    )
    assert s.children("proximal") == ("middle", "side")
    assert [f.name for f in s.flexure_order()] == ["proximal", "distal", "side"]


def test_resolve_point():
    s = scene_from_dict(valid())
    assert s.resolve_point("fingertip.anchor") == ("fingertip", (0.025, 0.003))
    assert s.resolve_point("base.r0") == ("base", (0.0, 0.004))
    assert s.resolve_point("distal.tip") == ("distal", (0.0, 0.0))
    for bad in ("fingertip.pd", "nobody.pad", "fingertip", "distal.root"):
        with pytest.raises(SceneError) as e:
            s.resolve_point(bad)
        assert "\n" not in str(e.value)


def test_scene_module_does_not_import_sympy():
    tree = ast.parse(Path(scene_mod.__file__).read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add((node.module or "").split(".")[0])
    assert "sympy" not in imported
    assert "numpy" not in imported


# -- files -----------------------------------------------------------------------------------


def _write(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_broken_toml(tmp_path: Path):
    p = _write(tmp_path, 'name = "x"\n[[flexure]\nlength = 1\n', "broken.toml")
    with pytest.raises(SceneError) as e:
        load_scene(p)
    msg = str(e.value)
    assert "\n" not in msg
    assert "broken.toml" in msg and "invalid TOML" in msg and "line 2" in msg


def test_missing_file(tmp_path: Path):
    with pytest.raises(SceneError) as e:
        load_scene(tmp_path / "nope.toml")
    assert "nope.toml" in str(e.value) and "\n" not in str(e.value)


def test_validation_error_from_file_names_key(tmp_path: Path):
    p = _write(tmp_path, CONTRACT_TOML.replace("length = 0.015", "lenght = 0.015"))
    with pytest.raises(SceneError, match=r"^flexure\[1\]\.lenght: unknown key"):
        load_scene(p)


def test_nan_from_toml(tmp_path: Path):
    p = _write(tmp_path, CONTRACT_TOML.replace("EI = 2.5e-5\nparent", "EI = nan\nparent"))
    with pytest.raises(SceneError, match=r"^flexure\[0\]\.EI: .*got nan$"):
        load_scene(p)


# -- invalid scenes: one case per rule -------------------------------------------------------


def _set(path, value):
    """Mutator setting d[path...] = value (list indices allowed)."""

    def f(d):
        obj = d
        for k in path[:-1]:
            obj = obj[k]
        obj[path[-1]] = value

    return f


def _del(path):
    def f(d):
        obj = d
        for k in path[:-1]:
            obj = obj[k]
        del obj[path[-1]]

    return f


def _all(*fs):
    def f(d):
        for g in fs:
            g(d)

    return f


NAN, INF = float("nan"), float("inf")
F0, F1, L0, L1 = ("flexure", 0), ("flexure", 1), ("link", 0), ("link", 1)

BAD = [
    # id, mutation, substrings the one-line message must contain
    ("length-negative", _set((*F1, "length"), -0.02), ["flexure[1].length:", "-0.02"]),
    ("length-zero", _set((*F0, "length"), 0.0), ["flexure[0].length:", "got 0.0"]),
    ("EI-negative", _set((*F0, "EI"), -1e-5), ["flexure[0].EI:", "-1e-05"]),
    ("EI-zero", _set((*F1, "EI"), 0), ["flexure[1].EI:", "got 0"]),
    (
        "E-negative",
        _all(_del((*F0, "EI")), _set((*F0, "E"), -2e9), _set((*F0, "I"), 1e-14)),
        ["flexure[0].E:", "-2000000000.0"],
    ),
    (
        "I-zero",
        _all(_del((*F0, "EI")), _set((*F0, "E"), 2e9), _set((*F0, "I"), 0.0)),
        ["flexure[0].I:", "got 0.0"],
    ),
    (
        "width-negative",
        _all(
            _del((*F0, "EI")),
            _set((*F0, "E"), 2e9),
            _set((*F0, "width"), -0.01),
            _set((*F0, "thickness"), 1e-3),
        ),
        ["flexure[0].width:", "-0.01"],
    ),
    (
        "thickness-zero",
        _all(
            _del((*F0, "EI")),
            _set((*F0, "E"), 2e9),
            _set((*F0, "width"), 0.01),
            _set((*F0, "thickness"), 0),
        ),
        ["flexure[0].thickness:", "got 0"],
    ),
    (
        "EI-overflow",
        _all(_del((*F0, "EI")), _set((*F0, "E"), 1e60), _set((*F0, "I"), 1e60)),
        ["flexure[0].EI:", "e+119"],
    ),
    # missing required keys
    ("missing-length", _del((*F0, "length")), ["flexure[0].length:", "missing"]),
    ("missing-stiffness", _del((*F1, "EI")), ["flexure[1].EI:", "missing"]),
    ("E-without-I", _all(_del((*F0, "EI")), _set((*F0, "E"), 2e9)), ["flexure[0].I:", "missing"]),
    (
        "E-width-no-thickness",
        _all(_del((*F0, "EI")), _set((*F0, "E"), 2e9), _set((*F0, "width"), 0.01)),
        ["flexure[0].thickness:", "missing"],
    ),
    ("EI-and-E", _set((*F0, "E"), 2e9), ["flexure[0].E:", "conflicts with EI", "2000000000.0"]),
    (
        "I-and-width",
        _all(
            _del((*F0, "EI")),
            _set((*F0, "E"), 2e9),
            _set((*F0, "I"), 1e-14),
            _set((*F0, "width"), 0.01),
        ),
        ["flexure[0].width:", "conflicts with I"],
    ),
    ("missing-flexure-name", _del((*F0, "name")), ["flexure[0].name:", "missing"]),
    ("missing-link-name", _del((*L1, "name")), ["link[1].name:", "missing"]),
    ("missing-load-point", _del(("load", 0, "point")), ["load[0].point:", "missing"]),
    ("missing-load-force", _del(("load", 0, "force")), ["load[0].force:", "missing"]),
    ("missing-tension", _del(("tendon", 0, "tension")), ["tendon[0].tension:", "missing"]),
    ("missing-route", _del(("tendon", 0, "route")), ["tendon[0].route:", "missing"]),
    # wrong types
    ("length-string", _set((*F0, "length"), "0.02"), ["flexure[0].length:", "'0.02'"]),
    ("EI-bool", _set((*F0, "EI"), True), ["flexure[0].EI:", "True"]),
    ("moment-string", _set(("load", 0, "moment"), "1"), ["load[0].moment:", "'1'"]),
    ("force-element-string", _set(("load", 0, "force"), ["a", 1.0]), ["load[0].force[0]:", "'a'"]),
    ("at-string", _set((*F0, "at"), "origin"), ["flexure[0].at:", "'origin'"]),
    ("name-number", _set((*F0, "name"), 5), ["flexure[0].name:", "got 5"]),
    ("name-with-dot", _set((*L0, "name"), "mid.dle"), ["link[0].name:", "'mid.dle'"]),
    (
        "point-name-with-dot",
        _set(("base", "points"), {"r.0": [0.0, 0.0]}),
        ["base.points:", "'r.0'"],
    ),
    ("parent-number", _set((*F1, "parent"), 3), ["flexure[1].parent:", "got 3"]),
    ("scene-name-number", _set(("name",), 1), ["name:", "got 1"]),
    ("model-not-table", _set(("model",), "scm"), ["model:", "'scm'"]),
    ("flexure-not-array", _set(("flexure",), {"name": "a"}), ["flexure:", "array of tables"]),
    ("route-not-list", _set(("tendon", 0, "route"), "base.r0"), ["tendon[0].route:", "'base.r0'"]),
    ("route-element-number", _set(("tendon", 0, "route", 1), 7), ["tendon[0].route[1]:", "7"]),
    (
        "output-points-string",
        _set(("output", "points"), "middle.pad"),
        ["output.points:", "'middle.pad'"],
    ),
    ("tension-bool", _set(("tendon", 0, "tension"), False), ["tendon[0].tension:", "False"]),
    # NaN / inf
    ("length-nan", _set((*F0, "length"), NAN), ["flexure[0].length:", "nan"]),
    ("EI-inf", _set((*F1, "EI"), INF), ["flexure[1].EI:", "inf"]),
    ("at-nan", _set((*F1, "at"), [0.045, 0.0, NAN]), ["flexure[1].at[2]:", "nan"]),
    ("force-inf", _set(("load", 0, "force"), [0.0, -INF]), ["load[0].force[1]:", "-inf"]),
    ("moment-nan", _set(("load", 0, "moment"), NAN), ["load[0].moment:", "nan"]),
    ("tension-inf", _set(("tendon", 0, "tension"), INF), ["tendon[0].tension:", "inf"]),
    ("base-point-nan", _set(("base", "points", "r0"), [NAN, 0.0]), ["base.points.r0[0]:", "nan"]),
    (
        "link-point-inf",
        _set((*L0, "points", "pad"), [0.02, INF]),
        ["link[0].points.pad[1]:", "inf"],
    ),
    ("tolerance-nan", _set(("model", "tolerance"), NAN), ["model.tolerance:", "nan"]),
    (
        "E-inf",
        _all(_del((*F0, "EI")), _set((*F0, "E"), INF), _set((*F0, "I"), 1e-14)),
        ["flexure[0].E:", "inf"],
    ),
    # unknown parent / point / body
    (
        "unknown-flexure-parent",
        _set((*F1, "parent"), "midle"),
        ["flexure[1].parent:", "'midle'", "middle"],
    ),
    ("unknown-link-parent", _set((*L0, "parent"), "proximl"), ["link[0].parent:", "'proximl'"]),
    (
        "unknown-load-point",
        _set(("load", 0, "point"), "fingertip.pd"),
        ["load[0].point:", "'fingertip.pd'", "fingertip.pad"],
    ),
    (
        "unknown-load-body",
        _set(("load", 0, "point"), "fingertp.pad"),
        ["load[0].point:", "'fingertp'"],
    ),
    (
        "flexure-point-not-tip",
        _set(("load", 0, "point"), "distal.root"),
        ["load[0].point:", "'distal.root'", "distal.tip"],
    ),
    ("ref-without-dot", _set(("load", 0, "point"), "fingertip"), ["load[0].point:", "'fingertip'"]),
    (
        "route-unknown-point",
        _set(("tendon", 0, "route", 1), "middle.hol"),
        ["tendon[0].route[1]:", "'middle.hol'"],
    ),
    (
        "route-repeated-point",
        _set(("tendon", 0, "route", 1), "base.r0"),
        ["tendon[0].route[1]:", "'base.r0'"],
    ),
    (
        "output-unknown-point",
        _set(("output", "points", 1), "fingertip.nail"),
        ["output.points[1]:", "'fingertip.nail'"],
    ),
    # duplicate names
    ("duplicate-flexures", _set((*F1, "name"), "proximal"), ["flexure[1].name:", "'proximal'"]),
    ("duplicate-flexure-link", _set((*L0, "name"), "distal"), ["link[0].name:", "'distal'"]),
    ("link-named-base", _set((*L1, "name"), "base"), ["link[1].name:", "'base'"]),
    ("flexure-named-base", _set((*F0, "name"), "base"), ["flexure[0].name:", "'base'"]),
    # cycles
    (
        "cycle-through-link",
        _set((*F0, "parent"), "distal"),
        ["flexure[0].parent:", "cycle", "'distal'"],
    ),
    ("self-parent", _set((*F1, "parent"), "distal"), ["flexure[1].parent:", "cycle", "'distal'"]),
    # empty scene
    ("no-flexure-key", _del(("flexure",)), ["flexure:", "at least one"]),
    (
        "empty-flexure-list",
        _all(
            _set(("flexure",), []),
            _set(("link",), []),
            _set(("load",), []),
            _set(("tendon",), []),
            _del(("output",)),
        ),
        ["flexure:", "at least one"],
    ),
    # tendons
    (
        "route-one-point",
        _set(("tendon", 0, "route"), ["base.r0"]),
        ["tendon[0].route:", "two", "['base.r0']"],
    ),
    ("route-empty", _set(("tendon", 0, "route"), []), ["tendon[0].route:", "got []"]),
    ("tension-negative", _set(("tendon", 0, "tension"), -1.0), ["tendon[0].tension:", "-1.0"]),
    # model keys
    ("modes-zero", _set(("model", "modes"), 0), ["model.modes:", "got 0"]),
    ("modes-negative", _set(("model", "modes"), -2), ["model.modes:", "-2"]),
    ("modes-float", _set(("model", "modes"), 2.5), ["model.modes:", "2.5"]),
    ("modes-float-integral", _set(("model", "modes"), 3.0), ["model.modes:", "3.0"]),
    ("modes-bool", _set(("model", "modes"), True), ["model.modes:", "True"]),
    ("modes-string", _set(("model", "modes"), "3"), ["model.modes:", "'3'"]),
    ("flexure-modes-zero", _set((*F0, "modes"), 0), ["flexure[0].modes:", "got 0"]),
    (
        "flexure-model-modes-zero",
        _set((*F1, "model"), {"modes": 0}),
        ["flexure[1].model.modes:", "got 0"],
    ),
    ("elements-zero", _set(("model", "elements"), 0), ["model.elements:", "got 0"]),
    ("flexure-elements-float", _set((*F0, "elements"), 4.5), ["flexure[0].elements:", "4.5"]),
    ("kind-unknown", _set(("model", "kind"), "beam"), ["model.kind:", "'beam'"]),
    ("flexure-kind-unknown", _set((*F1, "kind"), "SCM"), ["flexure[1].kind:", "'SCM'"]),
    ("kernel-unknown", _set(("model", "kernel"), "fast"), ["model.kernel:", "'fast'"]),
    (
        "flexure-model-kernel-unknown",
        _set((*F0, "model"), {"kernel": "taylor"}),
        ["flexure[0].model.kernel:", "'taylor'"],
    ),
    ("tolerance-zero", _set(("model", "tolerance"), 0.0), ["model.tolerance:", "got 0.0"]),
    ("tolerance-negative", _set((*F0, "tolerance"), -1e-4), ["flexure[0].tolerance:", "-0.0001"]),
    # a count the flexure's kind does not read (as --model cc --modes 3), a tolerance with modes
    (
        "cc-flexure-modes",
        _all(_set((*F0, "kind"), "cc"), _set((*F0, "modes"), 3)),
        ["flexure[0].modes:", "'cc'", "flexure[0].kind", "one mode", "got 3"],
    ),
    (
        "fem-subtable-modes",
        _set((*F1, "model"), {"kind": "fem", "modes": 4}),
        ["flexure[1].model.modes:", "'fem'", "flexure[1].model.kind", "got 4"],
    ),
    (
        "prb-from-model-modes",
        _all(_set(("model", "kind"), "prb"), _set((*F0, "modes"), 2)),
        ["flexure[0].modes:", "'prb'", "model.kind", "only scm has modes", "got 2"],
    ),
    (
        "scm-flexure-elements",
        _set((*F1, "elements"), 8),
        ["flexure[1].elements:", "'scm'", "only fem has elements", "got 8"],
    ),
    (
        "exact-flexure-elements",
        _set((*F0, "model"), {"kind": "exact", "elements": 8}),
        ["flexure[0].model.elements:", "'exact'", "got 8"],
    ),
    (
        "model-modes-with-tolerance",
        _set(("model", "tolerance"), 1e-2),
        ["model.modes:", "(model.tolerance)", "not both", "got 3"],
    ),
    (
        "flexure-modes-with-flexure-tolerance",
        _all(_del(("model", "modes")), _set((*F0, "modes"), 5), _set((*F1, "tolerance"), 1e-3)),
        ["flexure[0].modes:", "(flexure[1].tolerance)", "not both", "got 5"],
    ),
    ("output-points-empty", _set(("output", "points"), []), ["output.points:", "got []"]),
    (
        "override-given-twice",
        _all(_set((*F0, "modes"), 4), _set((*F0, "model"), {"modes": 5})),
        ["flexure[0].model.modes:", "got 5"],
    ),
    # unknown keys
    (
        "typo-flexure-key",
        _all(_del((*F1, "length")), _set((*F1, "lenght"), 0.015)),
        ["flexure[1].lenght:", "unknown key", "'length'"],
    ),
    ("unknown-top-level", _set(("flexures",), []), ["flexures:", "unknown"]),
    ("unknown-model-key", _set(("model", "mode"), 3), ["model.mode:", "unknown"]),
    (
        "unknown-flexure-model-key",
        _set((*F0, "model"), {"elemnts": 3}),
        ["flexure[0].model.elemnts:", "unknown"],
    ),
    ("unknown-base-key", _set(("base", "point"), {}), ["base.point:", "unknown"]),
    ("unknown-link-key", _set((*L0, "at"), [0.0, 0.0, 0.0]), ["link[0].at:", "unknown"]),
    ("unknown-load-key", _set(("load", 0, "torque"), 1.0), ["load[0].torque:", "unknown"]),
    ("unknown-tendon-key", _set(("tendon", 0, "force"), 1.0), ["tendon[0].force:", "unknown"]),
    ("unknown-output-key", _set(("output", "point"), []), ["output.point:", "unknown"]),
    (
        "flexure-declares-points",
        _set((*F0, "points"), {"p": [0.0, 0.0]}),
        ["flexure[0].points:", "tip"],
    ),
    # link parent must be a flexure
    ("link-parent-base", _set((*L0, "parent"), "base"), ["link[0].parent:", "'base'", "flexure"]),
    (
        "link-parent-link",
        _set((*L1, "parent"), "middle"),
        ["link[1].parent:", "'middle'", "flexure"],
    ),
    # vector lengths
    ("at-two-numbers", _set((*F1, "at"), [0.045, 0.0]), ["flexure[1].at:", "3", "[0.045, 0.0]"]),
    ("at-four-numbers", _set((*F0, "at"), [0, 0, 0, 0]), ["flexure[0].at:", "[0, 0, 0, 0]"]),
    (
        "force-three-numbers",
        _set(("load", 0, "force"), [0.0, -1.0, 0.0]),
        ["load[0].force:", "2", "[0.0, -1.0, 0.0]"],
    ),
    ("force-scalar", _set(("load", 0, "force"), -1.0), ["load[0].force:", "-1.0"]),
    ("base-point-one-number", _set(("base", "points", "r0"), [0.0]), ["base.points.r0:", "[0.0]"]),
    (
        "link-point-three-numbers",
        _set((*L1, "points", "pad"), [0.0, 0.0, 0.0]),
        ["link[1].points.pad:", "[0.0, 0.0, 0.0]"],
    ),
]


@pytest.mark.parametrize("mutate, expected", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_invalid_scene(mutate, expected):
    d = valid()
    mutate(d)
    with pytest.raises(SceneError) as e:
        scene_from_dict(d)
    msg = str(e.value)
    assert "\n" not in msg and msg.strip() == msg
    for s in expected:
        assert s in msg, f"{s!r} not in {msg!r}"
    assert msg.startswith(expected[0]), msg  # the message starts with the key path


def test_all_bad_case_ids_unique():
    ids = [b[0] for b in BAD]
    assert len(ids) == len(set(ids))


def test_nan_is_reported_not_compared():
    # a NaN must never slip through a "<= 0" comparison
    d = valid()
    d["flexure"][0]["length"] = NAN
    assert math.isnan(NAN)
    with pytest.raises(SceneError):
        scene_from_dict(d)


def test_a_line_of_many_numbers_is_no_dotted_key(tmp_path):
    # review of the change: the dotted-key guard counted every dot of a line, so a link with 300
    # points on its one inline-table line (inside the limits) was refused
    points = ", ".join(f"p{i} = [0.{i:03d}, 0.5]" for i in range(300))
    path = tmp_path / "many.toml"
    path.write_text(
        '[[flexure]]\nname = "f"\nlength = 1.0\nEI = 1.0\n'
        f'[[link]]\nname = "L"\nparent = "f"\npoints = {{ {points} }}\n'
    )
    assert len(load_scene(path).link("L").points) == 300
    path.write_text("x" + ".x" * 600 + " = 1\n")
    with pytest.raises(SceneError, match="dotted key or table header of more than 512"):
        load_scene(path)


def test_too_many_named_points_names_the_key_holding_them():
    """Review: 1001 base points were blamed on 'link'."""
    from flexgen.scene import MAX_ENTRIES

    n = MAX_ENTRIES + 1
    base = {"points": {f"p{i}": [0.0, float(i)] for i in range(n)}}
    flexure = {"name": "b", "length": 1.0, "EI": 1.0}
    with pytest.raises(SceneError, match=r"^base\.points: too many named points: 1001"):
        scene_from_dict({"base": base, "flexure": [flexure]})
    link = {"name": "L", "parent": "b", "points": base["points"]}
    with pytest.raises(SceneError, match=r"^link\[0\]\.points: too many named points: 1001"):
        scene_from_dict({"flexure": [flexure], "link": [link]})


def test_api_arguments_of_the_wrong_kind_are_type_errors_naming_them():
    """Review: with_values(None) was an AttributeError, scene_from_dict(order=5) "'int' object
    is not iterable"."""
    flexure = {"name": "b", "length": 1.0, "EI": 1.0}
    scene = scene_from_dict({"flexure": [flexure]})
    for bad in (None, [1]):
        with pytest.raises(TypeError, match="^with_values: expected a mapping"):
            scene.with_values(bad)
    for order in (5, "flexure", ["flexure", "body"]):
        with pytest.raises(TypeError, match="^scene_from_dict: order must be a sequence"):
            scene_from_dict({"flexure": [flexure]}, order=order)


def test_a_scene_pickles_and_deep_copies_read_only():
    """Review: a Scene held read-only mappings (MappingProxyType), which do not pickle: no scene
    could go to a worker process (multiprocessing, concurrent.futures) nor be deep-copied."""
    import pickle
    from types import MappingProxyType

    import flexgen

    examples = Path(__file__).resolve().parents[1] / "examples"
    with_units = scene_from_dict(
        {
            "units": {"length": "mm"},
            "flexure": [{"name": "beam", "length": "20 mm", "EI": 0.4}],
            "load": [{"point": "beam.tip", "force": [0.0, -0.2]}],
        }
    )
    for scene in (load_scene(examples / "two_link_finger.toml"), with_units):
        for again in (pickle.loads(pickle.dumps(scene)), copy.deepcopy(scene)):
            assert again == scene and again.units == scene.units
            assert again.source == scene.source
            assert isinstance(again.base_points, MappingProxyType)
            assert all(isinstance(lk.points, MappingProxyType) for lk in again.links)
            with pytest.raises(TypeError):
                again.source["name"] = "changed"  # type: ignore[index]
            assert flexgen.solve(again).to_json() == flexgen.solve(scene).to_json()
            assert again.with_value("load.0.force.1", -0.1) == scene.with_value(
                "load.0.force.1", -0.1
            )


def test_numpy_numbers_in_a_scene_dict_are_numbers():
    """Review: a scene dict built by a script with np.int64 or np.float32 values was refused
    ("must be a finite number ..., got np.int64(0)"); NumPy's bool stays no number."""
    np = pytest.importorskip("numpy")
    scene = scene_from_dict(
        {
            "flexure": [
                {"name": "beam", "length": np.float32(0.5), "EI": np.int64(2), "modes": np.int64(4)}
            ],
            "load": [{"point": "beam.tip", "force": [np.int64(0), np.float64(-1.0)]}],
        }
    )
    assert (scene.flexures[0].length, scene.flexures[0].EI, scene.flexures[0].model.modes) == (
        0.5,
        2.0,
        4,
    )
    assert type(scene.flexures[0].model.modes) is int and scene.loads[0].force == (0.0, -1.0)
    with pytest.raises(SceneError, match="got np.True_"):
        scene_from_dict({"flexure": [{"name": "beam", "length": np.bool_(True), "EI": 1.0}]})
