"""The arcsim Python package against the arcsim command: same results, located errors, numpy
columns, the GIL released, Ctrl-C in sweeps.

Run from the repository root with the wheel installed: ARCSIM_BIN names the `arcsim` binary to
compare with (the Rust test `crates/cli/tests/python.rs` builds both and runs this suite);
ARCSIM_TEST_DICOM an RT Ion Plan file to import, ARCSIM_TEST_DICOM_WARNED one whose import warns
(a GantryAngle of 360).
"""

import _thread
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import arcsim

BIN = os.environ.get("ARCSIM_BIN", "target/debug/arcsim")
ATOM_REFERENCE = Path("reference/atom-article-cases.json")


def cli(*args):
    """Runs the arcsim command from the repository root; returns (exit code, stdout, stderr)."""
    p = subprocess.run([BIN, *args], capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def cli_json(tmp_path, *args):
    out = tmp_path / "result.json"
    code, _, err = cli(*args, "--json", str(out))
    assert code == 0, err
    return json.loads(out.read_text())


# (plan, schedule, motion): free motion only where it takes well under a second.
CASES = [
    ("plans/prostate.json", "optimal", None),
    ("plans/prostate.json", "scan", None),
    ("plans/lung.json", "optimal", "constant"),
    ("plans/lung.json", "step-and-shoot", None),
    ("plans/head-neck.json", "scan", "constant"),
    ("plans/two-arc.json", "optimal", "constant"),
    ("plans/two-arc.json", "optimal", "one-speed"),
]


@pytest.mark.parametrize("plan,schedule,motion", CASES)
def test_simulate_equals_the_cli(tmp_path, plan, schedule, motion):
    args = ["simulate", plan, "--schedule", schedule]
    if motion:
        args += ["--motion", motion]
    expected = cli_json(tmp_path, *args)
    d = arcsim.simulate(arcsim.load_plan(plan), schedule=schedule, motion=motion)
    assert d.total_s == pytest.approx(expected["total_s"], rel=1e-12)
    got = json.loads(d.to_json())
    assert got == expected
    assert d.breakdown == expected["breakdown"]
    assert d.limiter_counts == expected["limiter_counts"]
    assert d.options == (schedule, expected["options"]["motion"], "rest")
    assert d.switching == expected["switching"]


def test_certify_equals_the_cli(tmp_path):
    expected = cli_json(tmp_path, "simulate", "plans/lung.json", "--motion", "constant", "--certify")
    d = arcsim.simulate(arcsim.load_plan("plans/lung.json"), motion="constant")
    c = d.certify()
    assert c == expected["certificate"]
    assert 0 < c["lower_bound_s"] <= d.total_s
    assert c["gap_s"] == pytest.approx(d.total_s - c["lower_bound_s"], rel=1e-12)
    free_expected = cli_json(tmp_path, "simulate", "plans/lung.json", "--motion", "free", "--certify")
    f = arcsim.simulate(arcsim.load_plan("plans/lung.json"), motion="free").certify()
    assert f == free_expected["certificate"]
    assert 0 < f["lower_bound_s"] <= free_expected["total_s"]


def test_spots_equal_the_cli_on_a_scanning_machine(tmp_path):
    machine = "scenarios/machine-opentps-pbs.json"
    spots_csv = tmp_path / "spots.csv"
    expected = cli_json(tmp_path, "simulate", "plans/lung.json", "--machine", machine,
                        "--motion", "constant", "--spots", str(spots_csv))
    d = arcsim.simulate(arcsim.load_plan("plans/lung.json"), arcsim.load_machine(machine),
                        motion="constant")
    s = d.spots
    want = expected["spots"]
    assert len(s["mu"]) == len(want) > 100
    for key in ("layer_index", "spot", "painting", "x_mm", "mu", "t_start_s", "angle_end_deg",
                "burst", "spill"):
        assert list(s[key]) == [w[key] for w in want], key
    lines = spots_csv.read_text().splitlines()
    assert len(lines) == len(want) + 1
    b = d.breakdown
    assert b["spot_irradiation_s"] + b["scanning_s"] == pytest.approx(b["beam_on_s"], rel=1e-12)
    assert b["burst_switching_s"] == b["spill_waiting_s"] == 0.0
    assert d.to_pandas("spots").shape[0] == len(want)


def test_spills_equal_the_cli_on_a_synchrotron(tmp_path):
    machine = "scenarios/machine-probeat-v5-like-mee.json"
    expected = cli_json(tmp_path, "simulate", "plans/lung.json", "--machine", machine,
                        "--motion", "constant", "--spots", str(tmp_path / "spots.csv"))
    d = arcsim.simulate(arcsim.load_plan("plans/lung.json"), arcsim.load_machine(machine),
                        motion="constant")
    assert list(d.spots["spill"]) == [w["spill"] for w in expected["spots"]]
    assert d.breakdown == expected["breakdown"]
    assert d.breakdown["spill_waiting_s"] > 0.0


def test_machine_file_period_and_limits_equal_the_cli(tmp_path):
    machine = "scenarios/machine-fast.json"
    expected = cli_json(
        tmp_path, "simulate", "plans/two-arc.json", "--machine", machine,
        "--schedule", "scan", "--period", "0.004",
    )
    d = arcsim.simulate(
        arcsim.load_plan("plans/two-arc.json"), arcsim.load_machine(machine),
        schedule="scan", period_s=0.004,
    )
    assert json.loads(d.to_json()) == expected
    assert d.notes == expected["notes"] and d.options[1] == "constant"

    faster = arcsim.Machine.atom().with_limits(jerk=1.0, accel=0.75, speed=6)
    assert (faster.jerk, faster.accel, faster.speed) == (1.0, 0.75, 6.0)
    mfile = tmp_path / "m.json"
    mfile.write_text(faster.to_json())
    expected = cli_json(tmp_path, "simulate", "plans/prostate.json", "--machine", str(mfile),
                        "--schedule", "scan", "--motion", "constant")
    d = arcsim.simulate(arcsim.load_plan("plans/prostate.json"), faster, "scan", motion="constant")
    assert d.total_s == pytest.approx(expected["total_s"], rel=1e-12)


def test_dicom_import_warnings_are_python_warnings():
    dcm = os.environ.get("ARCSIM_TEST_DICOM_WARNED")
    if not dcm:
        pytest.skip("ARCSIM_TEST_DICOM_WARNED not set (the Rust runner writes a fixture)")
    with pytest.warns(UserWarning, match=r"GantryAngle \(300A,011E\) 360 .* read as 0") as caught:
        plan = arcsim.load_plan(dcm)
    # The warning names the file, as the CLI's does.
    assert any(dcm in str(w.message) for w in caught)
    code, _, err = cli("validate", dcm)
    assert code == 0, err
    assert "read as 0" in err
    assert plan.layers == 3


def test_dicom_round_trip(tmp_path):
    dcm = os.environ.get("ARCSIM_TEST_DICOM")
    if not dcm:
        pytest.skip("ARCSIM_TEST_DICOM not set (the Rust runner writes a fixture)")
    plan = arcsim.load_plan(dcm)
    out = tmp_path / "imported.json"
    code, _, err = cli("import", dcm, "-o", str(out))
    assert code == 0, err
    assert plan.to_json() == out.read_text()
    again = arcsim.load_plan(out)
    assert again.to_json() == plan.to_json()
    a = arcsim.simulate(plan, schedule="scan", motion="constant")
    b = arcsim.simulate(again, schedule="scan", motion="constant")
    assert a.total_s == b.total_s
    expected = cli_json(tmp_path, "simulate", dcm, "--schedule", "scan", "--motion", "constant")
    assert json.loads(a.to_json()) == expected


def test_errors_are_located_python_exceptions(tmp_path):
    bad = tmp_path / "bad.json"
    plan = json.loads(Path("plans/prostate.json").read_text())
    plan["arcs"][0]["control_points"][3]["layers"][0]["energy_mev"] = -5
    bad.write_text(json.dumps(plan))
    with pytest.raises(arcsim.PlanError) as e:
        arcsim.load_plan(bad)
    code, _, err = cli("validate", str(bad))
    assert code == 1
    assert str(e.value) in err  # the CLI's message, word for word
    assert "control point 3" in str(e.value) and "energy_mev" in str(e.value)
    assert isinstance(e.value, ValueError)

    with pytest.raises(arcsim.PlanError, match="cannot read"):
        arcsim.load_plan(tmp_path / "missing.json")
    with pytest.raises(arcsim.PlanError, match="max_jerk_deg_per_s3"):
        arcsim.Machine.atom().with_limits(jerk=-1)
    with pytest.raises(ValueError, match="schedule"):
        arcsim.simulate(arcsim.load_plan("plans/lung.json"), schedule="fastest")
    with pytest.raises(ValueError, match="servo period"):
        arcsim.simulate(arcsim.load_plan("plans/lung.json"), period_s=5.0)
    with pytest.raises(arcsim.ProfileError):
        arcsim.profile(2, 1.5, 0.5, 0.5, 0.5, 5)  # too short to slow down
    with pytest.raises(arcsim.SweepError, match="format"):
        arcsim.sweep({"format": "nope"})
    with pytest.raises(ValueError, match="switching_times_s"):
        arcsim.Plan.from_arrays([0, 2, 4], [1, 1, 1], 100, switching_times_s=[1])
    # Implausible values: warnings, or an error with strict.
    slow = arcsim.Machine.atom().with_limits(jerk=500)
    with pytest.warns(UserWarning, match="jerk"):
        arcsim.simulate(arcsim.load_plan("plans/lung.json"), slow, "scan", motion="constant")
    with pytest.raises(arcsim.PlanError, match="strict"):
        arcsim.simulate(arcsim.load_plan("plans/lung.json"), slow, "scan", strict=True)


def test_columns_and_timeline_are_numpy():
    d = arcsim.simulate(arcsim.load_plan("plans/prostate.json"), schedule="scan", motion="constant")
    layers = d.layers
    n = arcsim.load_plan("plans/prostate.json").layers
    for key, dtype in [("angle_deg", np.float64), ("speed_deg_per_s", np.float64),
                       ("index", np.int64), ("control_point", np.int64)]:
        assert layers[key].dtype == dtype and layers[key].shape == (n,), key
    assert len(layers["transition_limited_by"]) == n
    assert d.transitions["index"].shape == (n - 1,)
    # Irradiation times add up to the beam-on time.
    assert layers["irradiation_s"].sum() == pytest.approx(d.breakdown["beam_on_s"], rel=1e-12)

    tl = d.timeline(dt=0.05)
    m = len(tl["t_s"])
    assert all(v.shape == (m,) for v in tl.values())
    assert tl["beam_on"].dtype == np.bool_ and tl["layer"].dtype == np.int64
    assert tl["t_s"][-1] == pytest.approx(d.total_s)
    assert np.all(np.abs(tl["speed_deg_per_s"]) <= 5 + 1e-9)
    assert np.all(np.isnan(tl["energy_mev"][~tl["beam_on"]]))
    # While a layer is irradiated (constant motion), the gantry moves at its speed.
    on = tl["layer"] >= 0
    assert np.allclose(np.abs(tl["speed_deg_per_s"][on]),
                       layers["speed_deg_per_s"][tl["layer"][on]], atol=1e-9)
    pd = pytest.importorskip("pandas")
    df = d.to_pandas()
    assert isinstance(df, pd.DataFrame) and len(df) == n
    assert len(d.to_pandas("transitions")) == n - 1


def test_to_log_equals_the_cli(tmp_path):
    machine = "scenarios/machine-opentps-pbs.json"
    cli_log = tmp_path / "cli.csv"
    code, _, err = cli("simulate", "plans/lung.json", "--machine", machine, "--motion", "constant",
                       "--log", str(cli_log), "--log-period", "0.05", "--angle-noise-deg", "0.02",
                       "--seed", "4")
    assert code == 0, err
    d = arcsim.simulate(arcsim.load_plan("plans/lung.json"), arcsim.load_machine(machine),
                        motion="constant")
    py_log = tmp_path / "py.csv"
    cols = d.to_log(py_log, period=0.05, angle_noise_deg=0.02, seed=4)
    assert py_log.read_bytes() == cli_log.read_bytes()
    lines = cli_log.read_text().splitlines()
    assert lines[0] == "t_s,gantry_angle_deg,beam_on,energy_mev,spot,mu"
    assert len(cols["t_s"]) == len(lines) - 1
    assert cols["beam_on"].dtype == bool and cols["beam_on"].any()
    assert cols["t_s"][-1] == pytest.approx(d.total_s, rel=0, abs=1e-12)
    with pytest.raises(ValueError, match="log period"):
        d.to_log(period=0.0)
    back = arcsim.load_log(str(cli_log))
    for key in ("t_s", "gantry_angle_deg", "beam_on"):
        assert list(back[key]) == list(cols[key]), key
    assert list(np.isnan(back["energy_mev"])) == list(np.isnan(cols["energy_mev"]))
    bad = tmp_path / "bad.csv"
    bad.write_text("TIME,angle,on\n0,1,0\n0,2,1\n")
    with pytest.raises(arcsim.LogError, match=r"bad.csv: line 3: column TIME: time 0 s repeats"):
        arcsim.load_log(bad, columns="t_s=TIME,gantry_angle_deg=angle,beam_on=on")
    with pytest.raises(arcsim.LogError, match="no column t_s"):
        arcsim.load_log(bad)


def test_save_rrd(tmp_path):
    d = arcsim.simulate(arcsim.load_plan("plans/lung.json"), schedule="scan", motion="constant")
    path = tmp_path / "lung.rrd"
    d.save_rrd(path)
    assert path.read_bytes()[:4] == b"RRF2"


def test_gil_is_released_while_simulating():
    plan = arcsim.load_plan("plans/head-neck.json")

    def work():
        arcsim.simulate(plan, schedule="optimal", motion="constant")

    work()  # warm up
    # While one thread simulates, this one keeps running Python between its ticks. Were the GIL
    # held for the whole simulation, one gap between two ticks would last about as long as the
    # simulation. Timing-free of the machine's load otherwise: best of three trials.
    worst = []
    for _ in range(3):
        done = threading.Event()
        worker = threading.Thread(target=lambda: (work(), done.set()))
        stamps = [time.perf_counter()]
        worker.start()
        while not done.is_set():
            stamps.append(time.perf_counter())
        worker.join()
        busy = stamps[-1] - stamps[0]
        gap = max(b - a for a, b in zip(stamps, stamps[1:]))
        worst.append((gap / busy, len(stamps)))
    assert min(w[0] for w in worst) < 0.5, worst
    assert max(w[1] for w in worst) > 1000, worst


def test_profile_equals_the_cli():
    code, out, err = cli("profile", "--distance", "4", "--v-start", "1.5", "--v-end", "0.5",
                         "--jerk", "0.5", "--accel", "0.5", "--vel", "5", "--json")
    assert code == 0, err
    expected = json.loads(out)
    p = arcsim.profile(4, 1.5, 0.5, 0.5, 0.5, 5)
    assert p.duration_s == expected["duration_s"]
    assert p.peak_speed_deg_per_s == expected["peak_speed_deg_per_s"]
    assert np.allclose(p.phases["duration_s"], [ph["duration_s"] for ph in expected["phases"]],
                       rtol=0, atol=0)
    end = p.sample(np.array([0.0, p.duration_s]))
    assert end["position_deg"][1] == pytest.approx(4, abs=1e-9)
    assert end["speed_deg_per_s"].tolist() == pytest.approx([1.5, 0.5], abs=1e-9)
    # Sampled speeds integrate to the distance (trapezoid rule, fine grid).
    t = np.linspace(0, p.duration_s, 20001)
    s = p.sample(t)
    v = s["speed_deg_per_s"]
    assert np.sum((v[1:] + v[:-1]) / 2 * np.diff(t)) == pytest.approx(4, abs=1e-6)
    timed = arcsim.profile(1.6, 0.3, 0.3, 0.5, 0.5, 5, min_duration=5)
    assert timed.duration_s == pytest.approx(5, abs=1e-9)
    grid = arcsim.profile(4, 1.5, 0.5, 0.5, 0.5, 5, period_s=0.004)
    phases = grid.phases["duration_s"]
    assert np.allclose(phases / 0.004, np.round(phases / 0.004), atol=1e-6)


def test_profile_batch_matches_single_moves():
    rng = np.random.default_rng(7)
    n = 2000
    dist = rng.uniform(0.0, 20.0, n)
    vs = rng.uniform(0.0, 5.0, n)
    ve = rng.uniform(0.0, 5.0, n)
    b = arcsim.profile_batch(dist, vs, ve, 0.5, 0.5, 5.0)
    assert b["duration_s"].shape == (n,) and b["ok"].dtype == np.bool_
    assert b["ok"].any() and (~b["ok"]).any()  # some moves are too short to fit
    for k in range(0, n, 97):
        if b["ok"][k]:
            assert arcsim.profile(dist[k], vs[k], ve[k], 0.5, 0.5, 5.0).duration_s == b["duration_s"][k]
            assert b["error"][k] is None
        else:
            assert np.isnan(b["duration_s"][k])
            with pytest.raises(arcsim.ProfileError) as e:
                arcsim.profile(dist[k], vs[k], ve[k], 0.5, 0.5, 5.0)
            assert str(e.value) == b["error"][k]
    with pytest.raises(ValueError, match="expected 3"):
        arcsim.profile_batch(np.ones(3), np.zeros(2), 0.0, 0.5, 0.5, 5.0)


def test_plan_from_arrays():
    p = arcsim.Plan.from_arrays([0, 0, 2, 4], [1.0, 0.5, 1.0, 1.0], [120, 118, 116, 114],
                                window_deg=1.5, switching_times_s=[0.6, 0.6, 2.0])
    assert p.layers == 4 and p.arcs == 1
    doc = json.loads(p.to_json())
    cps = doc["arcs"][0]["control_points"]
    assert [len(cp["layers"]) for cp in cps] == [2, 1, 1]
    assert cps[2]["layers"][0]["switching_time_s"] == 2.0
    d = arcsim.simulate(p, schedule="scan", motion="constant")
    assert d.breakdown["energy_switching_s"] == pytest.approx(0.6 + 0.6 + 2.0)


NAN = float("nan")
INF = float("inf")


def test_plan_from_arrays_checks_every_number():
    def plan(**kw):
        args = dict(angles_deg=[0, 2, 4], irradiation_times_s=[1.0, 1.0, 1.0],
                    energies_mev=[120, 118, 116])
        args.update(kw)
        return arcsim.Plan.from_arrays(**args)

    # NaN or inf: a ValueError naming the argument and the index, never a fallback to the
    # machine's ELST or default window.
    with pytest.raises(ValueError, match=r"switching_times_s\[1\]: expected a finite number, got nan"):
        plan(switching_times_s=[0.5, NAN])
    with pytest.raises(ValueError, match=r"switching_times_s\[0\]: expected a finite number, got inf"):
        plan(switching_times_s=np.array([INF, 0.5]))
    with pytest.raises(ValueError, match=r"window_deg\[2\]: expected a finite number, got nan"):
        plan(window_deg=[1.0, 1.0, NAN])
    with pytest.raises(ValueError, match=r"window_deg: expected a finite number, got inf"):
        plan(window_deg=INF)
    with pytest.raises(ValueError, match=r"angles_deg\[1\]: expected a finite number, got nan"):
        plan(angles_deg=[0, NAN, 4])
    with pytest.raises(ValueError, match=r"irradiation_times_s\[2\]: expected a finite number, got inf"):
        plan(irradiation_times_s=np.array([1.0, 1.0, INF]))
    with pytest.raises(ValueError, match=r"energies_mev: expected a finite number, got nan"):
        plan(energies_mev=NAN)
    # Booleans are not numbers.
    with pytest.raises(TypeError, match=r"angles_deg\[1\]: expected a number, got a bool"):
        plan(angles_deg=[0, True, 4])
    with pytest.raises(TypeError, match=r"irradiation_times_s: expected a number, got a bool"):
        plan(irradiation_times_s=True)
    with pytest.raises(TypeError, match=r"window_deg: expected numbers, got an array of bools"):
        plan(window_deg=np.array([True, True, False]))
    with pytest.raises(TypeError, match=r"energies_mev\[0\]: expected a number, got str"):
        plan(energies_mev=["120", 118, 116])
    # Zero or negative where a positive value is needed: the argument and the index.
    with pytest.raises(ValueError, match=r"irradiation_times_s\[1\]: expected a time > 0 s, got -1"):
        plan(irradiation_times_s=[1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match=r"window_deg\[0\]: expected a window > 0 deg, got 0"):
        plan(window_deg=0)
    with pytest.raises(ValueError, match=r"switching_times_s\[0\]: expected a time >= 0 s, got -0.5"):
        plan(switching_times_s=[-0.5, 1.0])
    with pytest.raises(ValueError, match=r"energies_mev\[2\]: expected an energy > 0 MeV"):
        plan(energies_mev=[120, 118, 0])
    # Integer arrays and numpy scalars are numbers.
    assert plan(angles_deg=np.array([0, 2, 4]), window_deg=np.float64(1.5)).layers == 3


def test_machine_limits_check_every_number():
    atom = arcsim.Machine.atom()
    with pytest.raises(ValueError, match=r"jerk: expected a finite number, got nan"):
        atom.with_limits(jerk=NAN)
    with pytest.raises(ValueError, match=r"accel: expected a finite number, got inf"):
        atom.with_limits(accel=INF)
    with pytest.raises(TypeError, match=r"speed: expected a number, got a bool"):
        atom.with_limits(speed=True)
    with pytest.raises(TypeError, match=r"decel: expected a number, got str"):
        atom.with_limits(decel="1")
    with pytest.raises(ValueError, match=r"jerk: expected a finite number, got an integer too large"):
        atom.with_limits(jerk=10**400)
    with pytest.raises(arcsim.PlanError, match=r"speed \(max_speed_deg_per_s\): expected a number > 0, got 0"):
        atom.with_limits(speed=0)
    with pytest.raises(arcsim.PlanError, match=r"decel \(max_decel_deg_per_s2\): expected a number > 0, got -1"):
        atom.with_limits(decel=-1)
    assert atom.with_limits(jerk=np.float64(2), speed=4).speed == 4.0


def test_simulate_and_delivery_check_their_numbers(tmp_path):
    plan = arcsim.load_plan("plans/lung.json")
    with pytest.raises(TypeError, match=r"period_s: expected a number, got a bool"):
        arcsim.simulate(plan, period_s=True)
    with pytest.raises(ValueError, match=r"period_s: expected a finite number, got nan"):
        arcsim.simulate(plan, period_s=NAN)
    d = arcsim.simulate(plan, schedule="scan", motion="constant")
    with pytest.raises(TypeError, match=r"dt: expected a number, got a bool"):
        d.save_rrd(tmp_path / "x.rrd", dt=True)
    with pytest.raises(ValueError, match=r"dt: expected a number > 0, got 0"):
        d.save_rrd(tmp_path / "x.rrd", dt=0)
    with pytest.raises(ValueError, match=r"dt: expected a finite number, got inf"):
        d.save_rrd(tmp_path / "x.rrd", dt=INF)
    assert not (tmp_path / "x.rrd").exists()
    with pytest.raises(TypeError, match=r"dt: expected a number, got a bool"):
        d.timeline(dt=True)
    with pytest.raises(ValueError, match=r"dt: expected a finite number, got nan"):
        d.timeline(dt=NAN)
    assert d.timeline()["t_s"][1] == pytest.approx(0.01)


def test_schedule_arrays_checks_every_number():
    def run(times=(1.0, 1.0, 1.0), switching=(0.5, 0.5), **kw):
        args = dict(spacing_deg=2.0, max_window_deg=1.0, jerk=0.5, accel=0.5, speed=5.0)
        args.update(kw)
        return arcsim.schedule_arrays(list(times), list(switching), **args)

    with pytest.raises(ValueError, match=r"irradiation_times_s\[1\]: expected a finite number, got nan"):
        run(times=(1.0, NAN, 1.0))
    with pytest.raises(ValueError, match=r"switching_times_s\[1\]: expected a finite number, got inf"):
        run(switching=(0.5, INF))
    with pytest.raises(ValueError, match=r"max_window_deg: expected a finite number, got nan"):
        run(max_window_deg=NAN)
    with pytest.raises(ValueError, match=r"max_window_deg: expected a number > 0, got 0"):
        run(max_window_deg=0)
    with pytest.raises(TypeError, match=r"jerk: expected a number, got a bool"):
        run(jerk=True)
    with pytest.raises(ValueError, match=r"speed: expected a number > 0, got -5"):
        run(speed=-5)
    with pytest.raises(ValueError, match=r"decel: expected a finite number, got inf"):
        run(decel=INF)
    with pytest.raises(ValueError, match=r"irradiation_times_s\[0\]: expected a time > 0 s, got 0"):
        run(times=(0.0, 1.0, 1.0))
    total, speeds = run()
    assert total > 3.0 and speeds.shape == (3,)


def test_profiles_check_every_number():
    args = dict(distance=10.0, v_start=0.0, v_end=0.0, jerk=0.5, accel=0.5, vel=5.0)

    def one(**kw):
        return arcsim.profile(**dict(args, **kw))

    with pytest.raises(ValueError, match=r"distance: expected a finite number, got nan"):
        one(distance=NAN)
    with pytest.raises(ValueError, match=r"vel: expected a finite number, got inf"):
        one(vel=INF)
    with pytest.raises(TypeError, match=r"jerk: expected a number, got a bool"):
        one(jerk=True)
    with pytest.raises(ValueError, match=r"accel: expected a number > 0, got -0.5"):
        one(accel=-0.5)
    with pytest.raises(ValueError, match=r"min_duration: expected a number >= 0, got -1"):
        one(min_duration=-1)
    with pytest.raises(ValueError, match=r"min_duration: expected a finite number, got nan"):
        one(min_duration=NAN)
    with pytest.raises(ValueError, match=r"period_s: expected a finite number, got inf"):
        one(period_s=INF)
    p = one()
    with pytest.raises(ValueError, match=r"t\[1\]: expected a finite number, got nan"):
        p.sample(np.array([0.0, NAN]))
    with pytest.raises(TypeError, match=r"t: expected a number, got a bool"):
        p.sample(True)

    def batch(**kw):
        return arcsim.profile_batch(**dict(args, **kw))

    with pytest.raises(ValueError, match=r"distance\[1\]: expected a finite number, got nan"):
        batch(distance=np.array([1.0, NAN, 3.0]))
    with pytest.raises(ValueError, match=r"jerk\[1\]: expected a number > 0, got -1"):
        batch(distance=np.ones(2), jerk=np.array([0.5, -1.0]))
    with pytest.raises(ValueError, match=r"vel: expected a number > 0, got 0"):
        batch(distance=np.ones(2), vel=0)
    with pytest.raises(TypeError, match=r"accel: expected a number, got a bool"):
        batch(distance=np.ones(2), accel=False)
    with pytest.raises(TypeError, match=r"v_end: expected numbers, got an array of bools"):
        batch(distance=np.ones(2), v_end=np.zeros(2, dtype=bool))
    with pytest.raises(ValueError, match=r"period_s: expected a finite number, got nan"):
        batch(period_s=NAN)
    assert batch(distance=np.array([10, 20]))["ok"].all()  # integer arrays are numbers
    # Outside the ranges a move is solved in: refused by name, never "a bug".
    with pytest.raises(arcsim.ProfileError, match=r"jerk 1e-300 deg/s³ is outside the range a move is solved in \(0.001 to 10000 deg/s³\)"):
        one(jerk=1e-300)
    with pytest.raises(arcsim.ProfileError, match=r"distance 1e300 deg is outside"):
        one(distance=1e300)
    out = batch(distance=np.array([10.0, 1e300]))
    assert out["ok"].tolist() == [True, False]
    assert "distance 1e300 deg is outside" in out["error"][1]


def test_sweep_checks_its_numbers():
    spec = sweep_dict(3)
    spec["axes"]["jerk_deg_per_s3"]["from"] = NAN
    with pytest.raises(arcsim.SweepError, match=r"axes\.jerk_deg_per_s3\.from: expected a finite number, got nan"):
        arcsim.sweep(spec, progress=False)
    spec = sweep_dict(3)
    spec["axes"]["accel_deg_per_s2"] = [0.5, INF]
    with pytest.raises(arcsim.SweepError, match=r"axes\.accel_deg_per_s2\[1\]: expected a finite number, got inf"):
        arcsim.sweep(spec, progress=False)
    with pytest.raises(TypeError, match=r"threads: expected an integer, got a bool"):
        arcsim.sweep(sweep_dict(3), threads=True, progress=False)
    with pytest.raises(TypeError, match=r"threads: expected an integer, got float"):
        arcsim.sweep(sweep_dict(3), threads=2.0, progress=False)
    with pytest.raises(ValueError, match=r"threads: expected 1 to 256, got -1"):
        arcsim.sweep(sweep_dict(3), threads=-1, progress=False)


def test_schedule_arrays_atom_cases():
    ref = json.loads(ATOM_REFERENCE.read_text())
    for case in ref["cases"]:
        total, speeds = arcsim.schedule_arrays(
            case["irradiation_times_s"], case["energy_switch_times_s"],
            ref["control_point_spacing_deg"], ref["max_window_deg"],
            jerk=0.5, accel=0.5, speed=5.0, schedule="scan")
        times = np.array(case["irradiation_times_s"])
        assert speeds.shape == times.shape
        assert np.all(speeds <= 5 + 1e-12) and np.all(speeds * times <= ref["max_window_deg"] + 1e-9)
        assert total > sum(case["irradiation_times_s"]) + sum(case["energy_switch_times_s"])
        # The same case through the sweep's ATOM loader (placeholder energies): the same total.
        spec = {
            "format": "arcsim-sweep/1", "name": "atom",
            "plans": [{"atom_case": case["name"], "reference": str(ATOM_REFERENCE.resolve())}],
            "machine": "scenarios/machine-atom.json", "schedules": ["scan"],
        }
        rows = arcsim.sweep(spec, progress=False).rows
        assert rows["total_s"][0] == pytest.approx(total, rel=1e-12)


def sweep_dict(n_jerk, schedule="scan"):
    return {
        "format": "arcsim-sweep/1",
        "name": "py",
        "plans": ["plans/prostate.json", "plans/lung.json"],
        "machine": "scenarios/machine-atom.json",
        "axes": {
            "jerk_deg_per_s3": {"from": 0.25, "to": 2, "steps": n_jerk},
            "accel_deg_per_s2": [0.5, 1],
        },
        "schedules": [schedule],
    }


def test_sweep_equals_the_cli(tmp_path):
    spec = sweep_dict(3)
    path = tmp_path / "sweep.json"
    spec_file = dict(spec, plans=[str(Path(p).resolve()) for p in spec["plans"]],
                     machine=str(Path(spec["machine"]).resolve()))
    path.write_text(json.dumps(spec_file))
    out = tmp_path / "rows.json"
    code, table, err = cli("sweep", str(path), "--json", str(out), "--threads", "2")
    assert code == 0, err
    expected = json.loads(out.read_text())
    r = arcsim.sweep(path, threads=2, progress=False)
    assert r.complete and r.combinations == 12
    got = json.loads(r.to_json())
    assert got["rows"] == expected["rows"] and got["summary"] == expected["summary"]
    assert r.summary_table() == table
    rows = r.rows
    assert rows["total_s"].dtype == np.float64 and rows["total_s"].shape == (12,)
    assert rows["jerk_deg_per_s3"].tolist() == [row["setting"]["jerk_deg_per_s3"] for row in expected["rows"]]
    # The dict form (paths relative to the current directory) gives the same rows, with the
    # plans named as written.
    def unnamed(rows):
        return [dict(r, plan=None) for r in rows]

    from_dict = json.loads(arcsim.sweep(spec, progress=False).to_json())["rows"]
    assert unnamed(from_dict) == unnamed(expected["rows"])
    assert from_dict[0]["plan"] == "plans/prostate.json"
    pd = pytest.importorskip("pandas")
    assert len(r.to_pandas()) == 12


def test_ctrl_c_stops_a_sweep_and_keeps_finished_rows():
    spec = sweep_dict(400, schedule="optimal")  # 1,600 combinations: far longer than the test
    # Python installs its Ctrl-C handler only when SIGINT is not ignored at start-up, and a
    # process started in the background of a shell (as CI may) inherits it ignored.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(1.0, _thread.interrupt_main)
    timer.start()
    t0 = time.perf_counter()
    try:
        with pytest.raises(KeyboardInterrupt) as e:
            arcsim.sweep(spec, threads=2, progress=False)
    finally:
        signal.signal(signal.SIGINT, previous)
    elapsed = time.perf_counter() - t0
    assert isinstance(e.value, arcsim.SweepInterrupted)
    result = e.value.result
    assert not result.complete and result.combinations == 1600
    n = len(result.rows["index"])
    assert n < 1600
    assert result.rows["index"].tolist() == list(range(n))  # in order, none lost
    assert elapsed < 30


SIGINT_AFTER_SWEEP = r"""
import os, signal, sys, threading, time
import arcsim

spec = {
    "format": "arcsim-sweep/1", "name": "py", "plans": ["plans/prostate.json", "plans/lung.json"],
    "machine": "scenarios/machine-atom.json", "schedules": ["optimal"],
}

def own_handler(signum, frame):
    raise KeyboardInterrupt("own handler")

# The interpreter may start with SIGINT ignored (in the background of a shell): install one.
signal.signal(signal.SIGINT, own_handler)

def later_ctrl_c_raises():
    try:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(100):
            time.sleep(0.01)
    except KeyboardInterrupt:
        return True
    return False

PATH = sys.argv[1]
if PATH == "complete":
    r = arcsim.sweep(dict(spec, axes={"jerk_deg_per_s3": [0.5]}), threads=1, progress=False)
    assert r.complete
elif PATH == "error":
    try:
        arcsim.sweep({"format": "nope"}, progress=False)
        raise SystemExit("no SweepError")
    except arcsim.SweepError:
        pass
elif PATH == "interrupt":
    threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT)).start()
    try:
        arcsim.sweep(dict(spec, axes={"jerk_deg_per_s3": {"from": 0.25, "to": 2, "steps": 800}}),
                     threads=1, progress=False)
        raise SystemExit("no SweepInterrupted")
    except arcsim.SweepInterrupted:
        pass
assert signal.getsignal(signal.SIGINT) is own_handler, signal.getsignal(signal.SIGINT)
assert later_ctrl_c_raises(), "a Ctrl-C after the sweep was lost"
print("handler restored")
"""


@pytest.mark.parametrize("path", ["complete", "error", "interrupt"])
def test_sigint_handler_is_restored_after_a_sweep(path):
    p = subprocess.run([sys.executable, "-c", SIGINT_AFTER_SWEEP, path], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0 and "handler restored" in p.stdout, p.stdout + p.stderr


def test_dask_maps_simulate_over_plans_and_settings():
    db = pytest.importorskip("dask.bag", reason="dask is not installed")
    plans = ["plans/prostate.json", "plans/lung.json"]
    jerks = [0.5, 1.0]

    def total(task):
        plan, jerk = task
        machine = arcsim.Machine.atom().with_limits(jerk=jerk)
        return plan, jerk, arcsim.simulate(arcsim.load_plan(plan), machine, "scan",
                                           motion="constant").total_s

    tasks = [(p, j) for p in plans for j in jerks]
    got = db.from_sequence(tasks, npartitions=2).map(total).compute(scheduler="threads")
    assert len(got) == 4
    for plan, jerk, t in got:
        assert t == total((plan, jerk))[2]


MADE_UP_MACHINE = {
    "format": "arcsim-machine/1", "name": "made-up",
    "gantry": {"max_speed_deg_per_s": 4.0, "max_accel_deg_per_s2": 0.3, "max_jerk_deg_per_s3": 0.4},
    "beam": {"s_per_mu": 0.004, "spot_switch_time_s": 0.002, "min_spot_time_s": 0.0},
    "elst": {"kind": "constant", "up_s": 3.2, "down_s": 0.8, "same_s": 0.0},
    "default_window_deg": 1.0,
}


def test_compare_calibrate_and_monte_carlo(tmp_path):
    machine_file = tmp_path / "made-up.json"
    machine_file.write_text(json.dumps(MADE_UP_MACHINE))
    made_up = arcsim.load_machine(machine_file)
    runs = []
    for name in ("lung", "two-arc"):
        plan = arcsim.load_plan(f"plans/{name}.json")
        log = tmp_path / f"{name}.csv"
        arcsim.simulate(plan, made_up).to_log(log, angle_noise_deg=0.01, seed=1)
        runs.append((plan, log))
    # compare equals the command's JSON, row for row.
    c = arcsim.compare(runs[0][0], runs[0][1], made_up)
    code, _, err = cli("compare", "plans/lung.json", str(runs[0][1]), "--machine", str(machine_file),
                       "--json", str(tmp_path / "cmp.json"))
    assert code == 0, err
    cli_doc = json.loads((tmp_path / "cmp.json").read_text())
    assert c.difference_s == cli_doc["difference_s"]
    assert list(c.layers["logged_start_s"]) == [r["logged_start_s"] for r in cli_doc["layers"]]
    assert abs(c.difference_s) <= 0.01 + 1e-9
    # The made-up machine names no controller: simulated (and logged) under the assumed one,
    # constant speed per layer, which the log then fits best.
    assert c.summary["motion"] == "constant" and c.summary["better_motion"] == "constant"
    with pytest.raises(arcsim.LogError, match="the first that differs"):
        arcsim.compare(arcsim.load_plan("plans/prostate.json"), runs[0][1], made_up)
    # calibrate recovers the made-up machine from the ATOM one.
    fitted, report = arcsim.calibrate(arcsim.Machine.atom(), runs)
    values = {v["field"]: v for v in report["values"]}
    assert values["elst.up_s"]["value"] == pytest.approx(3.2, rel=0.02)
    assert values["elst.down_s"]["value"] == pytest.approx(0.8, rel=0.02)
    assert values["beam.s_per_mu"]["value"] == pytest.approx(0.004, rel=0.02)
    assert values["gantry.max_accel_deg_per_s2"]["value"] == pytest.approx(0.3, rel=0.05)
    for r in report["residuals"]:
        assert abs(r["fitted_error_pct"]) < 1.0
    # The controller is learnt from the logs and written into the fitted machine.
    assert report["controller"]["decision"] == "chosen", report["controller"]
    rms = report["controller"]["rms_beam_on_start_s"]
    assert rms["constant"] * 3 <= rms["free"]
    assert json.loads(fitted.to_json())["controller"]["motion"] == "constant"
    # The fitted machine simulates and carries spreads to draw.
    d = arcsim.simulate(runs[0][0], fitted)
    mc = d.monte_carlo(6, seed=3)
    assert mc["p5_s"] <= mc["p50_s"] <= mc["p95_s"] and len(mc["totals_s"]) == 6
    with pytest.raises(arcsim.SimulationError, match="no timing spreads"):
        arcsim.simulate(runs[0][0], made_up).monte_carlo(3)
    with pytest.raises(ValueError, match="elst"):
        arcsim.calibrate(made_up, runs, elst="cubic")


def test_calibrate_spots_equals_the_cli(tmp_path):
    # A hidden scanning machine (6,000 mm/s, 2 ms settling) writes the per-spot log.
    base_file = "scenarios/machine-proteusone-like.json"
    hidden = json.loads(open(base_file).read())
    hidden["beam"]["scan_speed_mm_per_s"] = 6000.0
    hidden["beam"]["settling_time_s"] = 0.002
    hidden_file = tmp_path / "hidden.json"
    hidden_file.write_text(json.dumps(hidden))
    spots = tmp_path / "spots.csv"
    code, _, err = cli("simulate", "plans/prostate.json", "--machine", str(hidden_file),
                       "--spots", str(spots))
    assert code == 0, err
    plan = arcsim.load_plan("plans/prostate.json")
    fitted, report = arcsim.calibrate_spots(arcsim.load_machine(base_file), [(plan, spots)])
    values = {v["field"]: v for v in report["values"]}
    assert values["beam.scan_speed_mm_per_s"]["value"] == pytest.approx(6000.0, rel=1e-6)
    assert values["beam.settling_time_s"]["value"] == pytest.approx(0.002, rel=1e-6)
    assert json.loads(fitted.to_json())["beam"]["scan_speed_mm_per_s"] == pytest.approx(6000.0)
    cli_doc = cli_json(tmp_path, "calibrate-spots", "--machine", base_file, "plans/prostate.json",
                       str(spots), "-o", str(tmp_path / "fitted.json"))
    assert [v["value"] for v in cli_doc["values"]] == [v["value"] for v in report["values"]]
    with pytest.raises(ValueError, match="per_mu"):
        arcsim.calibrate_spots(arcsim.Machine.atom(), [(plan, spots)])
    with pytest.raises(arcsim.LogError, match="no column"):
        arcsim.calibrate_spots(arcsim.load_machine(base_file), [(plan, "plans/README.md")])


def test_iba_logs_are_read_as_the_cli_reads_them(tmp_path):
    # A hidden scanning machine's IBA-style log of a plan whose spot spacing varies by energy.
    base_file = "scenarios/machine-opentps-pbs.json"
    hidden = json.loads(open(base_file).read())
    hidden["beam"]["scan_speed_mm_per_s"] = 6000.0
    hidden["beam"]["settling_time_s"] = 0.002
    hidden_file = tmp_path / "hidden.json"
    hidden_file.write_text(json.dumps(hidden))
    plan_file, folder = tmp_path / "lung-spaced.json", tmp_path / "lung-iba"
    code, _, err = cli("generate-plan", "--kind", "lung", "--spot-spacing", "3-8", "-o", str(plan_file))
    assert code == 0, err
    code, _, err = cli("simulate", str(plan_file), "--machine", str(hidden_file),
                       "--iba-log", str(folder))
    assert code == 0, err
    plan = arcsim.load_plan(str(plan_file))
    log = arcsim.load_log(str(folder))
    layers = sum(len(cp["layers"]) for a in json.loads(plan_file.read_text())["arcs"]
                 for cp in a["control_points"])
    # Two beam-on rows per layer, between beam-off rows; no energies in such a log.
    assert int(sum(log["beam_on"])) == 2 * layers
    fitted, report = arcsim.calibrate_spots(arcsim.load_machine(base_file), [(plan, folder)])
    values = {v["field"]: v for v in report["values"]}
    assert values["beam.scan_speed_mm_per_s"]["value"] == pytest.approx(6000.0, rel=0.03)
    assert values["beam.settling_time_s"]["value"] == pytest.approx(0.002, rel=0.03)
    cli_doc = cli_json(tmp_path, "calibrate-spots", "--machine", base_file, str(plan_file),
                       str(folder), "-o", str(tmp_path / "fitted.json"))
    assert [v["value"] for v in cli_doc["values"]] == [v["value"] for v in report["values"]]
    with pytest.raises(arcsim.LogError, match="no map_record"):
        arcsim.load_log(str(tmp_path))


def test_resequence_equals_the_cli(tmp_path):
    # Each control point's layers in ascending energy: re-sequencing has upward switches to remove.
    plan = json.loads(Path("plans/lung.json").read_text())
    for arc in plan["arcs"]:
        for cp in arc["control_points"]:
            cp["layers"].sort(key=lambda l: l["energy_mev"])
    src = tmp_path / "ascending.json"
    src.write_text(json.dumps(plan))
    out, report_path = tmp_path / "out.json", tmp_path / "report.json"
    code, stdout, err = cli("resequence", str(src), "-o", str(out), "--json", str(report_path))
    assert code == 0, err
    expected = json.loads(report_path.read_text())
    got_plan, report = arcsim.resequence(arcsim.load_plan(str(src)))
    assert report == expected
    assert report["resequenced"]
    assert report["total_after_s"] < report["total_before_s"]
    assert json.loads(got_plan.to_json()) == json.loads(out.read_text())
    # The written plan simulates to the reported total.
    again = arcsim.simulate(arcsim.load_plan(str(out)))
    assert again.total_s == report["total_after_s"]


def _layers_in_force(beam):
    """Per layer control point of a beam (pydicom), in order: (energy, weights, positions), the
    energy resolved through inheritance as DICOM defines it."""
    out, energy = [], None
    for cp in beam.IonControlPointSequence:
        energy = float(cp.NominalBeamEnergy) if "NominalBeamEnergy" in cp else energy
        weights = tuple(float(w) for w in cp.ScanSpotMetersetWeights)
        if sum(weights) > 0:
            out.append((energy, weights, tuple(float(p) for p in cp.ScanSpotPositionMap)))
    return out


def test_a_dicom_plan_written_back_reads_in_pydicom(tmp_path):
    import pydicom

    src = "plans/dicom/multi.dcm"
    cli_out = tmp_path / "cli.dcm"
    code, _, err = cli("resequence", src, "-o", str(cli_out))
    assert code == 0, err
    plan, report = arcsim.resequence(arcsim.load_plan(src))
    assert report["resequenced"] and report["moved_layers"] > 0
    py_out = tmp_path / "py.dcm"
    uid = arcsim.write_resequenced_dicom(plan, src, str(py_out))
    given, by_cli, by_py = (pydicom.dcmread(p) for p in (src, cli_out, py_out))
    assert by_py.SOPInstanceUID == uid
    assert by_py.file_meta.MediaStorageSOPInstanceUID == uid
    assert len({given.SOPInstanceUID, by_cli.SOPInstanceUID, uid}) == 3
    assert by_cli.IonBeamSequence == by_py.IonBeamSequence
    ref = by_py.ReferencedRTPlanSequence[-1]
    assert ref.ReferencedSOPInstanceUID == given.SOPInstanceUID
    assert ref.RTPlanRelationship == "PREDECESSOR"
    assert by_py.ApprovalStatus == "UNAPPROVED"
    # Every beam keeps its layers (energy, weights, positions) as a multiset, in the order of the
    # re-sequenced plan; the cumulative weights are the running sums of the new order.
    energies = [
        layer["energy_mev"]
        for arc in json.loads(plan.to_json())["arcs"]
        for cp in arc["control_points"]
        for layer in cp["layers"]
    ]
    written_energies = []
    for old, new in zip(given.IonBeamSequence, by_py.IonBeamSequence):
        assert sorted(_layers_in_force(old)) == sorted(_layers_in_force(new))
        written_energies += [e for e, _, _ in _layers_in_force(new)]
        total = 0.0
        for i, cp in enumerate(new.IonControlPointSequence):
            assert int(cp.ControlPointIndex) == i
            assert abs(float(cp.CumulativeMetersetWeight) - total) < 1e-6
            total += sum(float(w) for w in cp.ScanSpotMetersetWeights)
        assert abs(total - float(new.FinalCumulativeMetersetWeight)) < 1e-6
    assert written_energies == energies
    # A plan that is not a reorder of the original is refused.
    with pytest.raises(arcsim.PlanError, match="arcsim JSON"):
        arcsim.write_resequenced_dicom(arcsim.load_plan("plans/lung.json"), src, str(tmp_path / "x.dcm"))


def test_a_treatment_record_reads_in_pydicom_as_the_simulation_and_loads_as_a_log(tmp_path):
    """`simulate --record` read by pydicom, independently of arcsim's reader: one pair of control
    points per layer at the simulation's beam-on and beam-off, the delivered meterset growing by
    the plan's MU; then `load_log` and `compare` read it as that delivery."""
    import pydicom
    rec = tmp_path / "lung.dcm"
    d = cli_json(tmp_path, "simulate", "plans/lung.json", "--record", str(rec),
                 "--record-time-digits", "6", "--record-start", "20261231235930")
    ds = pydicom.dcmread(rec)
    assert ds.SOPClassUID == "1.2.840.10008.5.1.4.1.1.481.9"
    cps = [c for b in ds.TreatmentSessionIonBeamSequence for c in b.IonControlPointDeliverySequence]
    assert len(cps) == 2 * len(d["layers"])

    def seconds(c):
        day = 0 if c.TreatmentControlPointDate == "20261231" else 1
        t = c.TreatmentControlPointTime
        return day * 86400 + int(t[:2]) * 3600 + int(t[2:4]) * 60 + float(t[4:]) - 86370.0

    plan = json.loads(Path("plans/lung.json").read_text())
    mu = [layer["spots"]["total_mu"] for arc in plan["arcs"] for cp in arc["control_points"]
          for layer in cp["layers"]]
    for k, layer in enumerate(d["layers"]):
        on, off = cps[2 * k], cps[2 * k + 1]
        assert seconds(on) == pytest.approx(layer["t_start_s"], abs=1e-6)
        assert seconds(off) == pytest.approx(layer["t_end_s"], abs=1e-6)
        assert float(off.DeliveredMeterset) - float(on.DeliveredMeterset) == pytest.approx(
            mu[k], abs=2e-6)
        assert float(on.NominalBeamEnergy) == pytest.approx(layer["energy_mev"], abs=1e-6)
    log = arcsim.load_log(rec)
    assert int(log["beam_on"].sum()) == 2 * len(d["layers"])
    c = arcsim.compare(arcsim.load_plan("plans/lung.json"), rec, arcsim.Machine.atom())
    assert abs(c.difference_s) < 1e-4
