"""flexgen.sweep, Scene.with_value and `flexgen sweep` (docs/sweep.md)."""

from __future__ import annotations

import dataclasses
import io
import itertools
import json
import math
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import flexgen
from flexgen import SceneError
from flexgen.cli import main

ROOT = Path(__file__).resolve().parents[1]
FINGER = ROOT / "examples" / "two_link_finger.toml"
POINTS = ("middle.pad", "fingertip.pad")
FLEXURES = ("proximal", "distal")
POINT_COLUMNS = ("x", "y", "angle", "major", "minor", "ellipse_angle", "error_estimate")
# A warm-started Newton and a cold load path stop at different iterates within the solver's
# tolerance (SolverSettings.tol = 1e-12, relative): measured differences up to 2.5e-12 on the
# finger's compliances, so rows are compared with a margin of 100 tol.
RTOL = 100 * flexgen.SolverSettings().tol
# Compliances (the ellipse axes) come from the stiffness and Jacobians of the last evaluated
# state: Newton's last step is taken unevaluated (docs/solver-core.md), from a residual of up to
# 30 tol, so they differ between paths by up to ~3e-10 relative (measured 2.6e-10 on the finger)
CRTOL = 1000 * flexgen.SolverSettings().tol
# The error estimate is a difference of two answers (dimensionless), so it carries their own
# difference between paths, mostly the compliances' (CRTOL) times its margin: docs/sweep.md
# claims 1e-6 relative or 1e-9 absolute, whichever is larger (measured worst 2.3e-10 absolute;
# 5.7e-5 relative at an estimate of 2.9e-8)
EST_RTOL, EST_ATOL = 1e-6, 1e-9
ELASTICA = ROOT / "examples" / "rectangular_elastica.toml"
sweep_module = sys.modules["flexgen.sweep"]


@pytest.fixture(scope="module")
def finger():
    return flexgen.load_scene(FINGER)


def expected_columns(keys):
    cols = list(keys) + ["converged", "stable", "iterations", "reason", "warnings", "notes"]
    cols += [f"{p}.{c}" for p in POINTS for c in POINT_COLUMNS]
    cols += [f"{f}.{c}" for f in FLEXURES for c in ("max_stress", "safety_factor")]
    return cols


def assert_row_is_solve(row, result):
    """The row's numbers are those of ``result`` (a cold flexgen.solve of the same scene)."""
    assert row["converged"] == result.converged
    assert row["stable"] == result.stable
    # the Result's warnings and notes, but the safety factors' (their own column)
    warnings = [w for w in result.warnings if "safety factor " not in w]
    assert row["warnings"] == "\n".join(warnings)
    assert row["notes"] == "\n".join(result.notes)
    for ref, pr in result.points.items():
        got = [row[f"{ref}.{c}"] for c in ("x", "y", "angle")]
        np.testing.assert_allclose(got, pr.pose, rtol=RTOL, atol=RTOL * 0.1)
        ell = pr.ellipse
        got = [row[f"{ref}.major"], row[f"{ref}.minor"]]
        np.testing.assert_allclose(
            got, [ell["major"], ell["minor"]], rtol=0, atol=CRTOL * ell["major"]
        )
        assert row[f"{ref}.ellipse_angle"] == pytest.approx(ell["angle"], abs=1e-8)
        est = max(pr.error_estimate.values())
        assert row[f"{ref}.error_estimate"] == pytest.approx(est, rel=EST_RTOL, abs=EST_ATOL)
    for name, st in result.flexures.items():
        for column in ("max_stress", "safety_factor"):
            want = getattr(st, column)
            got = row[f"{name}.{column}"]
            assert math.isnan(got) if want is None else got == pytest.approx(want, rel=1e-9)


# -- Scene.with_value -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "path, value, read",
    [
        ("flexure.proximal.thickness", 0.3e-3, lambda s: s.flexure("proximal").EI),
        ("flexure.0.length", 0.025, lambda s: s.flexures[0].length),
        ("flexure.distal.at.0", 0.04, lambda s: s.flexure("distal").at[0]),
        ("flexure.distal.modes", 5, lambda s: s.flexure("distal").model.modes),
        ("load.0.force.1", -1.5, lambda s: s.loads[0].force[1]),
        ("load.0.moment", 0.01, lambda s: s.loads[0].moment),
        ("tendon.0.tension", 3.0, lambda s: s.tendons[0].tension),
        ("model.modes", 4.0, lambda s: [f.model.modes for f in s.flexures]),
        ("link.middle.points.pad.0", 0.018, lambda s: s.link("middle").points["pad"][0]),
        ("link.1.points.anchor.1", 0.005, lambda s: s.link("fingertip").points["anchor"][1]),
        ("base.points.r0.1", 0.006, lambda s: s.base_points["r0"][1]),
        ("name", "other", lambda s: s.name),
    ],
)
def test_with_value_changes_the_value_at_each_path_form(finger, path, value, read):
    changed = finger.with_value(path, value)
    want = {
        # EI = E w t^3 / 12 of the scene's steel strip (E 200 GPa, 10 mm wide)
        "flexure.proximal.thickness": 200e9 * 0.010 * 0.3e-3**3 / 12,
        "model.modes": [4, 4],
    }.get(path, value)
    assert read(changed) == pytest.approx(want)
    assert read(finger) != pytest.approx(want)  # the original is untouched
    assert changed.declaration_order == finger.declaration_order


def test_with_value_reads_units_as_the_scene_does(finger):
    assert finger.with_value("flexure.0.length", "25 mm").flexures[0].length == pytest.approx(0.025)


def test_with_value_keeps_what_it_does_not_change(finger):
    changed = finger.with_value("tendon.0.tension", 3.0)
    assert dataclasses.replace(changed, tendons=finger.tendons) == finger


@pytest.mark.parametrize(
    "path, value, message",
    [
        (
            "flexure.wrist.thickness",
            1e-3,
            "flexure.wrist.thickness: unknown flexure 'wrist' (known: proximal, distal)",
        ),
        ("flexure.proximal.thick", 1e-3, "flexure.proximal has no key 'thick'"),
        ("load.3.force.0", 1.0, "load.3.force.0: no load 3 (the scene has 1)"),
        ("load.0.force.2", 1.0, "load.0.force has no index '2'"),
        (
            "link.middle.points.palm.0",
            1.0,
            "link.middle.points has no key 'palm' (known: pad, hole, joint)",
        ),
        ("gravity", 9.81, "the scene has no key 'gravity'"),
        # review: "flexure.proximal.at has no key '2' (known: none)"
        ("flexure.proximal.at.2", 0.1, "flexure.proximal.at is not in the scene, so it has no"),
        ("flexure.proximal", 1.0, "names a whole [[flexure]] table"),
        (
            "tendon.0.tension",
            -1.0,
            "tendon.0.tension: tendon[0].tension: must be zero or a positive",
        ),
        (
            "tendon.0.tension",
            "ten",  # a string is a number with its unit ("5 N"), as in a scene file
            "tendon.0.tension: tendon[0].tension: 'ten': expected a number and a unit",
        ),
        ("model.modes", 2.5, "model.modes: must be an integer in [1, 8]"),
        ("flexure.proximal.EI", 1e-4, "flexure.proximal.EI: flexure[0].E: conflicts with EI"),
        ("flexure..length", 1.0, "scene path must be keys joined by dots"),
    ],
)
def test_with_value_errors_name_the_path(finger, path, value, message):
    with pytest.raises(SceneError) as err:
        finger.with_value(path, value)
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_with_value_on_a_flexure_given_by_ei_follows_the_scene_rules():
    scene = flexgen.scene_from_dict({"flexure": [{"name": "beam", "length": 0.02, "EI": 1e-4}]})
    assert scene.with_value("flexure.beam.EI", 2e-4).flexures[0].EI == 2e-4
    # a thickness beside EI is the section for the stress; EI stays as given
    thick = scene.with_value("flexure.beam.thickness", 1e-3).flexures[0]
    assert (thick.EI, thick.thickness) == (1e-4, 1e-3)
    with pytest.raises(SceneError, match="flexure.beam.E: flexure\\[0\\].E: conflicts with EI"):
        scene.with_value("flexure.beam.E", 2e11)


