"""The spec example of docs/road-acceptance.md runs as copied (a newcomer's probe, session 36: it failed twice, on
the events table it named and on "MRI needs exactly two tracks" with a one-track profile)."""

from __future__ import annotations

from pathlib import Path

from longprofile.road import iso8608_profile
from longprofile.road.smoothness._acceptance import read_spec, smoothness_acceptance

DOC = Path(__file__).resolve().parents[3] / "docs" / "road-acceptance.md"


def test_the_documented_spec_runs_on_a_one_track_profile(tmp_path):
    text = DOC.read_text(encoding="utf-8")
    spec = tmp_path / "spec.toml"
    spec.write_text(text.split("```toml", 1)[1].split("```", 1)[0], encoding="utf-8")
    profile = iso8608_profile(2000.0, 0.05, "A", rng=3)  # one track, 2 km (the example's zone at 1000-1150 ft)
    res = smoothness_acceptance(profile, read_spec(spec))
    assert len(res.lots) >= 12
