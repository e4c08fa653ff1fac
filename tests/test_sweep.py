"""flexgen.sweep, Scene.with_value and `flexgen sweep` (docs/sweep.md)."""

from __future__ import annotations

import dataclasses
import itertools
import math
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
sweep_module = sys.modules["flexgen.sweep"]


@pytest.fixture(scope="module")
def finger():
    return flexgen.load_scene(FINGER)


def expected_columns(keys):
    cols = list(keys) + ["converged", "stable", "iterations", "reason"]
    cols += [f"{p}.{c}" for p in POINTS for c in POINT_COLUMNS]
    cols += [f"{f}.{c}" for f in FLEXURES for c in ("max_stress", "safety_factor")]
    return cols


def assert_row_is_solve(row, result):
    """The row's numbers are those of ``result`` (a cold flexgen.solve of the same scene)."""
    assert row["converged"] == result.converged
    assert row["stable"] == result.stable
    for ref, pr in result.points.items():
        got = [row[f"{ref}.{c}"] for c in ("x", "y", "angle")]
        np.testing.assert_allclose(got, pr.pose, rtol=RTOL, atol=RTOL * 0.1)
        ell = pr.ellipse
        got = [row[f"{ref}.major"], row[f"{ref}.minor"]]
        np.testing.assert_allclose(
            got, [ell["major"], ell["minor"]], rtol=0, atol=CRTOL * ell["major"]
        )
        assert row[f"{ref}.ellipse_angle"] == pytest.approx(ell["angle"], abs=1e-8)
        # the estimate is a difference of two answers: the iterates' difference shows there
        est = max(pr.error_estimate.values())
        assert row[f"{ref}.error_estimate"] == pytest.approx(est, rel=1e-6, abs=1e-12)
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
        ("model.modes", 2.5, "model.modes: model.modes: must be an integer in [1, 8]"),
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
        ({}, {}, "vary: expected"),
    ],
)
def test_bad_studies_are_one_line_errors_before_solving(finger, vary, kwargs, message):
    with pytest.raises(SceneError) as err:
        flexgen.sweep(finger, vary, workers=1, **kwargs)
    assert message in str(err.value)


@pytest.mark.parametrize(
    "path, value, message",
    [("model.kind", "exact", "the exact model"), ("model.tolerance", 1e-4, "asks for a tolerance")],
)
def test_scenes_a_study_does_not_solve_are_refused(finger, path, value, message):
    with pytest.raises(SceneError, match=message):
        flexgen.sweep(finger.with_value(path, value), {"tendon.0.tension": [1.0]}, workers=1)


def test_progress_lines_when_stderr_is_not_a_terminal(finger, capsys):
    flexgen.sweep(finger, {"tendon.0.tension": [1.0, 2.0]}, workers=1, progress=True)
    assert "sweep: 2/2 cases" in capsys.readouterr().err
    flexgen.sweep(finger, {"tendon.0.tension": [1.0, 2.0]}, workers=1)
    assert capsys.readouterr().err == ""  # the API's default off a terminal: silent


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
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
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
    got["reason"] = got["reason"].astype(object).where(got["reason"].notna(), "")  # "" read as NaN
    pd.testing.assert_frame_equal(got, want, check_dtype=False, rtol=1e-15)
    assert "sweep: 6 cases, 0 without an equilibrium" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no temporary file left


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
    ],
    ids=["one key", "two keys", "monte carlo"],
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
        (["--vary", "model.modes=1:4:7"], "model.modes: model.modes: must be an integer"),
        (["--vary", "model.kind=1:2:2"], "model.kind: model.kind: must be one of"),
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
    assert code == 2
    assert "pip install 'flexgen[cluster]'" in capsys.readouterr().err
    assert not out.exists()


def test_cli_help_shows_an_example(capsys):
    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    text = capsys.readouterr().out
    assert "--vary tendon.0.tension=0:10:11" in text and "normal:0.25e-3:0.01e-3" in text
