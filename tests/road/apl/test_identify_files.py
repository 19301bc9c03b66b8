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


def _bench(tmp_path, name, t, values, time_column="time_s", column="u_mm"):
    import pandas as pd

    path = tmp_path / name
    pd.DataFrame({time_column: t, column: values}).to_csv(path, index=False)
    return path


def test_road_identify_checks_a_bench_files_time_stamps_against_dx_over_speed(tmp_path, capsys):
    """The probe's 7.5 ms bench (paper 000 §4.1, Te) identified with the default dt = 0.05 / 20 = 2.5 ms: refused on
    the line of the first step, naming the --dx that gives the file's step; accepted with --dx 0.15."""
    from scipy import signal

    from longprofile.cli.app import main
    from longprofile.road.apl import apl_model

    m = apl_model(20.0, 0.15)
    k = np.arange(2000)
    u = np.where(((k + 100) // 200) % 2 == 1, 10.0, 0.0)  # crenels, mm
    y = signal.lfilter(m.numerator, m.denominator, u) + np.random.default_rng(0).normal(0, 0.02, k.size)
    t = k * 7.5e-3
    ui, yi = _bench(tmp_path, "u.csv", t, u), _bench(tmp_path, "y.csv", t, y, column="y_mm")
    args = ["road", "identify", "--input", str(ui), "--input-column", "u_mm", "--output", str(yi),
            "--output-column", "y_mm", "-o", str(tmp_path / "m.json")]
    assert main(args) == 2
    err = capsys.readouterr().err.replace("\n", " ")
    assert "line 3: time 0.0075 s" in err and "0.0025 s" in err and "--dx 0.15" in err, err
    assert not (tmp_path / "m.json").exists()
    assert main(args + ["--dx", "0.15"]) == 0, capsys.readouterr().err


def test_bench_time_stamps_another_rate_a_dropped_sample_and_no_unit_are_refused(tmp_path):
    from longprofile.errors import InputFormatError
    from longprofile.io import read_sampled_column

    k = np.arange(1000)
    v = np.sin(k / 10.0)
    jitter = np.random.default_rng(1).uniform(-0.05, 0.05, k.size) * 2.5  # +-5 % of the step, ms: accepted
    ok = _bench(tmp_path, "ok.csv", k * 2.5 + jitter, v, time_column="time_ms")
    assert np.allclose(read_sampled_column(ok, "u_mm", dx=0.05, speed=20.0), v * 1e-3)
    slow = _bench(tmp_path, "slow.csv", k * 2.6e-3, v)  # 4 % slower: each step within tolerance, the rate not
    with pytest.raises(InputFormatError, match=r"line 1001: .* mean step of 0\.0026 s.*--dx 0\.052"):
        read_sampled_column(slow, "u_mm", dx=0.05, speed=20.0)
    dropped = _bench(tmp_path, "dropped.csv", np.delete(k, 500) * 2.5e-3, np.delete(v, 500))
    with pytest.raises(InputFormatError, match=r"line 502: time 1\.2525 s is 0\.005 s after.*missing or repeated"):
        read_sampled_column(dropped, "u_mm", dx=0.05, speed=20.0)
    bare = _bench(tmp_path, "bare.csv", k * 2.5e-3, v, time_column="time")
    with pytest.raises(InputFormatError, match="'time' does not give its unit"):
        read_sampled_column(bare, "u_mm", dx=0.05, speed=20.0)
    with pytest.raises(InputFormatError, match="time stamps"):
        read_sampled_column(ok, "u_mm", dx=0.05)