def test_with_value_refuses_a_scene_changed_behind_its_source(finger):
    changed = dataclasses.replace(finger, loads=())
    with pytest.raises(SceneError, match="changed after it was read"):
        changed.with_value("tendon.0.tension", 1.0)
    bare = dataclasses.replace(finger, source=None)
    with pytest.raises(SceneError, match="built without its source"):
        bare.with_value("tendon.0.tension", 1.0)


# -- the study ---------------------------------------------------------------------------------


def test_load_grid_rows_are_the_single_solves_in_c_order(finger):
    tensions, forces = [0.0, 4.0, 10.0], [0.0, -0.3, -1.0]
    df = flexgen.sweep(finger, {"tendon.0.tension": tensions, "load.0.force.1": forces}, workers=1)
    assert list(df.columns) == expected_columns(["tendon.0.tension", "load.0.force.1"])
    want = list(itertools.product(tensions, forces))  # the first key slowest
    assert list(zip(df["tendon.0.tension"], df["load.0.force.1"])) == want
    assert df["converged"].all() and (df["reason"] == "").all()
    for (t, f), (_, row) in zip(want, df.iterrows()):
        scene = finger.with_value("tendon.0.tension", t).with_value("load.0.force.1", f)
        assert_row_is_solve(row, flexgen.solve(scene))


def test_a_start_stop_count_grid_holds_the_decimal_values_a_user_reads(finger):
    # numpy.linspace(0, 1, 11)[3] is 0.30000000000000004: the table's key column (and the
    # value solved) is 0.3, as a user writing the grid by hand would have it
    df = flexgen.sweep(finger, {"tendon.0.tension": (0.0, 1.0, 11)}, workers=1, estimate=False)
    assert df["tendon.0.tension"].tolist() == [i / 10 for i in range(11)]
    assert repr(float(df["tendon.0.tension"][3])) == "0.3"
    # where 15 digits would merge distinct points (a step of 4e-15), the points themselves
    fine = flexgen.sweep(
        finger, {"tendon.0.tension": (2.0, 2.00000000000002, 6)}, workers=1, estimate=False
    )
    assert fine["tendon.0.tension"].nunique() == 6


def test_design_grid_rows_are_the_single_solves(finger):
    vary = {
        "flexure.proximal.thickness": (0.2e-3, 0.3e-3, 2),
        "load.0.force.1": (0.0, -1.0, 2),
        "flexure.distal.length": (0.012, 0.018, 2),
    }
    df = flexgen.sweep(finger, vary, workers=1)
    assert len(df) == 8
    assert list(df["flexure.distal.length"]) == [0.012, 0.018] * 4  # the last key fastest
    for _, row in df.iterrows():
        scene = finger
        for key in vary:
            scene = scene.with_value(key, row[key])
        assert_row_is_solve(row, flexgen.solve(scene))


def test_monte_carlo_draws_from_the_seed(finger):
    vary = {
        "flexure.proximal.thickness": ("normal", 0.25e-3, 0.01e-3),
        "tendon.0.tension": ("uniform", 5.0, 10.0),
    }
    df = flexgen.sweep(finger, vary, samples=6, seed=7, workers=1)
    rng = np.random.default_rng(7)  # key by key, in the order given
    np.testing.assert_array_equal(df["flexure.proximal.thickness"], rng.normal(0.25e-3, 0.01e-3, 6))
    np.testing.assert_array_equal(df["tendon.0.tension"], rng.uniform(5.0, 10.0, 6))
    pd.testing.assert_frame_equal(df, flexgen.sweep(finger, vary, samples=6, seed=7, workers=1))
    other = flexgen.sweep(finger, vary, samples=6, seed=8, workers=1)
    assert not np.array_equal(other["tendon.0.tension"], df["tendon.0.tension"])
    row = df.iloc[3]
    scene = finger.with_value("flexure.proximal.thickness", row["flexure.proximal.thickness"])
    assert_row_is_solve(
        row, flexgen.solve(scene.with_value("tendon.0.tension", row["tendon.0.tension"]))
    )


def test_a_scene_without_a_section_has_empty_stress_columns():
    beam = {
        "flexure": [{"name": "beam", "length": 0.02, "EI": 1e-4}],
        "load": [{"point": "beam.tip", "force": [0.0, -1.0]}],
    }
    df = flexgen.sweep(beam, {"load.0.force.1": [-1.0, -2.0]}, workers=1)
    assert df["beam.max_stress"].isna().all() and df["beam.safety_factor"].isna().all()
    assert flexgen.solve(beam).flexures["beam"].max_stress is None
    # the section (E, width, thickness) gives it
    del beam["flexure"][0]["EI"]
    beam["flexure"][0].update(E=2e11, width=0.01, thickness=1e-3)
    df = flexgen.sweep(beam, {"load.0.force.1": [-2.0]}, workers=1)
    scene = flexgen.scene_from_dict(beam).with_value("load.0.force.1", -2.0)
    want = flexgen.solve(scene).flexures["beam"].max_stress
    assert want > 0 and df["beam.max_stress"].iloc[0] == pytest.approx(want, rel=1e-9)


def test_a_typo_in_a_study_key_suggests_the_key():
    """As a scene's own keys do: "did you mean", the key and flexure names listed."""
    finger = ROOT / "examples" / "two_link_finger.toml"
    with pytest.raises(SceneError, match=r"has no key 'thicknes' \(did you mean 'thickness'\?"):
        flexgen.sweep(finger, {"flexure.proximal.thicknes": [2e-4]}, workers=1)
    with pytest.raises(SceneError, match=r"unknown flexure 'proximl' \(did you mean 'proximal'\?"):
        flexgen.sweep(finger, {"flexure.proximl.thickness": [2e-4]}, workers=1)


def test_a_table_in_scene_units_says_them(tmp_path):
    """A scene with units: the table's attrs carry the Result's "units" object (Parquet keeps
    it); a scene without units gives none."""
    pytest.importorskip("pyarrow")
    beam = {
        "units": {"length": "mm", "force": "N"},
        "flexure": [{"name": "beam", "length": 20.0, "EI": 2000.0}],
        "load": [{"point": "beam.tip", "force": [0.0, -1.0]}],
    }
    df = flexgen.sweep(beam, {"load.0.force.1": [-1.0, -2.0]}, workers=1)
    assert df.attrs["units"] == json.loads(flexgen.solve(beam).to_json())["units"]
    assert df.attrs["units"]["compliance"] == "mm/N"
    df.to_parquet(tmp_path / "t.parquet")
    assert pd.read_parquet(tmp_path / "t.parquet").attrs["units"] == df.attrs["units"]
    del beam["units"]
    assert "units" not in flexgen.sweep(beam, {"load.0.force.1": [-1.0]}, workers=1).attrs


def test_a_scene_without_loads_reports_the_free_tips_as_a_solve_does():
    """No [[load]] and no [output]: the table's point columns are the points flexgen.solve
    reports (the tip of the flexure that carries no other), not none."""
    beam = {"flexure": [{"name": "a", "length": 1.0, "EI": 1.0}, {"name": "b", "length": 0.5}]}
    beam["flexure"][1]["EI"] = 2.0
    df = flexgen.sweep(beam, {"flexure.a.length": [1.0, 2.0]}, workers=1)
    assert list(flexgen.solve(beam).points) == ["b.tip"]
    assert df["b.tip.x"].tolist() == pytest.approx([1.5, 2.5], rel=1e-12)


