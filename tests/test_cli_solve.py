"""`flexgen solve` and `flexgen plot` from the command line: the JSON contract, the table, the
overrides, plots, every class of bad input (exit 2, one line naming the key), no equilibrium
(exit 1), the scm kernel switch (auto: a warning; poly: no equilibrium); the --backend option
of the deleted Python solver is gone (a usage error)."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

import flexgen
from flexgen.cli import main

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "examples"
CONTRACT = {
    "scene",
    "converged",
    "stable",
    "iterations",
    "model",
    "q",
    "points",
    "flexures",  # issue 11: per flexure max curvature, strain, stress, safety factor
    "stiffness",  # issue 11: the generalized stiffness (null for exact)
    "warnings",
    "notes",
}
CHAIN_CONTRACT = CONTRACT | {"error_estimate"}  # every chain-model answer (not exact)


def cli(*argv):
    """Run `python -m flexgen` in a subprocess: (exit code, stdout, stderr)."""
    p = subprocess.run(
        [sys.executable, "-m", "flexgen", *map(str, argv)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    return p.returncode, p.stdout, p.stderr


def run(capsys, *argv):
    """The same in-process (fast): an uncaught exception fails the test like a traceback would."""
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@pytest.fixture(scope="module")
def finger_json():
    code, out, err = cli("solve", EX / "two_link_finger.toml", "--json")
    assert code == 0, err
    return json.loads(out)


def test_json_has_exactly_the_contract_fields_and_types(finger_json):
    d = finger_json
    assert set(d) == CHAIN_CONTRACT
    assert d["scene"] == "two-link finger" and d["converged"] is True and d["stable"] is True
    assert isinstance(d["iterations"], int) and d["iterations"] > 0
    assert d["model"] == {
        "proximal": {"kind": "scm", "modes": 3},
        "distal": {"kind": "scm", "modes": 3},
    }
    assert set(d["q"]) == {"proximal", "distal"}
    assert all(len(v) == 3 and all(map(is_number, v)) for v in d["q"].values())
    assert set(d["points"]) == {"middle.pad", "fingertip.pad"}
    for p in d["points"].values():
        assert set(p) == {"pose", "compliance", "compliance3", "ellipse", "error_estimate"}
        assert [r[:2] for r in p["compliance3"][:2]] == p["compliance"]
        assert set(p["error_estimate"]) == {"pose", "compliance"}
        assert all(0 < v < 1e-3 for v in p["error_estimate"].values())
        assert max(p["error_estimate"].values()) <= d["error_estimate"]
        assert len(p["pose"]) == 3 and all(map(is_number, p["pose"]))
        C = p["compliance"]
        assert len(C) == 2 and all(len(r) == 2 and all(map(is_number, r)) for r in C)
        assert C[0][1] == pytest.approx(C[1][0], rel=1e-9)
        e = p["ellipse"]
        assert set(e) == {"major", "minor", "angle"} and all(map(is_number, e.values()))
        assert e["major"] >= e["minor"] and -math.pi / 2 < e["angle"] <= math.pi / 2
        tr, det = C[0][0] + C[1][1], C[0][0] * C[1][1] - C[0][1] ** 2
        assert e["major"] + e["minor"] == pytest.approx(tr, rel=1e-9)
        assert e["major"] * e["minor"] == pytest.approx(det, rel=1e-6, abs=1e-18)
    assert isinstance(d["warnings"], list) and all(isinstance(w, str) for w in d["warnings"])


def test_cli_json_matches_the_python_api(finger_json):
    res = flexgen.solve(EX / "two_link_finger.toml")
    assert json.loads(res.to_json()) == finger_json


def test_table_output(capsys):
    code, out, err = run(capsys, "solve", EX / "arc_moment.toml")
    assert code == 0 and err == ""
    assert "converged" in out and "beam.tip" in out and "major" in out
    assert " 0.2876 " in out and " 0.006883 " in out  # the 3-mode compliance eigenvalues


def test_a_newline_in_a_name_cannot_forge_a_table_line(tmp_path, capsys):
    """Found by review: a scene named "a\\nscene: forged" and a flexure named
    "b\\nconverged in 1 Newton iterations" printed those as lines of their own. The table has
    as many lines as with plain names, the newlines shown escaped."""
    lines = {}
    for label, (scene, flexure) in {
        "plain": ("a", "b"),
        "forged": ("a\\nscene: forged", "b\\nconverged in 1 Newton iterations"),
    }.items():
        path = tmp_path / f"{label}.toml"
        path.write_text(
            f'name = "{scene}"\n[[flexure]]\nname = "{flexure}"\nlength = 1.0\nEI = 1.0\n'
        )
        code, out, err = run(capsys, "solve", path)
        assert code == 0 and err == ""
        lines[label] = out.splitlines()
    assert len(lines["forged"]) == len(lines["plain"])
    assert lines["forged"][0] == "scene: a\\nscene: forged"
    assert not any(line.startswith("converged in 1 ") for line in lines["forged"])


@pytest.mark.parametrize(
    "argv, model, qlen",
    [
        (["--model", "fem", "--elements", "8"], {"kind": "fem", "elements": 8}, 8),
        (["--modes", "5"], {"kind": "scm", "modes": 5}, 5),
        (["--model", "cc"], {"kind": "scm", "modes": 1}, 1),
        (["--model", "prb"], {"kind": "prb"}, 1),
        (["--model", "exact"], {"kind": "exact"}, 3),  # q: root loads Fx, Fy, M0
    ],
)
def test_model_overrides_beat_the_scene(capsys, argv, model, qlen):
    code, out, err = run(capsys, "solve", EX / "cantilever_tip_load.toml", "--json", *argv)
    assert code == 0, err
    d = json.loads(out)
    assert set(d) == (CONTRACT if model["kind"] == "exact" else CHAIN_CONTRACT)
    assert d["model"] == {"beam": model} and len(d["q"]["beam"]) == qlen


def test_command_line_overrides_beat_per_flexure_keys(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[model]\nkind = "prb"\n[[flexure]]\nname = "a"\nlength = 1.0\nEI = 1.0\n'
        'kind = "fem"\nelements = 4\n[[load]]\npoint = "a.tip"\nforce = [0.0, -1.0]\n'
    )
    code, out, _ = run(capsys, "solve", scene, "--json", "--model", "scm", "--modes", "4")
    assert code == 0 and json.loads(out)["model"] == {"a": {"kind": "scm", "modes": 4}}


def test_help_explains_every_option(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["solve", "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0
    for opt in ("--json", "--model", "--modes", "--elements", "exact", "Exit codes"):
        assert opt in out


@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".svg", b"<svg")])
def test_plot_writes_png_and_svg(tmp_path, capsys, suffix, magic):
    path = tmp_path / f"finger{suffix}"
    code, out, err = run(capsys, "plot", EX / "two_link_finger.toml", "-o", path)
    assert code == 0, err
    data = path.read_bytes()
    assert len(data) > 5000 and magic in data[:400]


def test_plot_of_the_exact_solution(tmp_path, capsys):
    path = tmp_path / "arc.svg"
    code, _, err = run(capsys, "plot", EX / "arc_moment.toml", "--model", "exact", "-o", path)
    assert code == 0, err
    assert path.stat().st_size > 5000


# ---- bad input: exit 2, one line on stderr naming the key, nothing on stdout ------------------

GOOD = """name = "bad"
[base]
points = { r0 = [0.0, 0.1] }
[[flexure]]
name = "beam"
length = 1.0
EI = 1.0
[[load]]
point = "beam.tip"
force = [0.0, -1.0]
[[tendon]]
tension = 1.0
route = ["base.r0", "beam.tip"]
"""

BAD = {  # name: (replace this, with that, key the message must name)
    "negative length": ("length = 1.0", "length = -0.02", "flexure[0].length"),
    "zero length": ("length = 1.0", "length = 0.0", "flexure[0].length"),
    "zero EI": ("EI = 1.0", "EI = 0", "flexure[0].EI"),
    "negative EI": ("EI = 1.0", "EI = -2.5e-5", "flexure[0].EI"),
    "missing length": ("length = 1.0\n", "", "flexure[0].length"),
    "missing force": ("force = [0.0, -1.0]\n", "", "load[0].force"),
    "wrong type length": ("length = 1.0", 'length = "long"', "flexure[0].length"),
    "wrong type force": ("force = [0.0, -1.0]", "force = 3.0", "load[0].force"),
    "NaN length": ("length = 1.0", "length = nan", "flexure[0].length"),
    "inf EI": ("EI = 1.0", "EI = inf", "flexure[0].EI"),
    "NaN force": ("force = [0.0, -1.0]", "force = [nan, -1.0]", "load[0].force"),
    "unknown parent": ('name = "beam"', 'name = "beam"\nparent = "palm"', "flexure[0].parent"),
    "unknown point": ('point = "beam.tip"', 'point = "beam.pad"', "load[0].point"),
    "duplicate names": (
        "[[load]]",
        '[[flexure]]\nname = "beam"\nlength = 1.0\nEI = 1.0\n[[load]]',
        "flexure[1].name",
    ),
    "cycle": (
        'name = "beam"',
        'name = "beam"\nparent = "other"',
        "flexure[0].parent",
        '[[flexure]]\nname = "other"\nparent = "beam"\nlength = 1.0\nEI = 1.0\n',
    ),
    "tendon with one point": (
        'route = ["base.r0", "beam.tip"]',
        'route = ["base.r0"]',
        "tendon[0].route",
    ),
    "negative tension": ("tension = 1.0", "tension = -10.0", "tendon[0].tension"),
    "modes < 1": ('name = "bad"', 'name = "bad"\n[model]\nmodes = 0', "model.modes"),
    "unknown kind": ('name = "bad"', 'name = "bad"\n[model]\nkind = "magic"', "model.kind"),
    "unknown flexure kind": ("EI = 1.0", 'EI = 1.0\nkind = "spline"', "flexure[0].kind"),
    # a model the scene contradicts, as --model cc --modes 3 (it solved one mode silently)
    "modes on a cc flexure": ("EI = 1.0", 'EI = 1.0\nkind = "cc"\nmodes = 3', "flexure[0].modes"),
    "elements on an scm flexure": ("EI = 1.0", "EI = 1.0\nelements = 8", "flexure[0].elements"),
    "modes with a tolerance": (
        'name = "bad"',
        'name = "bad"\n[model]\nmodes = 5\ntolerance = 1e-2',
        "model.modes: a tolerance (model.tolerance)",
    ),
    "no output point": (
        "tension = 1.0",
        "tension = 1.0",
        "output.points",
        "[output]\npoints = []\n",
    ),
    "a unit value as written": (
        "length = 1.0",
        'length = "-20 mm"',
        "flexure[0].length: must be a positive number in [1e-100, 1e+100], got '-20 mm' (-0.02 m)",
    ),
}


@pytest.mark.parametrize(
    ("kind", "option", "why"),
    [("cc", "--modes", "cc is scm with one mode"), ("exact", "--modes", "its flexures are exact")],
)
def test_a_count_no_flexure_of_the_scene_reads_is_bad_input(tmp_path, capsys, kind, option, why):
    """--modes without --model on a scene of cc (or exact) flexures would be dropped silently,
    as --model cc --modes 3 would: exit 2, one line; the API's keyword likewise."""
    path = tmp_path / "s.toml"
    path.write_text(GOOD.replace('name = "bad"', f'name = "bad"\n[model]\nkind = "{kind}"', 1))
    code, out, err = run(capsys, "solve", str(path), option, "3")
    _one_line_error(code, out, err, f"{option}: not used by this scene")
    assert why in err
    with pytest.raises(flexgen.SceneError, match="modes: not used by this scene"):
        flexgen.solve(path, modes=3)


