"""The yield study as Ray tasks gives the command line's JSON, on 1 or 2 workers."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from ptsa import campaign

from test_same_as_cli import ROOT, cli_json

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