def test_failed_cases_are_rows_with_their_reason(finger):
    # the polynomial kernel only: a tendon bending the distal flexure past 90 deg has no answer
    scene = finger.with_value("model.kernel", "poly")
    df = flexgen.sweep(scene, {"tendon.0.tension": [0.0, 40.0, 5.0]}, workers=1)
    assert list(df["converged"]) == [True, False, True]
    failed = df.iloc[1]
    assert "bent past the range of the polynomial kernel" in failed["reason"]
    assert failed["reason"] == flexgen.solve(scene.with_value("tendon.0.tension", 40.0)).reason
    assert not failed["stable"] and math.isnan(failed["fingertip.pad.x"])
    assert math.isnan(failed["distal.max_stress"])
    assert df.iloc[2]["reason"] == "" and np.isfinite(df.iloc[2]["fingertip.pad.x"])


def test_a_failed_rows_warnings_and_notes_are_the_failed_solves(finger):
    # review: a failed row's notes were always empty, where flexgen.solve notes the kernel
    # switches on the way to where the load path ended (the flexures bent past a range)
    df = flexgen.sweep(finger, {"tendon.0.tension": [67.5]}, workers=1)
    row = df.iloc[0]
    single = flexgen.solve(finger.with_value("tendon.0.tension", 67.5))
    assert not row["converged"] and not single.converged
    assert len(single.notes) == 2 and "switched to the Gauss kernel" in single.notes[0]
    assert row["notes"] == "\n".join(single.notes)
    assert row["warnings"] == "\n".join(single.warnings)
    assert row["reason"] == single.reason


def test_without_the_estimate_or_stress_their_columns_are_empty(finger):
    df = flexgen.sweep(finger, {"tendon.0.tension": [1.0, 2.0]}, workers=1, estimate=False)
    assert df["fingertip.pad.error_estimate"].isna().all()
    assert df["fingertip.pad.x"].notna().all() and df["distal.max_stress"].notna().all()
    df = flexgen.sweep(finger, {"tendon.0.tension": [1.0, 2.0]}, workers=1, stress=False)
    assert df["distal.max_stress"].isna().all() and df["distal.safety_factor"].isna().all()
    assert df["fingertip.pad.error_estimate"].notna().all()


def test_stress_columns_are_the_results_flexures(finger):
    # a yield strength gives the safety factor; the finger's section (E, width, thickness) the
    # stress; the tendon at 10 N takes the thin distal flexure past 1.4 GPa
    scene = finger.with_value("model.yield_strength", 1.4e9)
    df = flexgen.sweep(scene, {"tendon.0.tension": [2.0, 10.0]}, workers=1)
    for tension, (_, row) in zip([2.0, 10.0], df.iterrows()):
        result = flexgen.solve(scene.with_value("tendon.0.tension", tension))
        assert result.flexures["distal"].max_stress > 0
        assert_row_is_solve(row, result)
    assert df["distal.safety_factor"].iloc[1] < 1 < df["distal.safety_factor"].iloc[0]
    # without a strength the stress is known and the safety factor is not
    plain = flexgen.sweep(finger, {"tendon.0.tension": [10.0]}, workers=1)
    assert plain["distal.max_stress"].iloc[0] == df["distal.max_stress"].iloc[1]
    assert math.isnan(plain["distal.safety_factor"].iloc[0])


@pytest.mark.parametrize(
    "vary, kwargs, message",
    [
        (
            {"tendon.0.tension": (0.0, 1.0, 0)},
            {},
            "tendon.0.tension: count must be an integer >= 1",
        ),
        ({"tendon.3.tension": (0.0, 1.0, 2)}, {}, "tendon.3.tension: no tendon 3"),
        ({"tendon.0.tension": ("normal", 1.0, 0.1)}, {}, "needs samples=N"),
        ({"tendon.0.tension": (0.0, 1.0, 2)}, {"samples": 5}, "with samples, expected"),
        ({"tendon.0.tension": ("gamma", 1.0, 0.1)}, {"samples": 5}, "with samples, expected"),
        (
            {"load.0.force.1": ("uniform", -1e308, 1e308)},
            {"samples": 3},
            "load.0.force.1: uniform's range high - low overflows",
        ),
        (
            {"tendon.0.tension": (-1.0, 1.0, 3)},
            {},
            "tendon.0.tension: tendon[0].tension: must be zero",
        ),
        (
            {"flexure.proximal.thickness": ("normal", 0.1e-3, 1e-3)},
            {"samples": 50, "seed": 1},
            "flexure.proximal.thickness: flexure[0].thickness: must be a positive",
        ),
        ({"load.0.point": (0.0, 1.0, 2)}, {}, "load.0.point: load[0].point: must be a string"),
        # a tuple is (start, stop, count): a forgotten count is not read as two values
        ({"load.0.force.1": (0.0, -1.0)}, {}, "load.0.force.1: a tuple is (start, stop, count)"),
        # counted before any axis is made (review: a MemoryError asking for 745 GiB)
        ({"load.0.force.1": (-1.0, -2.0, 10**11)}, {}, "vary: 100000000000 cases (at most"),
        # a value with a unit: values are numbers in the scene's units
        ({"load.0.force.1": ["1 N", "2 N"]}, {}, "'1 N' is neither a number (values are numbers"),
        ({}, {}, "vary: expected"),
        (
            {"flexure.proximal.thickness": [2e-4], "flexure.0.thickness": [3e-4]},
            {},
            "vary: flexure.proximal.thickness and flexure.0.thickness name the same value",
        ),
        (
            {"load.0.force.1": [0.0], "load.0.force.01": [-1.0]},
            {},
            "vary: load.0.force.1 and load.0.force.01 name the same value",
        ),
        ({"model.tolerance": [1e-4, 1e-3]}, {}, "model.tolerance: a study does not vary a tol"),
        (
            {"flexure.proximal.tolerance": [1e-4]},
            {},
            "flexure.proximal.tolerance: a study does not vary a tolerance",
        ),
        (
            {"flexure.proximal.thickness": ("normal", 0.25e-3, 0.01e-3)},
            {"samples": 3, "seed": -1},
            "seed: must be an integer >= 0, got -1",
        ),
    ],
)
def test_bad_studies_are_one_line_errors_before_solving(finger, vary, kwargs, message):
    with pytest.raises(SceneError) as err:
        flexgen.sweep(finger, vary, workers=1, **kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "path, canonical",
    [
        ("flexure.proximal.thickness", "flexure.0.thickness"),
        ("flexure.0.thickness", "flexure.0.thickness"),
        ("flexure.distal.at.00", "flexure.1.at.0"),
        ("load.0.force.01", "load.0.force.1"),
        ("link.fingertip.points.pad.1", "link.1.points.pad.1"),
        ("model.modes", "model.modes"),
    ],
)
def test_paths_naming_one_value_have_one_spelling(finger, path, canonical):
    from flexgen.scene import TABLE_KEYS
    from flexgen.scenepath import resolve

    root = finger.editable_source()
    container, key, got = resolve(root, path, TABLE_KEYS)
    assert got == canonical
    # the same value: changing it by either spelling gives the same scene
    same = resolve(root, canonical, TABLE_KEYS)
    assert same[0] is container and same[1] == key


