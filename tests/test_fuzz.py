"""The error contract under hostile input (issue 10, item 6).

A seeded generator makes a few thousand malformed or hostile scenes (wrong types, NaN and inf as
numbers and as strings, huge numbers and integers of hundreds of digits, deep nesting, unicode and
control characters, deep and large trees, unknown and missing keys, broken TOML, FIFOs, folders,
symbolic links, hostile command-line options and output paths) and runs them

- through the command line in process (``flexgen.cli.main``, stdout and stderr captured): no
  exception escapes, exit 0/1/2, stderr empty on success and exactly one printable
  ``flexgen: ...`` line otherwise (never "internal error"), stdout nothing on bad input, the JSON
  object alone with ``--json``, no raw control characters in text output, no NumPy/SciPy warning,
  no file half-written;
- through the command line in subprocesses for a sample (exit codes, stderr exactly one line);
- through the API (``scene_from_dict``, ``flexgen.solve`` with hostile options): only
  SceneError/ValueError/TypeError, with one-line messages.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import random
import subprocess
import sys
import time
import warnings
from pathlib import Path
from types import SimpleNamespace

import pytest

import flexgen
from flexgen import cli
from flexgen.scene import MAX_BODIES, Flexure, ModelSpec, Scene, SceneError, scene_from_dict

# FLEXGEN_FUZZ_SEED and FLEXGEN_FUZZ_SCALE run other or more scenes (e.g. SCALE=3: 7,800 runs)
SEED = int(os.environ.get("FLEXGEN_FUZZ_SEED", "20260610"))
SCALE = float(os.environ.get("FLEXGEN_FUZZ_SCALE", "1"))
N_CLI = int(1700 * SCALE)  # in-process command-line runs of generated scenes
N_API = int(900 * SCALE)  # API runs (scene_from_dict, and flexgen.solve on what parses)
N_SUBPROCESS = 24

ROOT = Path(__file__).resolve().parents[1]


class Raw(str):
    """TOML text written as is (a value with no Python form here: a 5000-digit integer, an array
    nested 1000 deep)."""


# -- the generator ------------------------------------------------------------------------------


def base_scene() -> dict:
    return {
        "name": "fuzz",
        "model": {"kind": "scm", "modes": 3},
        "base": {"points": {"r0": [0.0, 0.004]}},
        "flexure": [
            {"name": "p", "length": 0.02, "EI": 2.5e-5},
            {
                "name": "d",
                "parent": "m",
                "at": [0.045, 0.0, 0.0],
                "length": 0.015,
                "E": 2e9,
                "width": 0.01,
                "thickness": 0.0005,
            },
        ],
        "link": [
            {"name": "m", "parent": "p", "points": {"pad": [0.02, 0.004], "hole": [0.002, 0.003]}}
        ],
        "load": [{"point": "d.tip", "force": [0.0, -0.05], "moment": 0.0}],
        "tendon": [{"tension": 0.5, "route": ["base.r0", "m.hole"]}],
        "output": {"points": ["m.pad", "d.tip"]},
    }


NAMES = [
    "\x1b[2J\x1b[31mred",
    "tab\there",
    "new\nline",
    "cr\rreturn",
    "bell\x07",
    "csi\x9b31m",
    "ünïcødé",
    "指",
    "emoji😀",
    "rtl\u202eevil",
    "line\u2028sep",
    "$x^2$",
    "back\\slash",
    'quo"te',
    "x" * 300,
    "\ufeffbom",
]


def hostile_value(rng: random.Random, depth_ok: bool = True):
    choice = rng.randrange(22)
    if choice == 0:
        return math.nan
    if choice == 1:
        return rng.choice([math.inf, -math.inf])
    if choice == 2:
        # and unit strings (flexgen/units.py): good, of a wrong dimension, unknown, hostile
        return rng.choice(
            ["nan", "inf", "-inf", "1.0", "1e400", ""]
            + ["20 mm", "3 N", "200 GPa", "30 deg", "1e400 mm", "20 foo", "10**10**10 m"]
        )
    if choice == 3:
        return int("1" + "0" * rng.choice([20, 309, 400, 1000]))
    if choice == 4:
        return -int("9" * rng.choice([30, 400]))
    if choice == 5:
        return rng.choice([1e300, -1e300, 1e-300, 5e-324, 1e101, 1e-101, 1.7976931348623157e308])
    if choice == 6:
        return rng.choice([True, False])
    if choice == 7:
        return rng.choice(NAMES)
    if choice == 8:
        return []
    if choice == 9:
        return {}
    if choice == 10 and depth_ok:
        return nested(rng.choice([20, 100, 500, 1200]))
    if choice == 11:
        return [rng.random() for _ in range(rng.choice([1, 2, 4, 2000]))]
    if choice == 12:
        return {"x": 1.0, "\x00": 2.0}
    if choice == 13:
        return Raw("1" + "0" * 5000)
    if choice == 14:
        return rng.choice([0, -1, 1, 2, 8, 9, 512, 513, 2**31, 2**63])
    if choice == 15:
        return rng.choice([0.0, -0.0, -1.0, 0.5, 1.0, 5.0])
    if choice == 16:
        return [math.nan, math.inf]
    if choice == 17:
        return [[1.0, 2.0], [3.0]]
    if choice == 18:
        return "\x00nul"
    if choice == 19:
        return rng.choice(
            ["base", "p", "m", "d", "p.tip", "m.pad", "base.r0", "nowhere.x", "a.b.c"]
        )
    if choice == 20:
        return ["p.tip", "p.tip"]
    return rng.uniform(-1e3, 1e3)


def nested(depth: int):
    if depth > 400:  # deeper than any repr or serializer here should recurse: TOML text only
        return Raw("[" * depth + "]" * depth)
    v: list = []
    for _ in range(depth):
        v = [v]
    return v


def leaf_paths(d, prefix=()):
    """Every (path, value) of a nested dict/list scene."""
    out = []
    stack = [(prefix, d)]
    while stack:
        path, v = stack.pop()
        out.append((path, v))
        if isinstance(v, dict):
            stack.extend((path + (k,), x) for k, x in v.items())
        elif isinstance(v, list) and len(v) < 50:
            stack.extend((path + (i,), x) for i, x in enumerate(v))
    return out


def set_path(d, path, value):
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value


def del_path(d, path):
    for k in path[:-1]:
        d = d[k]
    if isinstance(d, dict):
        del d[path[-1]]
    elif isinstance(d, list):
        d.pop(path[-1])


def chain(n: int, child_first: bool, kind: str = "scm") -> dict:
    fl = [
        {"name": f"f{i}", "length": 1.0 / n, "EI": 1.0, "parent": f"f{i - 1}" if i else "base"}
        for i in range(n)
    ]
    if child_first:
        fl.reverse()
    return {
        "model": {"kind": kind, "elements": 2},
        "flexure": fl,
        "load": [{"point": f"f{n - 1}.tip", "force": [0.0, -0.5]}],
    }


MUTATIONS = ("set", "set", "set", "delete", "unknown", "names", "numbers", "model", "size")


def mutate(rng: random.Random, d: dict) -> dict:
    for _ in range(rng.choice([1, 1, 2, 3])):
        op = rng.choice(MUTATIONS)
        paths = [p for p, _ in leaf_paths(d) if p]
        if op == "set" and paths:
            set_path(d, rng.choice(paths), hostile_value(rng))
        elif op == "delete" and paths:
            with contextlib.suppress(KeyError, IndexError, TypeError):
                del_path(d, rng.choice(paths))
        elif op == "unknown":
            tables = [p for p, v in leaf_paths(d) if isinstance(v, dict)]
            where = rng.choice(tables)
            target = d
            for k in where:
                target = target[k]
            target[rng.choice(["lenght", "Ei", "parnet", "x", "\x1b[1m", "modes ", "點"])] = 1.0
        elif op == "names":  # valid scenes with hostile names, renamed consistently
            new = rng.choice(NAMES)
            old = rng.choice(["p", "m", "d", "r0", "pad"])
            text = json.dumps(d, allow_nan=True)
            if "." not in new:
                text = text.replace(f'"{old}"', json.dumps(new)).replace(
                    f'"{old}.', json.dumps(new)[:-1] + "."
                )
                text = text.replace(f'.{old}"', "." + json.dumps(new)[1:])
                with contextlib.suppress(ValueError):
                    d = json.loads(text)
            d["name"] = rng.choice(NAMES)
        elif op == "numbers":  # extreme but valid-looking magnitudes in numeric slots
            vals = [1e-100, 1e-30, 1e-10, 1e-3, 1.0, 1e3, 1e10, 1e30, 1e100, -1e100, 0.0]
            fl = d.get("flexure")
            if isinstance(fl, list) and fl and isinstance(fl[0], dict):
                fl[0]["length"] = rng.choice(vals[:9])
                fl[0]["EI"] = rng.choice(vals[:9])
            ld = d.get("load")
            if isinstance(ld, list) and ld and isinstance(ld[0], dict):
                ld[0]["force"] = [rng.choice(vals), rng.choice(vals)]
                ld[0]["moment"] = rng.choice(vals)
        elif op == "model":
            m = d.setdefault("model", {})
            if isinstance(m, dict):
                key = rng.choice(["kind", "modes", "elements", "kernel", "tolerance"])
                m[key] = rng.choice(
                    {
                        "kind": ["scm", "cc", "prb", "fem", "bogus", "SCM", 3],
                        "modes": [0, 1, 5, 8, 9, 10**300, -3, 2.0, "3", True],
                        "elements": [0, 1, 4, 513, 10**6, 10**300, -1, 2.5, "16", True],
                        "kernel": ["auto", "poly", "gauss", "fast", None],
                        "tolerance": [5, 1, 0, -1e-3, math.nan, math.inf, 1e-300, 1e-3, "1e-3"],
                    }[key]
                )
                if m[key] is None:
                    del m[key]
        elif op == "size":
            n = rng.choice([40, MAX_BODIES + 1, 1200, 3000])
            d = chain(n, child_first=rng.random() < 0.7, kind=rng.choice(["scm", "fem", "cc"]))
            if rng.random() < 0.3:  # a cycle, or a missing parent deep in the tree
                d["flexure"][rng.randrange(n)]["parent"] = rng.choice(["f1", "nowhere"])
    return d


# -- TOML writing ---------------------------------------------------------------------------------


def toml_value(v) -> str:
    if isinstance(v, Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def toml_key(k) -> str:
    k = str(k)
    if k and all(c.isascii() and (c.isalnum() or c in "_-") for c in k):
        return k
    return json.dumps(k, ensure_ascii=False)


def to_toml(d: dict, rng: random.Random) -> str:
    lines = []
    tables, arrays = [], []
    for k, v in d.items():
        if isinstance(v, dict) and v and rng.random() < 0.8:
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            arrays.append((k, v))
        else:
            lines.append(f"{toml_key(k)} = {toml_value(v)}")
    for k, v in tables:
        lines.append(f"[{toml_key(k)}]")
        lines.extend(f"{toml_key(a)} = {toml_value(b)}" for a, b in v.items())
    for k, items in arrays:
        for item in items:
            # the header in any of its legal spellings
            header = rng.choice(
                [toml_key(k), f'"{k}"', f"'{k}'", json.dumps(k).replace("e", "\\u0065")]
            )
            lines.append(f"[[ {header} ]]" if rng.random() < 0.2 else f"[[{header}]]")
            lines.extend(f"{toml_key(a)} = {toml_value(b)}" for a, b in item.items())
    return "\n".join(lines) + "\n"


def corrupt(rng: random.Random, text: str) -> str:
    """Byte-level damage: TOML that is broken, or valid in surprising ways."""
    for _ in range(rng.choice([1, 2, 4])):
        i = rng.randrange(len(text) + 1)
        op = rng.randrange(4)
        if op == 0:
            text = text[:i]
        elif op == 1:
            text = text[:i] + text[i + 1 :]
        else:
            bits = [
                "[",
                "]",
                "[[",
                '"',
                '"""',
                "'",
                "=",
                "#",
                "\n",
                "\x00",
                "\x1b",
                "\ufeff",
                "\u2028",
                "{",
                ".",
                "\\",
            ]
            text = text[:i] + rng.choice(bits) + text[i:]
    return text


