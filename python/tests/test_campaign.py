"""The yield study as Ray tasks gives the command line's JSON, on 1 or 2 workers."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

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
    want = cli_json("monte-carlo", *ARGS)
    r = subprocess.run(
        [sys.executable, "-m", "ptsa.campaign", "monte-carlo", *ARGS,
         "--ray", "local", "--num-cpus", str(workers), "--task-size", "10"],
        capture_output=True, text=True, cwd=ROOT, env=os.environ,
    )
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == want


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
    want = [cli_json("noise", "--counts", str(rack / f"unit{k}.csv"), "--identify") for k in range(3)]
    r = folder_campaign(str(rack), "--identify", "--ray", "local", "--num-cpus", "2")
    assert r.returncode == 0, r.stderr
    assert [json.loads(line) for line in r.stdout.splitlines()] == want
    assert all(w["identification"] is not None for w in want)


def test_a_record_refused_is_an_error_line_and_the_others_are_analysed(rack, tmp_path):
    for k in (0, 2):
        (tmp_path / f"unit{k}.csv").write_text((rack / f"unit{k}.csv").read_text())
    (tmp_path / "unit1.csv").write_text("time_s,pulses,ticks\n0.01,320,640\n0.02,x,640\n")
    r = folder_campaign(str(tmp_path))
    assert r.returncode == 1
    want = cli("noise", "--counts", str(tmp_path / "unit1.csv"), ok=False).stderr
    assert r.stderr == want
    assert [json.loads(line) for line in r.stdout.splitlines()] == [
        cli_json("noise", "--counts", str(tmp_path / f"unit{k}.csv")) for k in (0, 2)
    ]


def test_an_empty_folder_is_refused(tmp_path):
    r = folder_campaign(str(tmp_path))
    assert r.returncode == 1 and r.stderr == f"error: {tmp_path}: no records (.csv files) in the folder\n"