def test_a_flexure_model_key_is_one_value_by_both_paths():
    scene = flexgen.scene_from_dict(
        {
            "flexure": [{"name": "beam", "length": 0.02, "EI": 1e-4, "model": {"modes": 3}}],
            "load": [{"point": "beam.tip", "force": [0.0, -1.0]}],
        }
    )
    with pytest.raises(SceneError, match="flexure.beam.modes and flexure.0.model.modes name"):
        flexgen.sweep(scene, {"flexure.beam.modes": [2], "flexure.0.model.modes": [4]})


@pytest.mark.parametrize(
    "path, value, message",
    [("model.kind", "exact", "the exact model"), ("model.tolerance", 1e-4, "asks for a tolerance")],
)
def test_scenes_a_study_does_not_solve_are_refused(finger, tmp_path, path, value, message):
    if path == "model.tolerance":  # a scene gives modes or a tolerance, not both
        (tmp_path / "f.toml").write_text(FINGER.read_text().replace("modes = 3", ""))
        finger = flexgen.load_scene(tmp_path / "f.toml")
    with pytest.raises(SceneError, match=message):
        flexgen.sweep(finger.with_value(path, value), {"tendon.0.tension": [1.0]}, workers=1)


def test_progress_lines_when_stderr_is_not_a_terminal(finger, capsys, monkeypatch):
    flexgen.sweep(finger, {"tendon.0.tension": [1.0, 2.0]}, workers=1, progress=True)
    assert "sweep: 2/2 cases" in capsys.readouterr().err
    # in this process a line may come after any case, not only when a chunk is done
    monkeypatch.setattr(sweep_module, "PLAIN_EVERY", 0.0)
    flexgen.sweep(finger, {"tendon.0.tension": [1.0, 2.0, 3.0]}, workers=1, progress=True)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(" cases")[0] for line in lines] == [f"sweep: {i}/3" for i in (1, 2, 3)]
    monkeypatch.undo()
    flexgen.sweep(finger, {"tendon.0.tension": [1.0, 2.0]}, workers=1)
    assert capsys.readouterr().err == ""  # the API's default off a terminal: silent


# -- warm starts: a row is the single solve, whatever its neighbours -------------------------


@pytest.fixture(scope="module")
def elastica():
    return flexgen.load_scene(ELASTICA)


def single(scene, row, keys):
    return flexgen.solve(scene.with_values({k: row[k] for k in keys}))


def test_warm_rows_are_the_single_solves_to_the_documented_bounds(finger):
    # a row of small steps (from -0.29 on each case starts from the one before): warm and
    # cold answers differ within the tolerance, so tiny estimates differ by up to 6e-5
    # relative (2.9e-8 against 2.9e-8 + 1.7e-12), within EST_ATOL
    vary = {"tendon.0.tension": [0.0], "load.0.force.1": (0.0, -1.0, 15)}
    df = flexgen.sweep(finger, vary, workers=1)
    results = [single(finger, row, vary) for _, row in df.iterrows()]
    for (_, row), result in zip(df.iterrows(), results):
        assert_row_is_solve(row, result)
    assert (df["iterations"] < [r.iterations for r in results]).sum() >= 8  # warm starts taken


def test_a_row_does_not_take_its_neighbours_branch(elastica):
    # past the Euler load the elastica bends to the side of its lateral force; Newton from the
    # +0.01 answer at -0.01 converges to the +y branch, the load path to the -y one
    vary = {"load.0.force.1": (0.01, -0.01, 2), "load.0.force.0": (-3.0, -3.0, 1)}
    df = flexgen.sweep(elastica, vary, workers=1)
    for _, row in df.iterrows():
        result = single(elastica, row, vary)
        assert_row_is_solve(row, result)
        assert np.sign(row["beam.tip.y"]) == np.sign(row["load.0.force.1"])
    assert df["beam.tip.y"].iloc[1] == pytest.approx(-0.66575, abs=1e-5)


def test_a_grid_across_the_buckling_load_is_its_single_solves(elastica):
    vary = {"load.0.force.0": (-1.0, -6.0, 11), "load.0.force.1": [0.0, 0.01, -0.01]}
    df = flexgen.sweep(elastica, vary, workers=1)
    assert len(df) == 33 and df["converged"].all()
    for _, row in df.iterrows():
        pose = single(elastica, row, vary).points["beam.tip"].pose
        got = [row["beam.tip.x"], row["beam.tip.y"], row["beam.tip.angle"]]
        np.testing.assert_allclose(got, pose, rtol=0, atol=1e-9)
        assert np.sign(got[1]) == np.sign(pose[1])
    lateral = df[df["load.0.force.1"] != 0]
    assert (np.sign(lateral["beam.tip.y"]) == np.sign(lateral["load.0.force.1"])).all()


def test_no_warm_start_from_an_answer_past_a_critical_load(elastica):
    # fx -3.0 to -3.1 is a 3 % change: close; but the -3.0 answer crossed the bifurcation, so
    # the -3.1 case solves along its own load path, as flexgen.solve does
    vary = {"load.0.force.0": [-3.0, -3.1], "load.0.force.1": [0.0]}
    df = flexgen.sweep(elastica, vary, workers=1)
    first, second = (single(elastica, row, vary) for _, row in df.iterrows())
    assert first.critical_load_factors
    assert df["iterations"].iloc[1] == second.iterations
    # what a warm start from the first answer would have been, had it been taken without the
    # path samples that refuse it too (warm_on_path = 0): a few Newton steps
    solver = flexgen.Solver(
        elastica.with_values({"load.0.force.0": -3.0, "load.0.force.1": 0.0}), warm_on_path=0
    )
    warm = solver.solve(loads=[[-3.1, 0.0, 0.0]], q0=first.q)
    assert warm.iterations < second.iterations


def test_design_changes_warm_start_only_when_small(elastica):
    # length 1.0 to 1.1 (10 %): warm, fewer iterations than the single solve; 1.1 to 2.0: cold
    # (a lateral load alone: a load path the warm start's path samples accept)
    vary = {
        "flexure.beam.length": [1.0, 1.1, 2.0],
        "load.0.force.0": [0.0],
        "load.0.force.1": [1.0],
    }
    df = flexgen.sweep(elastica, vary, workers=1)
    results = [single(elastica, row, vary) for _, row in df.iterrows()]
    for (_, row), result in zip(df.iterrows(), results):
        assert_row_is_solve(row, result)
    assert df["iterations"].iloc[1] < results[1].iterations
    assert df["iterations"].iloc[2] == results[2].iterations


@pytest.mark.parametrize(
    "a, b, close",
    [
        ([0.0, 0.01, 0.0], [0.0, -0.01, 0.0], False),  # fy +0.01 to -0.01: 200 %
        ([-3.0, 0.0, 0.0], [-3.5, 0.0, 0.0], True),  # 0.5 <= 0.25 * 3.5; zeros stay close
        ([-1.0, 0.0, 0.0], [-1.5, 0.0, 0.0], False),  # 0.5 > 0.25 * 1.5
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1e-9], False),  # a moment from nothing
        # per group against its largest magnitude: load 1's fy of -4 makes load 0's turn small
        ([0.0, 0.01, 0.0, 0.0, -4.0, 0.0], [0.0, -0.01, 0.0, 0.0, -4.0, 0.0], True),
    ],
)
def test_warm_rule_is_the_controllers(a, b, close):
    from flexgen.warm import WARM_CHANGE, inputs_close

    assert WARM_CHANGE == 0.25  # NAME_WARM_CHANGE of docs/controller.md
    assert inputs_close(a, [10.0], b, [10.0]) is close
    assert inputs_close([0.0] * 3, [4.0], [0.0] * 3, [5.0]) is True  # 1 <= 0.25 * 5
    assert inputs_close([0.0] * 3, [4.0], [0.0] * 3, [6.0]) is False