def _bad_scene(tmp_path, name) -> Path:
    old, new, _key, *extra = BAD[name]
    assert old in GOOD
    text = GOOD.replace(old, new, 1) + (extra[0] if extra else "")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


def _one_line_error(code, out, err, key, json_out=False):
    """Exit 2, one line on stderr naming ``key``; stdout empty, or with --json the contract's
    object for a scene that cannot be solved (not converged, nothing solved, the reason)."""
    assert code == 2
    if json_out:
        d = json.loads(out)
        assert d["converged"] is False and key in d["reason"] and d["points"] == {}
        assert set(d) == CHAIN_CONTRACT | {"reason"}
    else:
        assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert key in lines[0]
    assert "Traceback" not in err


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_scene_exits_2_with_one_line_naming_the_key(tmp_path, capsys, name):
    path = _bad_scene(tmp_path, name)
    for flag in ((), ("--json",)):
        code, out, err = run(capsys, "solve", path, *flag)
        _one_line_error(code, out, err, BAD[name][2], json_out=bool(flag))


@pytest.mark.parametrize(
    "text, key",
    [
        ("", "flexure"),  # empty scene
        ("name = \n[[flexure]]\n", "invalid TOML"),  # broken TOML
        ("[[flexure]\nname = 'a'\n", "invalid TOML"),
    ],
)
def test_empty_and_broken_toml(tmp_path, capsys, text, key):
    path = tmp_path / "s.toml"
    path.write_text(text)
    code, out, err = run(capsys, "solve", path, "--json")
    _one_line_error(code, out, err, key, json_out=True)


