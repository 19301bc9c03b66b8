"""road.apl identification checks and the model file: structure named by keyword, save_model atomic."""

from __future__ import annotations

import numpy as np
import pytest

from longprofile.errors import InputError


def test_an_unknown_structure_is_named_by_its_keyword_before_any_fit():
    from longprofile.road.apl import IDENTIFICATION_STRUCTURES, identify_trailer

    with pytest.raises(InputError) as info:
        identify_trailer(np.zeros(10), np.zeros(12), speed=20.0, dx=0.05, structure="arx")
    msg = str(info.value)
    assert "structure" in msg and "--" not in msg and "'arx'" in msg
    assert all(s in msg for s in IDENTIFICATION_STRUCTURES)


def test_the_public_structure_check_names_the_callers_flag():
    from longprofile.road.apl import IDENTIFICATION_STRUCTURES, check_identification_structure

    for s in IDENTIFICATION_STRUCTURES:
        assert check_identification_structure(s) == s
    with pytest.raises(InputError, match="^--structure must be one of 'oe', 'armax'; got 'arx'"):
        check_identification_structure("arx", flag="--structure")


def test_save_model_replaces_an_older_file_atomically(tmp_path, monkeypatch):
    import os

    from longprofile.road.apl import apl_model, load_model, save_model

    path = tmp_path / "model.json"
    save_model(path, apl_model(20.0, 0.05))
    before = path.read_bytes()
    assert load_model(path).dt == pytest.approx(0.05 / 20.0)

    def broken(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(OSError):
        save_model(path, apl_model(6.0, 0.05))
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["model.json"]


def test_road_identify_refuses_a_bad_structure_before_reading(tmp_path, capsys):
    from longprofile.cli.app import main

    code = main(["road", "identify", "--input", str(tmp_path / "missing-u.csv"), "--output",
                 str(tmp_path / "missing-y.csv"), "-o", str(tmp_path / "m.json"), "--structure", "arx"])
    err = capsys.readouterr().err
    assert code == 2 and "structure" in err and "arx" in err and "missing" not in err, err
    assert list(tmp_path.iterdir()) == []