# -- the same numbers wherever the chunks run ------------------------------------------------------

STUDY = {"flexure.proximal.thickness": [0.22e-3, 0.28e-3], "tendon.0.tension": (0.0, 10.0, 9)}


@pytest.fixture(scope="module")
def in_process(finger):
    return flexgen.sweep(finger, STUDY, workers=1, chunk_size=4)


def test_worker_processes_give_the_in_process_numbers(finger, in_process, monkeypatch):
    monkeypatch.setattr(sweep_module, "START_UP", 0.0)  # the probe would keep it in-process
    monkeypatch.setattr(sweep_module, "START_UP_AGAIN", 0.0)
    df = flexgen.sweep(finger, STUDY, workers=2, chunk_size=4)
    assert sweep_module._pool_workers == 2  # it did use the processes
    pd.testing.assert_frame_equal(df, in_process, check_exact=True)


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port: no clash with a running cluster
        ) as c,
        distributed.Client(c) as client,
    ):
        yield c, client


def test_dask_gives_the_in_process_numbers(finger, in_process, cluster):
    _, client = cluster
    df = flexgen.sweep(finger, STUDY, client=client, chunk_size=4)
    pd.testing.assert_frame_equal(df, in_process, check_exact=True)


def test_cli_scheduler_gives_the_in_process_numbers(finger, cluster, tmp_path):
    c, _ = cluster
    out = tmp_path / "study.parquet"
    args = ["sweep", str(FINGER), *_args(), "--scheduler", c.scheduler_address, "--out", str(out)]
    assert main(args) == 0
    local = flexgen.sweep(
        finger, {"tendon.0.tension": (0.0, 10.0, 3), "load.0.force.1": (0.0, -1.0, 2)}, workers=1
    )
    pd.testing.assert_frame_equal(pd.read_parquet(out), local, check_exact=True, check_dtype=False)


def _args():
    return ["--vary", "tendon.0.tension=0:10:3", "--vary", "load.0.force.1=0:-1:2"]


# -- the command -----------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_cli_writes_the_table(finger, tmp_path, suffix, capsys):
    out = tmp_path / f"study{suffix}"
    assert main(["sweep", str(FINGER), *_args(), "--workers", "1", "--out", str(out)]) == 0
    got = (
        pd.read_parquet(out)
        if suffix == ".parquet"
        else pd.read_csv(out, keep_default_na=False, na_values=[""])
    )
    want = flexgen.sweep(
        finger, {"tendon.0.tension": (0.0, 10.0, 3), "load.0.force.1": (0.0, -1.0, 2)}, workers=1
    )
    assert list(got.columns) == list(want.columns)
    for text in ("reason", "warnings", "notes"):  # "" read as NaN
        got[text] = got[text].astype(object).where(got[text].notna(), "")
    pd.testing.assert_frame_equal(got, want, check_dtype=False, rtol=1e-15)
    assert "sweep: 6 cases, 0 without an equilibrium" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no temporary file left


def test_cli_takes_the_values_themselves(capsys):
    # review: the API took a list of values, the command line only START:STOP:COUNT
    args = ["--vary", "tendon.0.tension=0.5,2,3.5", "--vary", "load.0.force.1=-0.2"]
    assert main(["sweep", str(FINGER), *args, "--no-estimate"]) == 0
    got = pd.read_csv(io.StringIO(capsys.readouterr().out))
    want = flexgen.sweep(
        FINGER, {"tendon.0.tension": [0.5, 2.0, 3.5], "load.0.force.1": [-0.2]}, estimate=False
    )
    assert got["tendon.0.tension"].tolist() == [0.5, 2.0, 3.5]
    np.testing.assert_allclose(got["fingertip.pad.x"], want["fingertip.pad.x"], rtol=1e-15)
    assert main(["sweep", str(FINGER), "--vary", "tendon.0.tension=1,,2"]) == 2
    assert "expected a plain number" in capsys.readouterr().err


def test_cli_summary_counts_one_case_in_the_singular(capsys):
    assert main(["sweep", str(FINGER), "--vary", "tendon.0.tension=1:1:1"]) == 0
    assert "sweep: 1 case, 0 without an equilibrium" in capsys.readouterr().err