def api_form(v):
    """A generated value as the API gets it (Raw text has no Python form: a big int instead)."""
    if isinstance(v, Raw):  # a nested list deeper than a recursive repr could print
        return 10**400 if v.startswith("1") else nested(len(v) // 2 if len(v) < 800 else 400)
    if isinstance(v, dict):
        return {k: api_form(x) for k, x in v.items()}
    if isinstance(v, list):
        return [api_form(x) for x in v]
    return v


# -- the contract -------------------------------------------------------------------------------


def printable_text(s: str) -> bool:
    return all(c.isprintable() or c in "\n\t" for c in s)


def run_main(argv: list[str]) -> tuple[int, str, str, list]:
    out, err = io.StringIO(), io.StringIO()
    with (
        warnings.catch_warnings(record=True) as caught,
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
    ):
        warnings.simplefilter("always")
        code = cli.main(argv)  # an exception escaping here fails the test
    return code, out.getvalue(), err.getvalue(), caught


def check_run(argv, code, out, err, caught, json_out: bool, exit1_converged: bool = False) -> None:
    """The contract of one run. ``exit1_converged``: exit 1 may carry a converged answer
    (``flexgen select``: the tolerance out of reach)."""
    where = f"flexgen {' '.join(map(repr, argv))[:300]}"
    assert code in (0, 1, 2), where
    assert not caught, f"{where}: warnings {[str(w.message) for w in caught][:3]}"
    if code == 0:
        assert err == "", f"{where}: {err!r}"
    else:
        lines = err.splitlines()
        assert len(lines) == 1 and err.endswith("\n"), f"{where}: {err[:500]!r}"
        assert lines[0].startswith("flexgen: "), f"{where}: {err!r}"
        assert "internal error" not in lines[0], f"{where}: {err!r}"
        assert printable_text(lines[0]), f"{where}: {err!r}"
    if code == 2 and not json_out:
        assert out == "", f"{where}: {out[:300]!r}"
    elif code == 2:  # bad input with --json: the contract's object, not converged, the reason
        obj = json.loads(out)
        assert obj["converged"] is False and obj["points"] == {}, where
        assert obj["reason"] and "\n" not in obj["reason"], where
    elif json_out:
        obj = json.loads(out)
        assert isinstance(obj, dict), where
        assert obj["converged"] == (code == 0) or (exit1_converged and code == 1), where
    else:
        assert printable_text(out), f"{where}: {out[:300]!r}"


def cli_options(rng: random.Random) -> list[str]:
    opts: list[str] = []
    r = rng.random()
    if r < 0.04:
        opts += ["--modes", rng.choice(["0", "9", "8", "1" + "0" * 300, "x", "-1", "3.5", "1e3"])]
    elif r < 0.08:
        opts += ["--elements", rng.choice(["0", "513", "4", "1" + "0" * 5000, "", "nan"])]
    elif r < 0.11:
        opts += ["--model", rng.choice(["scm", "prb", "cc", "fem", "magic", "\x1b[31m"])]
    elif r < 0.14:
        opts += ["--tol", rng.choice(["5", "1", "0", "-1", "nan", "inf", "1e-3", "0.01", "x"])]
    return opts


@pytest.fixture(scope="module")
def generated():
    """(TOML texts, API dicts): the seeded hostile scenes."""
    rng = random.Random(SEED)
    texts, dicts = [], []
    for _ in range(N_CLI):
        d = mutate(rng, base_scene())
        text = to_toml(d, rng)
        if rng.random() < 0.15:
            text = corrupt(rng, text)
        texts.append(text)
    for _ in range(N_API):
        dicts.append(api_form(mutate(rng, base_scene())))
    return texts, dicts


def test_generator_makes_enough_hostile_scenes(generated):
    texts, dicts = generated
    assert len(texts) + len(dicts) >= 2000
    assert len(set(texts)) > 0.8 * len(texts)  # distinct, not one scene many times


def test_cli_in_process(generated, tmp_path):
    texts, _ = generated
    rng = random.Random(SEED + 1)
    codes = {0: 0, 1: 0, 2: 0}
    for i, text in enumerate(texts):
        path = tmp_path / f"s{i % 7}.toml"
        if rng.random() < 0.03:
            path.write_bytes(text.encode("utf-8", "surrogatepass")[:50] + b"\xff\xfe" + b"x")
        else:
            path.write_text(text, encoding="utf-8", errors="surrogatepass")
        json_out = rng.random() < 0.5
        if rng.random() < 0.04:  # the selection's command: its own solves and report
            argv = ["select", str(path), "--tol", rng.choice(["0.01", "1e-6"]), "--repeat", "0"]
        else:
            argv = ["solve", str(path), *cli_options(rng)]
        argv += ["--json"] if json_out else []
        code, out, err, caught = run_main(argv)
        check_run(argv, code, out, err, caught, json_out, exit1_converged=argv[0] == "select")
        codes[code] += 1
    # the generator reaches every outcome: answers, no equilibrium and bad input
    assert codes[0] > 50 and codes[2] > 500 and codes[1] > 5, codes


def test_api(generated):
    _, dicts = generated
    rng = random.Random(SEED + 2)
    parsed = 0
    for d in dicts:
        try:
            scene = scene_from_dict(d)
        except (SceneError, ValueError, TypeError) as e:
            assert len(str(e).splitlines()) == 1 and str(e).strip(), repr(e)
            continue
        parsed += 1
        options = rng.choice(
            [
                {},
                {"tol": math.inf},
                {"tol": 2.0},
                {"max_steps": 2**31},
                {"max_steps": -1},
                {"max_step": math.nan},
                {"bogus": 1},
                {"modes": 10**300},
                {"modes": 9},
                {"elements": 513},
                {"model": "magic"},
                {"model": ["scm"]},
                {"tolerance": 5},
                {"tolerance": math.nan},
                {"q0": {"p": ["x"]}},
                {"q0": {"zz": [0.0]}},
                {"q0": {"p": [math.nan]}},
                {"q0": 3},
                {"models": {"p": 3}},
                {"settings": "fast"},
            ]
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                flexgen.solve(scene, **options)
            except (SceneError, ValueError, TypeError) as e:
                assert len(str(e).splitlines()) == 1 and str(e).strip(), repr(e)
        assert not caught, [str(w.message) for w in caught][:3]
    assert parsed > 50


def _special_files(tmp: Path) -> dict[str, Path]:
    good = tmp / "good.toml"
    good.write_text(to_toml(base_scene(), random.Random(0)))
    files = {"good": good}
    (tmp / "folder.toml").mkdir()
    files["folder"] = tmp / "folder.toml"
    os.mkfifo(tmp / "fifo.toml")
    files["fifo"] = tmp / "fifo.toml"
    (tmp / "link.toml").symlink_to(good)
    files["symlink"] = tmp / "link.toml"
    (tmp / "dangling.toml").symlink_to(tmp / "missing.toml")
    files["dangling"] = tmp / "dangling.toml"
    (tmp / "dirlink.toml").symlink_to(tmp / "folder.toml")
    files["dirlink"] = tmp / "dirlink.toml"
    (tmp / "empty.toml").write_text("")
    files["empty"] = tmp / "empty.toml"
    (tmp / "big.toml").write_bytes(b"# " + b"x" * (4 * 1024 * 1024 + 10) + b"\n")
    files["big"] = tmp / "big.toml"
    files["devnull"] = Path("/dev/null")
    files["nul"] = Path(str(tmp / "a") + "\x00b.toml")
    files["long"] = Path("x" * 5000 + ".toml")
    return files


@pytest.mark.parametrize(
    "kind, code",
    [
        ("good", 0),
        ("folder", 2),
        ("fifo", 2),
        ("symlink", 0),
        ("dangling", 2),
        ("dirlink", 2),
        ("empty", 2),
        ("big", 2),
        ("devnull", 2),
        ("nul", 2),
        ("long", 2),
    ],
)
def test_special_scene_files(tmp_path, kind, code):
    path = _special_files(tmp_path)[kind]
    argv = ["solve", str(path)]
    got, out, err, caught = run_main(argv)  # a FIFO must not block
    check_run(argv, got, out, err, caught, json_out=False)
    assert got == code, err


def test_default_parents_follow_document_order_not_text(tmp_path):
    """A [[flexure]] line inside a multi-line string is text, and [["fle\\u0078ure"]] is a
    flexure: default parents follow the tables as TOML reads them."""
    text = '''name = """
[[flexure]]
name = "decoy"
"""
[[flexure]]
name = "a"
length = 1.0
EI = 1.0
[[link]]
name = "L"
points = { p = [0.5, 0.0] }
[["fle\\u0078ure"]]
name = "b"
length = 1.0
EI = 1.0
[[ 'link' ]] # [[flexure]]
name = "M"
points = { q = [0.0, 0.0] }
[[ "flexure" ]]
name = """c
[[link]]
x"""
length = 1.0
EI = 1.0
'''
    path = tmp_path / "order.toml"
    path.write_text(text)
    scene = flexgen.load_scene(path)
    parents = {f.name: f.parent for f in scene.flexures} | {
        lk.name: lk.parent for lk in scene.links
    }
    c = "c\n[[link]]\nx"
    assert parents == {"a": "base", "L": "a", "b": "L", "M": "b", c: "M"}
    assert scene.declaration_order == ("a", "L", "b", "M", c)


def test_default_parents_of_inline_arrays_of_tables(tmp_path):
    """An inline array of flexures (or links) is as ordered as headers: its items sit at the
    place of its key, before every table header (TOML allows root keys only there). The same
    scene written with inline arrays and with [[...]] headers has the same parents."""
    inline = """"flexure" = [ { name = "a", length = 1.0, EI = 1.0 },
  { name = "b", length = 1.0, EI = 1.0, at = [0.5, 0.0, 0.0] } ]  # [[link]]
link = [ { name = "L", points = { p = [0.5, 0.0] } },
         { name = "M", points = { q = [0.0, 0.0] } } ]
[[load]]
point = "b.tip"
force = [0.0, -0.01]
"""
    headers = """[[flexure]]
name = "a"
length = 1.0
EI = 1.0
[[flexure]]
name = "b"
length = 1.0
EI = 1.0
at = [0.5, 0.0, 0.0]
[[link]]
name = "L"
points = { p = [0.5, 0.0] }
[[link]]
name = "M"
points = { q = [0.0, 0.0] }
[[load]]
point = "b.tip"
force = [0.0, -0.01]
"""
    mixed = (  # inline flexures, then [[link]] headers
        'flexure = [{ name = "a", length = 1.0, EI = 1.0 }]\n'
        '[[link]]\nname = "L"\npoints = { p = [0.5, 0.0] }\n'
        '[[link]]\nname = "K"\npoints = { q = [0.0, 0.0] }\n'
    )
    found = {}
    for name, text in (("inline", inline), ("headers", headers), ("mixed", mixed)):
        path = tmp_path / f"{name}.toml"
        path.write_text(text)
        scene = flexgen.load_scene(path)
        found[name] = (
            {f.name: f.parent for f in scene.flexures} | {lk.name: lk.parent for lk in scene.links},
            scene.declaration_order,
        )
    assert found["inline"] == found["headers"]
    assert found["inline"][0] == {"a": "base", "b": "a", "L": "b", "M": "b"}
    assert found["mixed"] == ({"a": "base", "L": "a", "K": "a"}, ("a", "L", "K"))


def test_trees_deeper_than_the_recursion_limit(monkeypatch):
    """Every traversal is iterative: a chain deeper than Python's recursion limit (built as a
    Scene directly, past the parser's size limit), declared child-first."""
    n = sys.getrecursionlimit() + 500
    spec = ModelSpec()
    fl = tuple(
        Flexure(f"f{i}", f"f{i - 1}" if i else "base", (0.0, 0.0, 0.0), 1.0, 1.0, spec)
        for i in reversed(range(n))
    )
    scene = Scene(name="deep", model=spec, base_points={}, flexures=fl)
    assert [f.name for f in scene.flexure_order()][:2] == ["f0", "f1"]
    assert len(scene.flexure_path(f"f{n - 1}")) == n
    from flexgen.chain import Chain
    from flexgen.models.exact import _SceneProblem

    models = {f.name: SimpleNamespace(n_dof=1) for f in fl}
    c = Chain(scene, models)  # type: ignore[arg-type]
    assert c.flexure_order[0] == "f0" and c.children("f0") == ["f1"]
    assert _SceneProblem(scene).order[0] == "f0"


def test_large_scenes_parse_in_linear_time():
    """8,000 flexures and 8,000 links are refused by the size limit at once, and a scene at the
    limit parses in well under a second (no quadratic step)."""
    big = {
        "flexure": [{"name": f"f{i}", "length": 1.0, "EI": 1.0} for i in range(8000)],
        "link": [{"name": f"l{i}", "parent": f"f{i}"} for i in range(8000)],
    }
    t = time.perf_counter()
    with pytest.raises(SceneError, match="too many bodies"):
        scene_from_dict(big, order=["flexure", "link"] * 8000)
    assert time.perf_counter() - t < 2  # was 9.9 s (quadratic): a guard against a hang
    n = MAX_BODIES // 2
    ok = {
        "flexure": [{"name": f"f{i}", "length": 1.0, "EI": 1.0} for i in range(n)],
        "link": [{"name": f"l{i}"} for i in range(n)],
    }
    t = time.perf_counter()
    scene = scene_from_dict(ok, order=["flexure", "link"] * n)
    assert time.perf_counter() - t < 2
    assert scene.link("l0").parent == "f0" and scene.flexure("f1").parent == "l0"


def _plot_targets(tmp: Path) -> dict[str, Path]:
    (tmp / "dir.png").mkdir()
    target = tmp / "target.png"
    target.write_bytes(b"keep me")
    (tmp / "link.png").symlink_to(target)
    os.mkfifo(tmp / "fifo.png")
    (tmp / "afile").write_text("x")
    return {
        "new": tmp / "out" / "new.png",
        "svg": tmp / "new.svg",
        "existing": target,
        "dir": tmp / "dir.png",
        "symlink": tmp / "link.png",
        "fifo": tmp / "fifo.png",
        "suffix": tmp / "out.txt",
        "under-a-file": tmp / "afile" / "x.png",
    }


@pytest.mark.parametrize(
    "kind, code",
    [
        ("new", 0),
        ("svg", 0),
        ("existing", 0),
        ("dir", 2),
        ("symlink", 2),
        ("fifo", 2),
        ("suffix", 2),
        ("under-a-file", 2),
    ],
)
def test_plot_output_paths(tmp_path, kind, code):
    pytest.importorskip("matplotlib")
    scene = tmp_path / "scene.toml"
    d = base_scene()
    d["name"] = "\x1b[31m$x$ 指"
    scene.write_text(to_toml(d, random.Random(1)))
    out_dir = tmp_path / "plots"
    out_dir.mkdir()
    target = _plot_targets(out_dir)[kind]
    before = sorted(p.name for p in out_dir.iterdir())
    argv = ["plot", str(scene), "-o", str(target)]
    got, out, err, caught = run_main(argv)
    check_run(argv, got, out, err, caught, json_out=False)
    assert got == code, err
    if kind == "symlink":
        assert (out_dir / "target.png").read_bytes() == b"keep me"
    if code == 0:
        assert target.is_file() and not target.is_symlink() and target.stat().st_size > 1000
    else:
        assert sorted(p.name for p in out_dir.iterdir()) == before  # nothing written
    leftovers = [p for p in out_dir.rglob(".*") if p.is_file()]
    assert not leftovers  # no temporary file left behind


def test_plot_without_matplotlib(tmp_path, monkeypatch):
    import importlib.util

    scene = tmp_path / "scene.toml"
    scene.write_text(to_toml(base_scene(), random.Random(1)))
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "matplotlib" else real(name, *a),
    )
    argv = ["plot", str(scene), "-o", str(tmp_path / "x.png")]
    code, out, err, caught = run_main(argv)
    check_run(argv, code, out, err, caught, json_out=False)
    assert code == 1 and "pip install" in err and not (tmp_path / "x.png").exists()


def test_plot_failed_write_leaves_nothing(tmp_path, monkeypatch):
    """A write that fails half way (a full disk) leaves neither a temporary nor a 0-byte file,
    and an existing plot untouched."""
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    scene = tmp_path / "scene.toml"
    scene.write_text(to_toml(base_scene(), random.Random(1)))
    target = tmp_path / "plot.png"
    target.write_bytes(b"old plot")

    def full_disk(self, fname, *args, **kwargs):
        Path(fname).write_bytes(b"partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", full_disk)
    argv = ["plot", str(scene), "-o", str(target)]
    code, out, err, caught = run_main(argv)
    check_run(argv, code, out, err, caught, json_out=False)
    assert code == 1 and "No space left" in err
    assert target.read_bytes() == b"old plot"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plot.png", "scene.toml"]


def test_cli_subprocess_sample(generated, tmp_path):
    """A sample through a real process: exit codes and stderr exactly one line."""
    texts, _ = generated
    rng = random.Random(SEED + 3)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("FLEXGEN_TRACEBACK", None)
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    cases = [["solve", str(fifo)]]
    for i, text in enumerate(rng.sample(texts, N_SUBPROCESS - 1)):
        path = tmp_path / f"s{i}.toml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        cases.append(["solve", str(path), *(["--json"] if i % 2 else [])])
    procs = []
    for argv in cases:
        procs.append(
            (
                argv,
                subprocess.Popen(
                    [sys.executable, "-m", "flexgen", *argv],
                    stdout=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                    stdin=subprocess.DEVNULL,
                    env=env,
                ),
            )
        )
        if len(procs) % 4 == 0:  # a few at a time: two cores
            procs[-4][1].wait(timeout=60)
    for argv, p in procs:
        out_b, err_b = p.communicate(timeout=60)
        out, err = out_b.decode(), err_b.decode()
        assert p.returncode in (0, 1, 2), (argv, err[-2000:])
        assert "Traceback" not in err, (argv, err[-2000:])
        check_run(argv, p.returncode, out, err, [], json_out="--json" in argv)
