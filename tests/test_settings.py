"""flexgen.settings.SolverSettings mirrors fg_settings of chain_solver.h (names, order, types),
its defaults are the solver's, and it rejects what the solver cannot run with."""

import math
import re
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from flexgen.core import SOURCES, ffi
from flexgen.settings import DEFAULT, SolverSettings

HEADER = SOURCES / "chain_solver.h"


def header_fields():
    text = HEADER.read_text()
    end = text.index("} fg_settings;")
    body = text[text.rindex("typedef struct {", 0, end) + len("typedef struct {") : end]
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    out = []
    for decl in body.split(";"):
        decl = decl.strip()
        if not decl:
            continue
        ctype, names = decl.split(None, 1)
        out += [(name.strip(), ctype) for name in names.split(",")]
    return out


def test_fields_mirror_the_header():
    declared = header_fields()
    assert [
        (f.name, {"float": "double", "int": "int", "bool": "int"}[f.type])
        for f in fields(SolverSettings)
    ] == declared
    # and the struct compiled into the core (cffi reads the header) has them in that order
    assert [name for name, _ in ffi.typeof("fg_settings").fields] == [n for n, _ in declared]


def test_defaults_are_the_solvers():
    assert DEFAULT == SolverSettings()
    assert (DEFAULT.tol, DEFAULT.max_iterations, DEFAULT.max_steps, DEFAULT.max_dq) == (
        1e-12,
        50,
        500,
        0.5,
    )
    assert (DEFAULT.initial_step, DEFAULT.max_step, DEFAULT.min_step) == (0.1, 0.25, 1e-5)
    assert DEFAULT.lapack_min_size == 32  # built-in below, LAPACK from 32 (solver-speed.md)


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("tol", math.inf, "settings.tol: must be a finite number in (0, 1), got inf"),
        ("tol", 0.0, "settings.tol: must be a finite number in (0, 1), got 0.0"),
        ("max_dq", -1.0, "settings.max_dq: must be a finite number > 0, got -1.0"),
        ("max_steps", -1, "settings.max_steps: must be an integer in [0, 2**31 - 1], got -1"),
        ("max_iterations", 2**31, "settings.max_iterations: must be an integer in [0, 2**31 - 1]"),
        ("line_search_halvings", 0, "settings.line_search_halvings: must be an integer in [1, "),
        ("max_iterations", 2.0, "settings.max_iterations: must be an integer, got 2.0"),
        ("armijo", True, "settings.armijo: must be a finite number, got True"),
        (
            "initial_step",
            0.5,
            "settings: min_step <= initial_step <= max_step must hold, got min_step=1e-05, "
            "initial_step=0.5, max_step=0.25",
        ),
        (
            "min_step",
            0.5,  # review: blamed on the default initial_step
            "settings: min_step <= initial_step <= max_step must hold, got min_step=0.5, ",
        ),
        (
            "stagnation_lag",
            9,
            "settings.stagnation_lag: must be at most stagnation_after (8), got 9",
        ),
        ("step_shrink", 1.0, "settings.step_shrink: must be a finite number in (0, 1), got 1.0"),
    ],
)
def test_bad_values_are_named(field, value, message):
    with pytest.raises(ValueError) as exc:
        SolverSettings(**{field: value})
    assert str(exc.value).startswith(message)
    assert "\n" not in str(exc.value)


def test_max_lag_is_the_headers():
    from flexgen import settings

    found = re.search(r"#define FG_MAX_LAG (\d+)", HEADER.read_text())
    assert int(found.group(1)) == settings.MAX_LAG
    with pytest.raises(ValueError, match=r"settings.stagnation_lag: must be at most 64"):
        SolverSettings(stagnation_lag=65, stagnation_after=100)


def test_the_ellipse_rounding_is_the_estimates_compliance_rounding():
    # one number in two languages: the ellipse clamps a minor axis within the compliance's
    # rounding to 0, the estimate floors a compliance estimate at that rounding
    from flexgen import estimate

    source = (HEADER.parent / "chain_solver.c").read_text()
    found = re.search(r"#define FG_ELLIPSE_ROUNDING (\S+)", source)
    assert float(found.group(1)) == estimate.ROUNDING_COMPLIANCE


def test_prepared_solver_refuses_a_warm_start_for_an_unknown_flexure():
    """A q0 naming no flexure of the scene is an error (a typo would otherwise be a silent cold
    solve); coordinates of another mode count are padded or cut, a warm start like any other."""
    import numpy as np

    import flexgen

    scene = Path(__file__).resolve().parents[1] / "examples" / "cantilever_tip_load.toml"
    solver = flexgen.Solver(scene)
    with pytest.raises(ValueError, match="q0: unknown flexure 'bem'"):
        solver.solve(q0={"bem": [0.1, 0.0, 0.0]})
    r = solver.solve()
    for q0 in (list(r.q["beam"]) + [0.0, 0.0], list(r.q["beam"])[:2]):
        again = solver.solve(q0={"beam": q0})
        assert again.converged
        np.testing.assert_allclose(again.q["beam"], r.q["beam"], rtol=0, atol=1e-12)


def test_numpy_integers_are_integers():
    """max_steps=np.int64(50) was refused ("must be an integer") where modes takes it."""
    import numpy as np

    s = SolverSettings(max_steps=np.int64(50))
    assert s.max_steps == 50 and type(s.max_steps) is int


def test_warm_on_path_is_a_flag():
    # review: SolverSettings(warm_on_path=False), as solve.md's loading-history recipe writes
    # it, was refused ("must be an integer, got False")
    assert SolverSettings(warm_on_path=False).warm_on_path is False
    assert SolverSettings(warm_on_path=1).warm_on_path is True
    assert SolverSettings(warm_on_path=np.False_).warm_on_path is False  # NumPy's bool too
    for bad in (2, 0.0, "no", None):
        with pytest.raises(ValueError, match=r"^settings.warm_on_path: must be True or False"):
            SolverSettings(warm_on_path=bad)


def test_the_docs_settings_table_is_the_dataclass():
    # docs/solver-core.md lists every field with its default: the same fields, in order, with
    # the defaults SolverSettings has (review: three copies of every setting, one tied by test)
    doc = (Path(__file__).resolve().parents[1] / "docs" / "solver-core.md").read_text()
    table = doc[doc.index("| field | default | accepted | what it sets |") :]
    rows = re.findall(r"^\| `(\w+)` \| ([^|]+) \|", table, flags=re.M)
    names = [f.name for f in fields(SolverSettings)]
    assert [name for name, _ in rows[: len(names)]] == names
    for name, default in rows[: len(names)]:
        value = getattr(DEFAULT, name)
        shown = {"True": True, "False": False}.get(default.strip(), default.strip())
        if isinstance(value, bool):
            assert shown is value, name
        else:
            assert float(shown) == value, name


def test_an_integer_beyond_a_floats_range_is_a_value_error_naming_the_field():
    # review: SolverSettings(tol=10**400) raised a bare OverflowError (int too large)
    with pytest.raises(ValueError, match=r"^settings.max_step: must be a finite number"):
        SolverSettings(max_step=10**400)