@pytest.mark.parametrize(
    "argv, key",
    [
        (["--modes", "0"], "--modes"),
        (["--modes", "three"], "--modes"),
        (["--elements", "-1"], "--elements"),
        (["--model", "magic"], "--model"),
        (["--modes", "40"], "--modes"),  # no kernel with that many modes: 1..8
    ],
)
def test_bad_command_line_overrides(capsys, argv, key):
    code, out, err = run(capsys, "solve", EX / "arc_moment.toml", "--json", *argv)
    _one_line_error(code, out, err, key, json_out=True)


def test_missing_scene_file_and_bad_plot_suffix(tmp_path, capsys):
    code, out, err = run(capsys, "solve", tmp_path / "nope.toml")
    _one_line_error(code, out, err, "nope.toml")
    code, out, err = run(capsys, "plot", EX / "arc_moment.toml", "-o", tmp_path / "arc.jpg")
    _one_line_error(code, out, err, "-o")
    assert not (tmp_path / "arc.jpg").exists()


def test_bad_input_in_a_subprocess_has_no_traceback(tmp_path):
    code, out, err = cli("solve", _bad_scene(tmp_path, "negative length"), "--json")
    _one_line_error(code, out, err, "flexure[0].length", json_out=True)
    code, out, err = cli("plot", EX / "arc_moment.toml", "-o", tmp_path / "x.gif")
    _one_line_error(code, out, err, "-o")