def test_cli_prints_csv_without_out(capsys):
    assert main(["sweep", str(FINGER), "--vary", "tendon.0.tension=1:2:2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split(",") == expected_columns(["tendon.0.tension"])
    assert len(lines) == 3


@pytest.mark.parametrize(
    "vary",
    [
        ["--vary", "tendon.0.tension=0:10:5"],
        _args(),
        [
            "--samples",
            "40",
            "--seed",
            "3",
            "--vary",
            "flexure.proximal.thickness=normal:0.25e-3:0.01e-3",
        ],
        # review: a zero spread left outputs equal to rounding, and the histogram's 5 bins over
        # a few ulps were an internal error with the study lost
        ["--samples", "4", "--seed", "1", "--vary", "load.0.force.1=normal:-0.2:0"],
    ],
    ids=["one key", "two keys", "monte carlo", "monte carlo, no spread"],
)
def test_cli_plot_renders(tmp_path, vary):
    plot = tmp_path / "study.png"
    assert (
        main(
            [
                "sweep",
                str(FINGER),
                *vary,
                "--workers",
                "1",
                "--plot",
                str(plot),
                "--out",
                str(tmp_path / "s.csv"),
            ]
        )
        == 0
    )
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and plot.stat().st_size > 10_000


def test_a_plot_where_every_case_failed_spans_the_keys_values(tmp_path, monkeypatch):
    """The failed cases' grey lines are where the key's values are (review: with nothing
    converged, thicknesses of 1e-6 and 2e-6 were drawn on an axis of -0.055..0.055)."""
    import flexgen.sweep_plot as sweep_plot

    key = "flexure.proximal.thickness"
    df = flexgen.sweep(FINGER, {key: [1e-6, 2e-6]}, workers=1)
    assert not df["converged"].any()
    drawn = []
    monkeypatch.setattr(sweep_plot, "_save", lambda fig, path: drawn.append(fig))
    sweep_plot.draw_study(df, [key], False, tmp_path / "study.png")
    [fig] = drawn
    for ax in (a for a in fig.axes if a.get_visible()):
        lo, hi = ax.get_xlim()
        assert lo < 1e-6 and 2e-6 < hi and hi - lo < 1e-5, (lo, hi)


def test_plot_labels_carry_the_scenes_units():
    from flexgen.sweep_plot import outputs

    scene = flexgen.scene_from_dict(
        {
            "units": {"length": "mm", "force": "N"},
            "flexure": [{"name": "beam", "length": "20 mm", "EI": "1e4 N*mm^2"}],
            "load": [{"point": "beam.tip", "force": [0.0, -1.0]}],
        }
    )
    df = flexgen.sweep(scene, {"load.0.force.1": [-1.0, -2.0]}, workers=1)
    labels = dict(outputs(df, scene.units))
    assert labels["beam.tip.x"] == "beam.tip x [mm]"
    assert labels["beam.tip.major"] == "beam.tip compliance major [mm/N]"
    assert dict(outputs(df))["beam.tip.x"] == "beam.tip x"  # plain numbers: no unit named


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["--vary", "flexure.wrist.thickness=1e-4:2e-4:3"],
            "flexure.wrist.thickness: unknown flexure 'wrist'",
        ),
        (["--vary", "tendon.0.tension=0:10:0"], "--vary tendon.0.tension: COUNT must be >= 1"),
        (
            ["--vary", "tendon.0.tension=0:10:two"],
            "--vary tendon.0.tension: COUNT must be an integer",
        ),
        (
            ["--vary", "tendon.0.tension=zero:10:3"],
            "--vary tendon.0.tension: 'zero' is neither a number",
        ),
        (["--vary", "model.modes=1:4:7"], "model.modes: must be an integer"),
        (["--vary", "model.kind=1:2:2"], "model.kind: must be one of"),
        (
            [
                "--samples",
                "200",
                "--seed",
                "1",
                "--vary",
                "flexure.proximal.thickness=normal:0.1e-3:0.1e-3",
            ],
            "flexure.proximal.thickness: flexure[0].thickness: must be a positive",
        ),
        (["--vary", "tendon.0.tension=normal:1:0.1"], "needs --samples N"),
        (["--seed", "1", "--vary", "tendon.0.tension=0:1:2"], "--seed: only with --samples"),
        (
            ["--vary", "tendon.0.tension=0:1:2", "--out", "study.xlsx"],
            "--out: the file must end in .parquet or .csv",
        ),
        (
            ["--vary", "tendon.0.tension=0:1:2", "--plot", "study.gif"],
            "--plot: the file must end in .png, .svg or .pdf",
        ),
        (
            ["--vary", "load.0.force.1=0:-0.5:2", "--vary", "load.0.force.01=-1:-1:1"],
            "load.0.force.1 and load.0.force.01 name the same value",
        ),
        (["--vary", "model.tolerance=1e-4:1e-3:2"], "give modes instead"),
        (["--vary", "flexure.distal.tolerance=1e-4:1e-3:2"], "give modes instead"),
        # review: Python's float() and int() read "1_0", a scene's numbers never do
        (["--vary", "tendon.0.tension=1_0:20:3"], "expected a plain number"),
        (["--vary", "tendon.0.tension=0:10:1_0"], "COUNT must be an integer"),
    ],
)
def test_cli_bad_input_is_exit_2_and_writes_nothing(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    out = ["--out", "study.csv"] if "--out" not in args else []
    assert main(["sweep", str(FINGER), *args, *out]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_cli_scheduler_without_dask_names_the_extra(monkeypatch, tmp_path, capsys):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "distributed" else real(name, *a),
    )
    out = tmp_path / "s.csv"
    code = main(
        [
            "sweep",
            str(FINGER),
            "--vary",
            "tendon.0.tension=0:1:2",
            "--scheduler",
            "tcp://127.0.0.1:1",
            "--out",
            str(out),
        ]
    )
    assert code == 1  # a missing extra is the install, not the input (as flexgen plot's)
    assert "pip install 'flexgen[cluster]'" in capsys.readouterr().err
    assert not out.exists()


def test_cli_help_shows_an_example(capsys):
    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    text = capsys.readouterr().out
    assert "--vary tendon.0.tension=0:10:11" in text and "normal:0.25e-3:0.01e-3" in text


@pytest.mark.parametrize("address", ["notanaddress", "tcp://host:notaport", "tcp://host", ""])
def test_cli_malformed_scheduler_address_is_exit_2(tmp_path, capsys, address):
    pytest.importorskip("distributed")
    out = tmp_path / "s.csv"
    args = ["sweep", str(FINGER), "--vary", "tendon.0.tension=0:1:2", "--out", str(out)]
    assert main([*args, "--scheduler", address]) == 2
    err = capsys.readouterr().err
    assert f"--scheduler: not a scheduler address {address!r}" in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


# -- writing the outputs -----------------------------------------------------------------------


def _limited_run(tmp_path, limit, *outputs):
    """`flexgen sweep` in a process whose files may not grow past ``limit`` bytes (as on a full
    disk: the write fails with EFBIG); (exit code, stderr)."""
    import subprocess

    resource = pytest.importorskip("resource")

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    args = [sys.executable, "-m", "flexgen", "sweep", str(FINGER), *_args(), "--workers", "1"]
    run = subprocess.run(
        [*args, *outputs], cwd=tmp_path, preexec_fn=limited, capture_output=True, text=True
    )
    return run.returncode, run.stderr


def _left(tmp_path):
    return sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))


@pytest.mark.parametrize(
    "outputs, failed",
    [
        # the plot alone (the table goes to stdout)
        (["--plot", "only.png"], "only.png"),
        # the table (2.4 kB) fits, the plot (~150 kB) does not: the plot named, the table gone
        (["--out", "a/b/t.csv", "--plot", "a/b/t.png"], "a/b/t.png"),
        # the folders made for the table are removed; the one that was there stays
        (["--out", "keep/new/sub/t.csv"], "keep/new/sub/t.csv"),
    ],
)
def test_cli_failed_write_names_the_file_and_leaves_nothing(tmp_path, outputs, failed):
    (tmp_path / "keep").mkdir()
    limit = 20_000 if "a/b/t.png" in outputs else 1_000
    code, err = _limited_run(tmp_path, limit, *outputs)
    assert code == 1
    lines = [line for line in err.splitlines() if not line.startswith("sweep:")]
    assert lines == [f"flexgen: cannot write {failed}: File too large"]
    assert _left(tmp_path) == ["keep"]


def test_cli_table_gets_a_new_files_mode(tmp_path):
    out = tmp_path / "t.csv"
    old = os.umask(0o027)
    try:
        assert (
            main(["sweep", str(FINGER), "--vary", "tendon.0.tension=1:2:2", "--out", str(out)]) == 0
        )
        reference = tmp_path / "reference"
        reference.write_text("")  # what open() makes under the same umask
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == stat.S_IMODE(reference.stat().st_mode) == 0o640


@pytest.mark.parametrize("key", ["estimate", "stress"])
def test_switches_must_be_booleans(finger, key):
    """estimate="no" is truthy: a switch that is not True or False is a one-line TypeError
    naming it, before anything is solved."""
    with pytest.raises(TypeError, match=rf"^{key}: must be True or False"):
        flexgen.sweep(finger, {"load.0.force.1": [0.0, -0.1]}, workers=1, **{key: "no"})


def test_a_flexures_model_key_in_both_spellings_is_one_value(finger):
    """flexure.X.modes and flexure.X.model.modes name one value (the scene refuses it given
    twice): refused before solving, as every alias pair."""
    with pytest.raises(SceneError, match="name the same value"):
        flexgen.sweep(
            finger,
            {"flexure.proximal.modes": [2, 3], "flexure.proximal.model.modes": [2, 3]},
            workers=1,
        )


def test_rows_where_the_load_path_jumps_between_neighbours_are_the_solves():
    """A thin finger whose load path from the unloaded state reaches another branch from
    F = -0.556 N on, while the neighbour's branch (F = -0.444 N) still holds the load: found by
    review, those rows sat on the neighbour's branch, 140 mm from flexgen.solve's answer. The
    warm start's path samples (settings.warm_on_path) send them cold."""
    scene = flexgen.load_scene(ROOT / "examples" / "two_link_finger.toml").with_values(
        {"flexure.proximal.length": 0.0225, "flexure.proximal.thickness": 0.0002}
    )
    vary = {"load.0.force.1": list(np.linspace(0.0, -1.0, 10))}
    df = flexgen.sweep(scene, vary, workers=1)
    for _, row in df.iterrows():
        assert_row_is_solve(row, single(scene, row, vary))


