"""The ``longprofile demo`` rail step (paper 004): report, figures and accuracy summary."""


def test_demo_writes_report_and_accuracy(tmp_path):
    from longprofile.demos.rail import run_demo

    files = run_demo(tmp_path)
    assert (tmp_path / "rail" / "report" / "index.html") in files
    text = (tmp_path / "rail" / "accuracy.txt").read_text()
    assert "settlement RMS error" in text and "S34 (reversed)" in text
    assert all(f.exists() for f in files)