# ---- no equilibrium, and the scm kernel switch -----------------------------------------------


def _bent(kernel: str, moment: float = 2.5) -> dict:
    """A flexure under a tip moment of 2.5 EI/L: a 143-degree arc, past the polynomial range."""
    return {
        "name": "bent",
        "model": {"kind": "scm", "modes": 3, "kernel": kernel},
        "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "beam.tip", "force": [0.0, 0.0], "moment": moment}],
    }


def _arc(t: float) -> tuple:
    """The tip pose of a flexure bent into a circular arc of angle t (L = 1)."""
    return (
        pytest.approx(math.sin(t) / t, abs=1e-9),
        pytest.approx((1 - math.cos(t)) / t, abs=1e-9),
        pytest.approx(t),
    )


def test_auto_kernel_is_local_then_switches_to_gauss_with_a_note():
    """ "auto": the local kernel wherever it certifies its bound (the 143-degree arc: no note),
    the Gauss kernel where it does not (a 332-degree arc), with a note naming both."""
    res = flexgen.solve(_bent("auto"))
    assert res.converged and res.stable
    assert tuple(res.points["beam.tip"].pose) == _arc(2.5)
    assert res.kernel == {"beam": "local"} and res.notes == [] and res.warnings == []
    far = flexgen.solve(_bent("auto", 5.8))
    assert far.converged and tuple(far.points["beam.tip"].pose) == _arc(5.8)
    switch = [w for w in far.notes if "Gauss kernel" in w]
    assert len(switch) == 1 and "'beam'" in switch[0] and "local kernel scm3_local9" in switch[0]
    assert far.kernel == {"beam": "gauss past its certified range"}


