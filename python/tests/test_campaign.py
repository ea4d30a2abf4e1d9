"""The yield study as Ray tasks gives the command line's JSON, on 1 or 2 workers."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

import ptsa
from ptsa import campaign

from test_same_as_cli import ROOT, cli, cli_json

ARGS = ["--yield", "40", "--seed", "9", "--gates", "2", "--gate-s", "0.02", "--spec-sf-ppm", "15000"]


def test_pieces_cover_the_study_once():
    assert campaign.pieces(10, 4) == [(0, 4), (4, 4), (8, 2)]
    assert campaign.pieces(8, 4) == [(0, 4), (4, 4)]


def test_without_ray_the_pieces_join_into_the_command_lines_study():
    want = cli_json("monte-carlo", *ARGS)
    got = campaign.yield_study(40, ray="none", task_size=7, seed=9, gates=2, gate_s=0.02, spec_sf_ppm=15000)
    assert got == want


@pytest.mark.parametrize("workers", [1, 2])
def test_on_a_local_ray_the_json_is_the_command_lines(workers):
    want = cli("monte-carlo", *ARGS, "--json").stdout
    r = subprocess.run(
        [sys.executable, "-m", "ptsa.campaign", "monte-carlo", *ARGS,
         "--ray", "local", "--num-cpus", str(workers), "--task-size", "10"],
        capture_output=True, text=True, cwd=ROOT, env=os.environ,
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout == want  # byte for byte


@pytest.fixture(scope="module")
def rack(tmp_path_factory):
    """A folder of three simulated counter records (20 s of 10 ms gates each, seeds 0 to
    2) and a file that is not a record."""
    d = tmp_path_factory.mktemp("rack")
    for k in range(3):
        cli("noise", "--simulate", "--seconds", "20", "--gate-s", "0.01", "--seed", str(k),
            "--output", str(d / f"unit{k}.csv"))
    (d / "notes.txt").write_text("not a record: not read\n")
    return d


def folder_campaign(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "ptsa.campaign", "noise", *args],
                          capture_output=True, text=True, cwd=ROOT, env=os.environ)


def test_a_folder_identified_on_a_local_ray_is_the_command_lines_lines(rack):
    # Two workers only: each record is a task of its own, so the count of workers cannot
    # change a line; the yield study above is the campaign whose tasks share a result.
    want = "".join(
        cli("noise", "--counts", str(rack / f"unit{k}.csv"), "--identify", "--json").stdout for k in range(3)
    )
    r = folder_campaign(str(rack), "--identify", "--ray", "local", "--num-cpus", "2")
    assert r.returncode == 0, r.stderr
    assert r.stdout == want  # byte for byte
    assert all(json.loads(line)["identification"] is not None for line in r.stdout.splitlines())


def test_a_record_refused_is_an_error_line_and_the_others_are_analysed(rack, tmp_path):
    for k in (0, 3):
        (tmp_path / f"unit{k}.csv").write_text((rack / f"unit{k % 3}.csv").read_text())
    (tmp_path / "unit1.csv").write_text("time_s,pulses,ticks\n0.01,320,640\n0.02,x,640\n")
    (tmp_path / "unit2.csv").write_bytes(b"time_s,pulses,ticks\n0.01,320,640\n0.02,3\xff0,640\n")
    r = folder_campaign(str(tmp_path), "--compare")
    assert r.returncode == 1
    bad = str(tmp_path / "unit1.csv")
    assert r.stderr.splitlines() == [
        cli("noise", "--counts", bad, ok=False).stderr.strip(),
        f"error: {tmp_path / 'unit2.csv'}:3: not UTF-8 text (a bad byte at byte offset 39); "
        "expected a CSV record in UTF-8",
    ]
    assert r.stdout == "".join(
        cli("noise", "--counts", str(tmp_path / f"unit{k}.csv"), "--compare", "--json").stdout for k in (0, 3)
    )


def test_options_are_refused_once_before_any_record(rack):
    r = folder_campaign(str(rack), "--confidence", "2")
    assert (r.returncode, r.stdout) == (1, "")
    assert r.stderr == "error: confidence 2: expected a level more than 0 and less than 1 (0.95 for 95 %)\n"


def test_unknown_options_and_a_bad_seed_are_refused_before_any_record(rack):
    with pytest.raises(ptsa.PtsaError, match="identfy: not an option"):
        campaign.noise_folder(str(rack), identfy=True)
    r = folder_campaign(str(rack), "--seed", "-1")
    assert (r.returncode, r.stdout) == (1, "")
    assert r.stderr == "error: seed -1: expected a whole number from 0 to 2^64 - 1\n"


def test_an_empty_folder_is_refused(tmp_path):
    r = folder_campaign(str(tmp_path))
    assert r.returncode == 1 and r.stderr == f"error: {tmp_path}: no records (.csv files) in the folder\n"


def hidden_campaign(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "ptsa.campaign", "hidden", *args],
                          capture_output=True, text=True, cwd=ROOT, env=os.environ)


def test_a_naming_campaign_in_shards_on_a_local_ray_is_the_whole_run():
    # 18 kinds, 2 sets each, in 5 shards on 2 workers, against the run in one process.
    whole = campaign.hidden("effects", sets=2, seed=11, analytic=True)
    assert len(whole["json"]["outcomes"]) == 36
    assert whole["json"]["failures"] == whole["failures"]
    r = hidden_campaign("effects", "--sets", "2", "--seed", "11", "--analytic", "--json",
                        "--ray", "local", "--num-cpus", "2", "--tasks", "5")
    assert r.returncode == (1 if whole["failures"] else 0), r.stderr
    assert r.stdout == whole["text"] + "\n"
    # The sets that matter and the table are the whole run's; only the title's wall time
    # differs.
    t = hidden_campaign("effects", "--sets", "2", "--seed", "11", "--analytic", "--tasks", "3")
    title = len(whole["notable"].splitlines())
    got, want = t.stdout.splitlines(), (whole["notable"] + whole["table"]).splitlines()
    assert got[title].startswith("hidden-effect campaign: 2 sets per kind, seed 11;")
    assert got[:title] + got[title + 1:] == want[:title] + want[title + 1:]


def test_a_naming_campaign_refuses_what_it_does_not_have_before_any_task():
    r = hidden_campaign("params", "--sets", "1", "--seed", "1", "--analytic", "--ray", "local")
    assert (r.returncode, r.stdout) == (1, "")
    assert r.stderr == "error: --analytic: only the effects and lab campaigns have it, not params\n"
    with pytest.raises(ptsa.PtsaError, match="at least 1 set"):
        campaign.hidden("sigma", sets=0, seed=1)
    with pytest.raises(ptsa.PtsaError, match="tasks 0"):
        campaign.hidden("sigma", sets=1, seed=1, tasks=0)
    with pytest.raises(ptsa.PtsaError, match="at least 1 set"):
        campaign.hidden("sigma", sets=-3, seed=1)
    with pytest.raises(ptsa.PtsaError, match=r"seed -1: expected a whole number from 0 to 2\^64 - 1"):
        campaign.hidden("sigma", sets=1, seed=-1)
