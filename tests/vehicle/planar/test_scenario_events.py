"""A shortened built-in drive says which of its scenario's events it leaves out (session 37).

Before, ``vehicle simulate --scenario paper --duration 5`` wrote a drive without steering or grade, and a 5 s
``hill`` drive never reached the hill, unsaid. The oracle is the simulated truth itself.
"""

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from longprofile.cli.app import app
from longprofile.vehicle import drive_scenario, missed_scenario_events, simulate_drive


def _drive(name, duration):
    return simulate_drive(drive_scenario(name, duration=duration), seed=0)


def test_a_5_s_paper_drive_names_the_steering_and_every_grade_ramp_that_its_truth_lacks():
    sim = _drive("paper", 5.0)
    assert np.all(sim.truth.steering_angle == 0) and np.all(sim.truth.slope == 0)  # the truth: nothing happens
    missed = missed_scenario_events("paper", sim)
    assert missed[0].startswith("the steering") and "none in this drive" in missed[0]
    assert [m.split(" at ")[0] for m in missed[1:]] == ["the grade ramp to +4 deg (+6.99 %)",
                                                         "the grade ramp to -3 deg (-5.24 %)", "the grade ramp to level"]


def test_an_event_the_truth_holds_is_not_named_and_one_it_lacks_is():
    sim = _drive("paper", 12.0)
    missed = " ".join(missed_scenario_events("paper", sim))
    assert math.isclose(sim.truth.slope.max(), math.radians(4.0), rel_tol=1e-3)  # the climb to +4 deg is in the drive
    assert "+4 deg" not in missed and "steering" not in missed
    assert sim.truth.slope.min() >= 0 and "-3 deg" in missed  # the descent to -3 deg is not
    hill = _drive("hill", 5.0)
    missed = missed_scenario_events("hill", hill)
    assert np.all(hill.truth.slope == 0) and any("+3.43 deg (+6 %) at 80-180 m" in m for m in missed)
    assert any(m.startswith("the braking 27 -> 12 m/s") for m in missed)
    assert any("(cut at 5 s)" in m for m in missed) and hill.truth.vx[-1] < 20  # the acceleration, cut


@pytest.mark.parametrize("name", ["paper", "hill", "low-mu"])
def test_a_drive_of_the_default_length_misses_nothing(name):
    assert missed_scenario_events(name, simulate_drive(name, seed=0)) == ()


def test_the_command_says_what_a_shortened_drive_leaves_out(tmp_path):
    runner = CliRunner()
    res = runner.invoke(app, ["vehicle", "simulate", "--scenario", "paper", "--duration", "5", "-o",
                              str(tmp_path / "p.csv")])
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "scenario paper is laid out for 40 s: this 5 s drive (125 m) leaves out or cuts the steering" in text
    assert "the grade ramp to +4 deg" in text
    res = runner.invoke(app, ["vehicle", "simulate", "--scenario", "low-mu", "--duration", "30", "-o",
                              str(tmp_path / "m.csv")])
    assert res.exit_code == 0 and "leaves out" not in res.output
    res = runner.invoke(app, ["vehicle", "simulate", "--help"], terminal_width=200)
    assert "leaves out or cuts those after its end" in " ".join(res.output.replace("│", " ").split())