def test_poly_kernel_out_of_range_is_no_equilibrium_naming_flexure_and_range():
    res = flexgen.solve(_bent("poly"))
    assert res.converged is False
    assert "'beam'" in res.reason and "90 deg" in res.reason and "poly" in res.reason


def test_no_equilibrium_exits_1_with_the_reason_in_json(tmp_path):
    path = tmp_path / "bent.toml"
    path.write_text(
        'name = "bent"\n[model]\nkind = "scm"\nkernel = "poly"\n'
        '[[flexure]]\nname = "beam"\nlength = 1.0\nEI = 1.0\n'
        '[[load]]\npoint = "beam.tip"\nforce = [0.0, 0.0]\nmoment = 2.5\n'
    )
    code, out, err = cli("solve", path, "--json")
    assert code == 1
    d = json.loads(out)
    assert set(d) == CHAIN_CONTRACT | {"reason"}
    assert d["error_estimate"] is None  # inf: no answer to estimate
    assert d["converged"] is False and "'beam'" in d["reason"] and "90 deg" in d["reason"]
    lines = err.splitlines()
    assert len(lines) == 1 and "no equilibrium" in lines[0] and "Traceback" not in err
    code, out, err = cli("solve", path)  # table: stdout says so, stderr one line
    assert code == 1 and "NOT converged" in out and len(err.splitlines()) == 1


# ---- --backend: gone with the Python solver ----------------------------------------------------


@pytest.mark.parametrize("value", ["c", "python", "fortran"])
def test_backend_option_is_gone(capsys, value):
    """One solver: --backend is an unknown option (exit 2, one line naming it), not silently
    ignored."""
    code, out, err = run(capsys, "solve", EX / "two_link_finger.toml", "--json", "--backend", value)
    _one_line_error(code, out, err, "--backend", json_out=True)
    assert json.loads(out)["scene"] == "two-link finger"  # the scene's name, as when solved


def test_the_json_of_a_bad_scene_carries_its_name(tmp_path, capsys):
    """Found by review: the exit-2 JSON named a bad scene by its file name, where the contract's
    "scene" is the scene's name (exit-1 JSON had it). A scene that says its name: that name;
    one that says none, or cannot be read: the file's stem, as a solved answer's default."""
    named = tmp_path / "named_bad.toml"
    named.write_text('name = "my finger"\n[[flexure]]\nname = "b"\nlength = -1.0\nEI = 1.0\n')
    nameless = tmp_path / "nameless.toml"
    nameless.write_text('[[flexure]]\nname = "b"\nlength = -1.0\nEI = 1.0\n')
    for path, name in (
        (named, "my finger"),
        (nameless, "nameless"),
        (tmp_path / "gone.toml", "gone"),
    ):
        code, out, err = run(capsys, "solve", path, "--json")
        assert code == 2 and len(err.splitlines()) == 1, err
        assert json.loads(out)["scene"] == name


