"""longprofile.io atomic writes: format fallback, umask without os.umask, kept permissions, one OutputError."""

from __future__ import annotations

import os
import stat
import sys

import pytest

from longprofile import _atomic
from longprofile.errors import OutputError
from longprofile.io import atomic_path, atomic_write_bytes, save_figure


def _fig():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 2))
    FigureCanvasAgg(fig)
    fig.add_subplot().plot([0, 1], [0, 1])
    return fig


def test_save_figure_without_suffix_uses_the_default_format(tmp_path):
    import matplotlib

    path = save_figure(_fig(), tmp_path / "figure")
    assert matplotlib.rcParams["savefig.format"] == "png"
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["figure"]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/self/status is Linux")
def test_the_umask_is_read_without_changing_it(monkeypatch):
    real = os.umask(0o022)
    os.umask(real)

    def forbidden(mask):
        raise AssertionError("os.umask changes the process-wide umask (racy under threads)")

    monkeypatch.setattr(_atomic.os, "umask", forbidden)
    assert _atomic._umask() == real


def test_a_new_file_gets_the_default_mode_and_a_replaced_file_keeps_its_mode(tmp_path):
    new = atomic_write_bytes(tmp_path / "new.csv", b"a\n")
    assert stat.S_IMODE(new.stat().st_mode) == 0o666 & ~_atomic._umask()
    old = tmp_path / "old.csv"
    old.write_bytes(b"old\n")
    os.chmod(old, 0o600)
    atomic_write_bytes(old, b"new\n")
    assert old.read_bytes() == b"new\n"
    assert stat.S_IMODE(old.stat().st_mode) == 0o600


def test_an_oserror_in_the_write_becomes_one_output_error(tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(b"old\n")
    with pytest.raises(OutputError) as info:
        with atomic_path(path) as tmp:
            tmp.write_bytes(b"partial")
            raise OSError(28, "No space left on device")
    msg = str(info.value)
    assert len(msg.splitlines()) == 1 and str(path) in msg and "No space left on device" in msg
    assert "cannot write" in msg and msg.count("cannot write") == 1
    assert path.read_bytes() == b"old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


def test_a_folder_that_cannot_be_created_is_an_output_error(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(OutputError, match="cannot write"):
        atomic_write_bytes(tmp_path / "afile" / "t.csv", b"x")


def test_an_output_error_of_the_body_passes_unchanged(tmp_path):
    with pytest.raises(OutputError, match="^mine$"):
        with atomic_path(tmp_path / "t.csv"):
            raise OutputError("mine")


def test_a_failed_replace_is_an_output_error(tmp_path, monkeypatch):
    path = tmp_path / "t.csv"

    def broken(src, dst):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(_atomic.os, "replace", broken)
    with pytest.raises(OutputError, match="Permission denied"):
        atomic_write_bytes(path, b"x")
    assert list(tmp_path.iterdir()) == []
