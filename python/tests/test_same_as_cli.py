"""Each function of the package against the command line on the same inputs.

The command line is the program `cargo xtask ci` built from the same tree (its path in
the environment variable PTSA_BIN). Equal means equal: the same JSON values, the same
arrays bit for bit, the same refusal's message.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import ptsa

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "data" / "examples"


def cli(*args: str, ok: bool = True) -> subprocess.CompletedProcess[str]:
    exe = os.environ.get("PTSA_BIN")
    if not exe:
        pytest.fail("PTSA_BIN is not set: run these tests through `cargo xtask python`")
    r = subprocess.run([exe, *args], capture_output=True, text=True, cwd=ROOT)
    if ok and r.returncode != 0:
        pytest.fail(f"ptsa {' '.join(args)} failed: {r.stderr}")
    return r


def cli_json(*args: str):
    return json.loads(cli(*args, "--json").stdout)


def test_static_is_the_command_lines_batch():
    got = ptsa.static([-1000.0, 0.0, 1234.5], seconds=0.05, seed=11)
    want = cli_json("static", "--accel-cm-s2", "-1000,0,1234.5", "--seconds", "0.05", "--seed", "11")
    assert got == want
    assert len(got) == 3 and all(r["ticks"] == 3200 for r in got)


def test_static_one_acceleration_with_bias_and_an_instrument_file():
    instr = "data/kearfott-2401-discovery.toml"
    got = ptsa.static([500.0], seconds=0.02, warmup_s=0.1, with_bias=True, instrument=ROOT / instr)
    want = cli_json(
        "--instrument", instr, "static", "--accel-cm-s2", "500",
        "--seconds", "0.02", "--warmup-s", "0.1", "--with-bias",
    )
    assert got == [want]


def test_record_is_the_simulated_record_the_command_writes(tmp_path):
    out = tmp_path / "rec.csv"
    cli("noise", "--simulate", "--seconds", "1", "--gate-s", "0.01", "--seed", "7",
        "--output", str(out), "--json")
    rows = [r for r in csv.reader(l for l in out.read_text().splitlines() if not l.startswith("#"))]
    assert rows[0] == ["time_s", "pulses", "ticks"]
    got = ptsa.record(1.0, gate_s=0.01, seed=7)
    assert got["time_s"].dtype == np.float64 and got["pulses"].dtype == np.uint64
    assert got["time_s"].tolist() == [float(r[0]) for r in rows[1:]]
    assert got["pulses"].tolist() == [int(r[1]) for r in rows[1:]]
    assert got["ticks"].tolist() == [int(r[2]) for r in rows[1:]]
    # The record analysed from arrays is the file analysed by the command.
    want = cli_json("noise", "--counts", str(out))
    assert ptsa.noise(got, name=str(out)) == want
    assert ptsa.noise(out) == want


def test_noise_of_readings_from_a_file_a_frame_and_a_dict():
    path = EXAMPLES / "static-readings.csv"
    rel = "data/examples/static-readings.csv"
    want = cli_json("noise", "--readings", rel, "--taus", "decade", "--confidence", "0.683")
    assert ptsa.noise(path, name=rel, taus="decade", confidence=0.683) == want
    frame = pd.read_csv(path, comment="#")
    assert ptsa.noise(frame, name=rel, taus="decade", confidence=0.683) == want
    as_dict = {"time_s": frame["time_s"].to_numpy(), "reading": frame["reading"].to_numpy()}
    assert ptsa.noise(as_dict, name=rel, taus="decade", confidence=0.683) == want


def test_noise_compare_and_identify_are_the_command_lines(tmp_path):
    rec = tmp_path / "rest.csv"
    cli("noise", "--simulate", "--seconds", "20", "--gate-s", "0.01", "--seed", "3", "--output", str(rec))
    want = cli_json("noise", "--counts", str(rec), "--identify", "--seed", "5", "--warmup-s", "0.2")
    got = ptsa.noise(rec, identify=True, seed=5, warmup_s=0.2)
    assert got == want and got["identification"] is not None
    want = cli_json("noise", "--counts", str(rec), "--compare", "--identify", "--seed", "6")
    got = ptsa.noise(rec, compare=True, identify=True, seed=6)
    assert got == want and got["comparison"] is not None
    rel = "data/examples/static-readings.csv"
    want = cli_json("noise", "--readings", rel, "--identify")
    got = ptsa.noise(EXAMPLES / "static-readings.csv", name=rel, identify=True)
    assert got == want and got["terms_identification"] is not None
    with pytest.raises(ptsa.PtsaError, match="octave"):
        ptsa.noise(rec, identify=True, taus="decade")
    with pytest.raises(ptsa.PtsaError, match="counter record"):
        ptsa.noise(EXAMPLES / "static-readings.csv", compare=True)


def test_an_instrument_given_as_its_text_is_the_file():
    path = "data/kearfott-2401-discovery.toml"
    pair = ptsa.instrument_text(ROOT / path)
    assert isinstance(pair, tuple) and pair[1] == (ROOT / path).read_text()
    assert ptsa.static([500.0], seconds=0.02, instrument=pair) == ptsa.static(
        [500.0], seconds=0.02, instrument=ROOT / path
    )
    assert ptsa.instrument_text("mems") == "mems"
    with pytest.raises(ptsa.PtsaError, match=r"bad\.toml:1:"):
        ptsa.static([0.0], seconds=0.01, instrument=("bad.toml", "[loop\n"))


def test_noise_refuses_a_gap_with_the_command_lines_message(tmp_path):
    t = np.arange(64) * 0.01
    t[40:] += 0.05
    frame = pd.DataFrame({"time_s": t, "reading": np.zeros(64)})
    path = tmp_path / "gap.csv"
    path.write_text(ptsa._ptsa.columns_csv(["time_s", "reading"], [t, np.zeros(64)]))
    r = cli("noise", "--readings", str(path), "--json", ok=False)
    assert r.returncode == 1
    with pytest.raises(ptsa.PtsaError) as e:
        ptsa.noise(frame, name=str(path))
    assert f"error: {e.value}" == r.stderr.strip()
    assert ":42:" in str(e.value)


def test_discover_from_a_path_and_a_frame():
    rel = "data/examples/tumble-counts.csv"
    want = cli_json("discover", "--data", rel, "--analytic", "--no-plots")
    assert ptsa.discover(rel, analytic=True) == want
    frame = pd.read_csv(ROOT / rel, comment="#", dtype=str)
    from_frame = ptsa.discover(frame, analytic=True)
    assert from_frame == want


def test_errors_are_ptsa_errors_with_the_message():
    with pytest.raises(ptsa.PtsaError, match="expected a gate of at least one limit cycle"):
        ptsa.static([0.0], seconds=1e-5)
    with pytest.raises(ptsa.PtsaError, match="no-such-instrument.toml"):
        ptsa.static([0.0], instrument="no-such-instrument.toml")


def test_a_refused_case_frame_names_its_line_and_column_as_the_command_does(tmp_path):
    lines = (EXAMPLES / "tumble-counts.csv").read_text().splitlines()
    k = next(i for i, l in enumerate(lines) if l and not l.startswith("#")) + 3
    cells = lines[k].split(",")
    cells[-1] = "twelve"
    lines[k] = ",".join(cells)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    r = cli("discover", "--data", str(bad), "--analytic", "--no-plots", "--json", ok=False)
    assert r.returncode == 1
    with pytest.raises(ptsa.PtsaError) as e:
        ptsa.discover(bad, analytic=True)
    assert f"error: {e.value}" == r.stderr.strip().splitlines()[-1]
    assert f"{bad}:{k + 1}:" in str(e.value)


def test_the_gil_is_released_while_the_loop_runs():
    import threading

    ticks = []
    done = threading.Event()

    def run():
        ptsa.static([0.0] * 8, seconds=200.0)
        done.set()

    t = threading.Thread(target=run)
    t.start()
    while not done.is_set():
        ticks.append(1)
        done.wait(0.001)
    t.join()
    # The main thread ran Python while the batch ran (with the GIL held it could not).
    assert len(ticks) > 10


def test_the_yield_study_is_the_command_lines_in_one_piece_or_many():
    args = ["monte-carlo", "--yield", "12", "--seed", "5", "--gates", "3", "--gate-s", "0.05",
            "--spec-sf-ppm", "20000", "--spec-noise-cm-s2", "30"]
    want = cli_json(*args)
    opts = dict(seed=5, gates=3, gate_s=0.05, spec_sf_ppm=20000, spec_noise_cm_s2=30)
    assert ptsa.yield_study(12, **opts) == want
    plan = ptsa.yield_plan(12, **opts)
    parts = [ptsa.yield_units(plan, s, c) for s, c in [(7, 5), (0, 3), (3, 4)]]
    assert ptsa.yield_summary(plan, [u for p in parts for u in p]) == want
    assert 0 < want["within_spec"] < 12, "the limits split the instruments"


def test_the_defaults_are_the_command_lines(tmp_path):
    assert ptsa.static([250.0]) == [cli_json("static", "--accel-cm-s2", "250")]
    out = tmp_path / "r.csv"
    cli("noise", "--simulate", "--seconds", "2", "--output", str(out))
    assert ptsa.record(2.0)["time_s"].tolist() == [
        float(l.split(",")[0]) for l in out.read_text().splitlines()[3:]
    ]
    rel = "data/examples/static-readings.csv"
    assert ptsa.noise(rel) == cli_json("noise", "--readings", rel)


def test_a_ptsa_error_pickles_as_itself():
    import pickle

    e = pickle.loads(pickle.dumps(ptsa.PtsaError("x")))
    assert type(e) is ptsa.PtsaError and str(e) == "x"


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: ptsa.static([0.0], seconds=float("nan")), "seconds NaN"),
        (lambda: ptsa.record(float("nan")), "seconds NaN"),
        (lambda: ptsa.static([0.0], warmup_s=-1.0), "warmup_s -1"),
        (lambda: ptsa.noise("data/examples/static-readings.csv", taus=[float("nan")]), "taus NaN"),
        (lambda: ptsa.yield_plan(4, gates=1), "gates 1"),
        (lambda: ptsa.yield_plan(4, fractions=[0.3]), "two different inputs"),
        (lambda: ptsa.yield_units(ptsa.yield_plan(4), 3, 2), "inside the plan's 4"),
        (lambda: ptsa.yield_summary(ptsa.yield_plan(2), []), "instrument 0 is missing"),
        (lambda: ptsa.discover(42), "expected a path"),
    ],
)
def test_bad_input_is_a_ptsa_error_that_says_what_was_expected(call, message, monkeypatch):
    monkeypatch.chdir(ROOT)
    with pytest.raises(ptsa.PtsaError, match=message):
        call()


def test_correct_applies_a_triads_calibration_as_the_command_does(tmp_path):
    stream = "data/examples/triad-stream.csv"
    toml, js = tmp_path / "cal.toml", tmp_path / "cal.json"
    js.write_text(cli("discover", "--data", stream, "--no-plots", "--json", "--write-instrument", str(toml)).stdout)
    rec = tmp_path / "rec.csv"
    rec.write_text(
        "label,measured_x_cm_s2,measured_y_cm_s2,measured_z_cm_s2\n"
        "up,1.2,-0.8,980.1\nside,979.5,2.0,0.5\nhalf,,3.0,4.0\n"
    )
    for cal in (toml, js):
        want = cli_json("correct", "--data", str(rec), "--calibration", str(cal), "--sigma", "0.05")
        assert ptsa.correct(rec, cal, sigma=0.05) == want
    got = ptsa.correct(rec, js)
    assert got == cli_json("correct", "--data", str(rec), "--calibration", str(js))
    assert len(got["warnings"]) == 2 and "f_cm_s2" not in got["rows"][2] and "f_cm_s2" in got["rows"][0]
    frame = pd.read_csv(rec)
    assert ptsa.correct(frame, js)["rows"] == got["rows"]
    with pytest.raises(ptsa.PtsaError, match="is a triad record"):
        ptsa.correct(rec)


def test_correct_applies_a_calibration_as_the_command_does(tmp_path):
    tumble, check = "data/examples/tumble-counts.csv", "data/examples/check-counts.csv"
    sn3 = tmp_path / "sn3.json"
    sn3.write_text(cli("discover", "--data", tumble, "--analytic", "--no-plots", "--json").stdout)
    want = cli_json("correct", "--calibration", str(sn3), "--data", check)
    assert ptsa.correct(check, sn3) == want
    # The calibration as ptsa.discover returns it: the same rows, to the bit.
    from_dict = ptsa.correct(ROOT / check, ptsa.discover(tumble, analytic=True))
    assert from_dict["rows"] == want["rows"]
    # From a frame: the same values (the lines are the temporary file's, without comments).
    frame = pd.read_csv(ROOT / check, comment="#", dtype=str)
    keys = ["label", "a_ia_cm_s2", "sigma_a_ia_cm_s2"]
    assert [[r.get(k) for k in keys] for r in ptsa.correct(frame, sn3)["rows"]] == [
        [r.get(k) for k in keys] for r in want["rows"]
    ]
    with pytest.raises(ptsa.PtsaError, match="no calibration to apply"):
        ptsa.correct(check)


def test_a_frame_or_a_dict_is_named_as_such_not_by_a_temporary_file():
    check = ROOT / "data/examples/check-counts.csv"
    cal = ptsa.discover("data/examples/tumble-counts.csv", analytic=True)
    frame = pd.read_csv(check, comment="#", dtype=str)
    out = ptsa.correct(frame, cal)
    assert (out["data"], out["calibration"]) == ("<DataFrame>", "<calibration dict>")
    assert "/tmp" not in json.dumps(out)
    bad = frame.copy()
    bad.loc[2, "pulses"] = "twelve"
    with pytest.raises(ptsa.PtsaError) as e:
        ptsa.discover(bad, analytic=True)
    assert str(e.value).startswith("<DataFrame>:") and "/tmp" not in str(e.value)
    with pytest.raises(ptsa.PtsaError, match="not plain JSON"):
        ptsa.correct(frame, {**cal, "x": float("nan")})