def test_help_names_no_backend_and_no_cache(capsys):
    with pytest.raises(SystemExit):
        main(["solve", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    for words in ("--backend", "FLEXGEN_CACHE", ".cache/flexgen", "python"):
        assert words not in out
    for words in ("--model KIND", "--modes N", "--elements N", "--tol T", "--json"):
        assert words in out


def test_a_path_that_ends_at_a_limit_point_says_so(tmp_path):
    """The contract's example scene (scene-format.md), tendon at 10 N: 20 N on the proximal
    flexure is 320 EI/L^2, so the finger would roll up past a full turn; the load path ends at a
    limit point near load factor 0.13 (the exact elastica's continuation stalls there too) and
    no stable state within the kernels is found. Exit 1, and the reason says what happened."""
    from test_scene import CONTRACT_TOML

    scene = tmp_path / "contract.toml"
    scene.write_text(CONTRACT_TOML)
    p = subprocess.run(
        [sys.executable, "-m", "flexgen", "solve", str(scene)], capture_output=True, text=True
    )
    assert p.returncode == 1
    line = p.stderr.strip()
    assert "\n" not in line and "Traceback" not in line
    assert "limit point" in line and "no stable state to snap to" in line


def test_select_json_on_bad_input_prints_the_unsolvable_object(tmp_path, capsys):
    """`flexgen select --json` on an invalid scene: exit 2, one line on stderr, and on stdout the
    contract's object of a scene that cannot be solved (as `solve --json`)."""
    code, out, err = run(
        capsys, "select", _bad_scene(tmp_path, "negative length"), "--tol", "1e-3", "--json"
    )
    _one_line_error(code, out, err, "flexure[0].length", json_out=True)
    code, out, err = run(capsys, "select", _bad_scene(tmp_path, "negative length"), "--tol", "1e-3")
    _one_line_error(code, out, err, "flexure[0].length")


def test_a_failed_exact_solve_claims_no_partial_result(tmp_path, capsys):
    """kind = "exact" beyond its load cap: exit 1, empty q and points, and no warning that the
    answer is "at the last converged load factor" (none is given)."""
    scene = tmp_path / "exact.toml"
    scene.write_text(
        '[model]\nkind = "exact"\n[[flexure]]\nname = "f"\nlength = 1.0\nEI = 1.0\n'
        '[[load]]\npoint = "f.tip"\nforce = [0.0, 5000.0]\n'
    )
    code, out, err = run(capsys, "solve", scene, "--json")
    d = json.loads(out)
    assert code == 1 and len(err.splitlines()) == 1
    assert d["converged"] is False and d["q"] == {} and d["points"] == {}
    assert not any("load not fully applied" in w for w in d["warnings"])
    assert "beyond the exact solver's cap" in d["reason"]


def test_without_loads_or_output_the_free_tips_are_reported(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(
        '[[flexure]]\nname = "a"\nlength = 1.0\nEI = 1.0\n'
        '[[flexure]]\nname = "b"\nlength = 1.0\nEI = 1.0\n'
    )
    for model in ("scm", "exact"):
        code, out, _ = run(capsys, "solve", scene, "--json", "--model", model)
        assert code == 0 and list(json.loads(out)["points"]) == ["b.tip"]


def test_the_solve_tables_headers_line_up_with_their_units_and_numbers():
    """Review: with a point name shorter than "point" every header sat two characters right of
    its units row and numbers, and a compound unit's label ran into the next column."""
    import flexgen

    scenes = [
        {
            "flexure": [{"name": "f", "length": 1.0, "EI": 1.0}],
            "link": [{"name": "L", "parent": "f", "points": {"p": [0.5, 0.0]}}],
            "load": [{"point": "L.p", "force": [0, -1]}],
        },
        {
            "units": {"length": "mm", "force": "g*cm/s^2"},
            "flexure": [{"name": "f", "length": 20, "E": "200 GPa", "width": 1, "thickness": 0.1}],
            "load": [{"point": "f.tip", "force": [0, -1]}],
        },
    ]
    for scene in scenes:
        lines = flexgen.solve(scene).table().splitlines()
        for title in ("  point ", "  flexure "):
            i = next(k for k, line in enumerate(lines) if line.startswith(title))
            header, units, numbers = lines[i], lines[i + 1], lines[i + 2]

            def ends(line):  # where each right-aligned column ends
                return [m.end() for m in re.finditer(r"\S+(?: \S+)?(?=\s{2,}|\s\[|$)", line)]

            unit_ends = [m.end() for m in re.finditer(r"\[[^\]]*\]", units)]
            assert set(unit_ends) <= set(ends(header)), (header, units)
            number_ends = [m.end() for m in re.finditer(r"\S+", numbers)][1 : len(unit_ends) + 1]
            assert number_ends == unit_ends, (units, numbers)