@pytest.mark.skipif(sys.platform == "win32", reason="process groups and SIGINT: POSIX")
def test_ctrl_c_stops_a_sweep_on_worker_processes(tmp_path):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) on a study running on
    worker processes: one line, exit 130, no output file, no process left. Found by review:
    the workers took the interrupt as a chunk's error and went on with every queued chunk while
    the parent waited for them at exit (a second Ctrl-C then hung it for good)."""
    import signal
    import subprocess
    import time

    text = (ROOT / "examples" / "two_link_finger.toml").read_text()
    scene = tmp_path / "finger_poly.toml"  # the poly kernel: most cases fail, slowly
    scene.write_text(text.replace("[model]\n", '[model]\nkernel = "poly"\n', 1))
    out = tmp_path / "study.parquet"
    cmd = [sys.executable, "-m", "flexgen", "sweep", str(scene), "--workers", "2",
           "--vary", "tendon.0.tension=20:60:100", "--vary", "load.0.force.1=0:-2:1000",
           "--out", str(out)]  # fmt: skip
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    time.sleep(4.0)  # the workers started and busy (the whole study takes minutes)
    assert proc.poll() is None, proc.communicate()
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("the sweep went on after Ctrl-C")
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "flexgen: interrupted"
    assert "Traceback" not in err and not out.exists()
    for _ in range(100):  # no process of the group is left (the fork server exits with it)
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("a worker process outlived the interrupted sweep by 10 s")


@pytest.mark.skipif(sys.platform == "win32", reason="the fork server: POSIX")
def test_workers_ignore_ctrl_c_from_birth_and_die_quietly_when_the_study_is_gone(monkeypatch):
    """Review: Ctrl-C while a worker was still starting printed its traceback under the one-line
    "interrupted" (a KeyboardInterrupt before the pool's initializer, or the study's semaphores
    gone). The fork server's preload makes every child ignore SIGINT and silences exactly the
    second case; any other error still prints."""
    import importlib
    import multiprocessing.forkserver
    import subprocess

    study = importlib.import_module("flexgen.sweep")  # (flexgen.sweep is also the function)
    study.OWN_PROCESS = False  # (an in-process `flexgen sweep` of another test may have set it)
    # the preload list only: no fork server started in this process with the command's preload
    monkeypatch.setattr(study, "_start_fork_server_deaf", lambda: None)
    study._context()  # a program's own fork server: left as it is (review)
    preload = multiprocessing.forkserver._forkserver._preload_modules
    assert "flexgen._forkserver_preload" not in preload
    try:
        study.OWN_PROCESS = True  # as the flexgen sweep command says
        study._context()
        preload = multiprocessing.forkserver._forkserver._preload_modules
        assert preload[0] == "flexgen._forkserver_preload"  # before the slow imports
    finally:
        study.OWN_PROCESS = False
        study._context()
    probe = r"""if True:
        import signal, sys
        import flexgen._forkserver_preload
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        source = "def __setstate__():\n    raise FileNotFoundError(2, 'gone')\n"
        code = compile(source, "/usr/lib/python3/multiprocessing/synchronize.py", "exec")
        space = {}
        exec(code, space)
        for call in (space["__setstate__"], lambda: 1 / 0):
            try:
                call()
            except Exception:
                sys.excepthook(*sys.exc_info())
    """
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "ZeroDivisionError" in run.stderr and "FileNotFoundError" not in run.stderr


@pytest.mark.skipif(sys.platform == "win32", reason="the fork server: POSIX")
def test_the_fork_server_survives_ctrl_c_while_it_imports_flexgen():
    """Review: Ctrl-C about 1 s into a `flexgen sweep` on workers printed the fork server's
    KeyboardInterrupt traceback: the server was still importing flexgen (the package, before
    its preload module ignores SIGINT). The command's fork server starts with SIGINT blocked
    until then: interrupts while it imports are dropped, the server lives and serves the study,
    and this process's mask is as before."""
    import subprocess

    probe = r"""if True:
        import os, signal, sys, time
        from multiprocessing import forkserver
        import flexgen
        study = sys.modules["flexgen.sweep"]
        if __name__ == "__main__":
            study.own_process()  # as the flexgen sweep command says
            study._context()
            assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, set())
            pid = forkserver._forkserver._forkserver_pid
            assert pid is not None, "no fork server started"
            for _ in range(6):  # while it imports flexgen (about 0.3 s), then after
                os.kill(pid, signal.SIGINT)
                time.sleep(0.1)
            assert os.waitpid(pid, os.WNOHANG) == (0, 0), "the fork server died"
            scene = flexgen.load_scene(sys.argv[1])
            vary = {"tendon.0.tension": [1.0, 2.0, 3.0, 4.0]}
            df = flexgen.sweep(scene, vary, workers=2, chunk_size=2)
            assert os.waitpid(pid, os.WNOHANG) == (0, 0), "the fork server died"
            ref = flexgen.sweep(scene, vary, workers=1)
            assert df["fingertip.pad.x"].tolist() == ref["fingertip.pad.x"].tolist()
    """
    run = subprocess.run(
        [sys.executable, "-c", probe, str(FINGER)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr and "KeyboardInterrupt" not in run.stderr


def test_workers_asked_for_are_used_without_the_probe(monkeypatch):
    """workers=N (N >= 2) runs N processes as asked; only the default probes whether the study
    is worth them (found by review: --workers 2 was silently one process)."""
    import importlib

    sweep_module = importlib.import_module("flexgen.sweep")  # flexgen.sweep is the function

    def no_probe(chunks, probes=5):
        raise AssertionError("the probe ran for workers=2")

    monkeypatch.setattr(sweep_module, "_serial_time", no_probe)
    scene = flexgen.load_scene(FINGER)
    vary = {"load.0.force.1": [-0.1, -0.2, -0.3, -0.4]}
    df = flexgen.sweep(scene, vary, workers=2, chunk_size=2)
    assert sweep_module._pool_workers == 2
    serial = flexgen.sweep(scene, vary, workers=1, chunk_size=2)
    assert df.equals(serial)


def test_count_keys_are_integer_columns():
    """A study over a count (modes, elements) lists it as integers, as the scene gives it (the
    table showed 2.0, 3.0: review)."""
    scene = flexgen.load_scene(ROOT / "examples" / "cantilever_tip_load.toml")
    df = flexgen.sweep(scene, {"model.modes": [2, 3, 4]}, workers=1)
    assert df["model.modes"].dtype == np.int64 and df["model.modes"].tolist() == [2, 3, 4]
    assert df["converged"].all()


def test_a_row_carries_the_warnings_and_notes_of_its_solve(finger):
    # review: a column near its Euler load (solve warns the compliance amplifies the model's
    # error 319x), one past it (a bifurcation note) and the finger bent past its kernels'
    # certified range (no accuracy claimed) were plain rows: only the estimate was kept
    column = flexgen.scene_from_dict(
        {
            "flexure": [{"name": "a", "length": 1.0, "EI": 1.0}],
            "load": [{"point": "a.tip", "force": [-1.0, 0.0]}],
            "output": {"points": ["a.tip"]},
        }
    )
    df = flexgen.sweep(column, {"load.0.force.0": [-1.0, -2.46, -3.0]}, workers=1)
    for row, fx in zip(df.to_dict("records"), (-1.0, -2.46, -3.0)):
        assert_row_is_solve(row, flexgen.solve(column.with_value("load.0.force.0", fx)))
    assert df["warnings"].tolist()[0] == "" and df["notes"].tolist()[0] == ""
    assert "near a critical load" in df["warnings"].tolist()[1]
    assert "bifurcation" in df["notes"].tolist()[2]
    df = flexgen.sweep(finger, {"tendon.0.tension": [60.0]}, workers=1)
    assert "no accuracy is claimed" in df["warnings"].tolist()[0]
    assert_row_is_solve(
        df.to_dict("records")[0], flexgen.solve(finger.with_value("tendon.0.tension", 60.0))
    )


def test_quiet_is_true_exactly_where_the_result_says_nothing(finger):
    """Solver.quiet (the rows' fast path) against the Result it stands for: quiet exactly where
    _result(stress=False) has no warning and no note, over answers with each source of one
    (a bifurcation note, a kernel switch, a scene note, a scene warning)."""
    from flexgen.solver import Solver

    column = {
        "flexure": [{"name": "a", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "a.tip", "force": [-1.0, 0.0]}],
        "output": {"points": ["a.tip"]},
    }
    thick = {**column, "flexure": [{"name": "a", "length": 1.0, "EI": 1.0, "thickness": 0.5}]}
    turned = {**column, "flexure": [{"name": "a", "length": 1.0, "EI": 1.0, "at": [0, 0, 7.0]}]}
    cases = [
        (finger, {}),
        (finger, {"tendon.0.tension": 60.0}),
        (flexgen.scene_from_dict(column), {}),
        (flexgen.scene_from_dict(column), {"load.0.force.0": -3.0}),
        (flexgen.scene_from_dict(thick), {}),
        (flexgen.scene_from_dict(turned), {}),
    ]
    seen = set()
    for scene, changes in cases:
        for path, value in changes.items():
            scene = scene.with_value(path, value)
        solver = Solver(scene)
        status = solver.run()
        est = solver.estimator().estimate(solver)
        result = solver._result(status, est, stress=False)
        says = bool(result.warnings or result.notes)
        assert solver.quiet(est) == (not says), (changes, result.warnings, result.notes)
        seen.add(says)
    assert seen == {True, False}


def test_a_script_without_the_main_guard_is_told_to_add_it(tmp_path):
    """A script starting a study on worker processes without `if __name__ == "__main__":`
    (each worker imports it and started the study again: 86 lines of multiprocessing's
    bootstrapping errors, then BrokenProcessPool; review): the error names the guard."""
    import subprocess

    script = tmp_path / "study.py"
    script.write_text(
        "import flexgen\n"
        f"flexgen.sweep({str(FINGER)!r}, {{'tendon.0.tension': [1.0, 2.0, 3.0, 4.0]}},\n"
        "              workers=2, chunk_size=2)\n"
    )
    proc = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("flexgen.sweep.WorkerDied: ") and '__name__ == "__main__"' in last
    assert "bootstrapping phase" not in proc.stderr


def test_cli_chunk_size_is_the_studys(finger, capsys):
    """--chunk-size N is flexgen.sweep's chunk_size (a short study of slow cases can then use
    --workers: one chunk runs in this process)."""
    assert main(["sweep", str(FINGER), "--vary", "tendon.0.tension=1:4:4", "--chunk-size", "2",
                 "--workers", "2"]) == 0  # fmt: skip
    got = pd.read_csv(io.StringIO(capsys.readouterr().out), keep_default_na=False)
    want = flexgen.sweep(finger, {"tendon.0.tension": (1.0, 4.0, 4)}, workers=1, chunk_size=2)
    np.testing.assert_allclose(got["fingertip.pad.x"], want["fingertip.pad.x"], rtol=1e-15)
    assert (
        main(["sweep", str(FINGER), "--vary", "tendon.0.tension=1:4:4", "--chunk-size", "0"]) == 2
    )


def test_digits_that_name_another_flexure_are_ambiguous():
    """Flexures named "1" and "2": flexure.1 changed "2" (index 1) while the columns, named by
    flexure, showed "1" unchanged (review). Now an error naming both; the bracket form, as
    messages write keys, is always an index."""
    src = {
        "flexure": [
            {"name": "1", "length": 1.0, "EI": 1.0},
            {"name": "2", "length": 1.0, "EI": 1.0},
        ],
        "load": [{"point": "2.tip", "force": [0.0, -1.0]}],
    }
    scene = flexgen.scene_from_dict(src)
    with pytest.raises(flexgen.SceneError, match=r"write flexure\[0\] or flexure\[1\]"):
        scene.with_value("flexure.1.length", 2.0)
    assert [f.length for f in scene.with_value("flexure[1].length", 2.0).flexures] == [1.0, 2.0]
    assert [f.length for f in scene.with_value("flexure[0].length", 2.0).flexures] == [2.0, 1.0]
    assert scene.with_value("load[0].force[1]", -2.0).loads[0].force[1] == -2.0
    df = flexgen.sweep(scene, {"flexure[1].length": [1.0, 1.5]}, workers=1)
    assert list(df["flexure[1].length"]) == [1.0, 1.5]
    assert df["2.tip.y"].iloc[1] < df["2.tip.y"].iloc[0]


@pytest.mark.parametrize("values", [[10**400], (0, 10**400, 2), (-1e308, 1e308, 3)])
def test_values_beyond_a_floats_range_are_scene_errors(finger, values, recwarn):
    # review: an int of 401 digits raised a bare OverflowError; a grid whose step overflows
    # printed NumPy's RuntimeWarnings before the one-line message
    with pytest.raises(SceneError, match=r"^tendon.0.tension: "):
        flexgen.sweep(finger, {"tendon.0.tension": values}, workers=1)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


def test_a_rows_checks_read_its_own_loads():
    # review of the change: a study of load keys checked each row against the scene's own
    # loads: a moment at a prb flexure and 5000 N (units) left the rows' warnings empty, where
    # flexgen.Solver and flexgen.solve warn
    beam = {
        "flexure": [{"name": "beam", "length": 1.0, "EI": 1.0}],
        "load": [{"point": "beam.tip", "force": [0.0, -0.5]}],
    }
    prb = flexgen.scene_from_dict({**beam, "model": {"kind": "prb"}})
    df = flexgen.sweep(prb, {"load.0.moment": [0.0, 0.5]}, workers=1, estimate=False)
    assert df["warnings"].tolist()[0] == ""
    assert "pseudo-rigid-body" in df["warnings"].tolist()[1]
    scm = flexgen.scene_from_dict(beam)
    df = flexgen.sweep(scm, {"load.0.force.1": [-2.0, -5000.0]}, workers=1, estimate=False)
    assert df["warnings"].tolist()[0] == ""
    assert "load level 5e+03" in df["warnings"].tolist()[1]
    for row, fy in zip(df.to_dict("records"), (-2.0, -5000.0)):
        solved = flexgen.solve(scm.with_value("load.0.force.1", fy), estimate=False)
        assert row["warnings"] == "\n".join(solved.warnings)


@pytest.mark.parametrize(
    "reply, message",
    [
        (None, "no Dask scheduler answered at"),  # accepts, stays silent (a dashboard's port)
        (b"HTTP/1.1 400 Bad Request\r\n\r\n", "no Dask scheduler at"),  # answers, not Dask
    ],
)
def test_a_port_that_is_no_scheduler_is_one_line_exit_1(reply, message, tmp_path):
    """Review: --scheduler at a port that accepted and stayed silent hung for ever (Client's
    timeout bounds the connection, not the handshake), and one that answered with other bytes
    was 'internal error: MemoryError: Unable to allocate 3.07 EiB' (its reply read as a
    length)."""
    pytest.importorskip("distributed")
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]
    held = []

    def serve():
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            held.append(conn)
            if reply is not None:
                conn.sendall(reply)

    threading.Thread(target=serve, daemon=True).start()
    code = (
        "import sys, flexgen.commands.sweep as s; s.CONNECT_DEADLINE = 3.0\n"
        "from flexgen.cli import main\n"
        f"sys.exit(main(['sweep', {str(FINGER)!r}, '--vary', 'tendon.0.tension=0:1:2', "
        f"'--scheduler', 'tcp://127.0.0.1:{port}']))"
    )
    try:
        run = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, cwd=tmp_path
        )
    finally:
        server.close()
        for conn in held:
            conn.close()
    assert run.returncode == 1, run.stderr
    assert run.stderr.count("\n") == 1 and message in run.stderr, run.stderr
    assert run.stdout == ""
