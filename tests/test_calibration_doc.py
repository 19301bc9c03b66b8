"""docs/calibration.md's road profile count agrees with its table (and the road guide quotes it): the cells counted
are the cells shown, in bold exactly when their coverage lies in 85-95 %."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _road_cells(text: str) -> list[tuple[float, bool]]:
    """(coverage %, shown in bold) of every cell of the road profile table."""
    section = text.split("## Road profile", 1)[1].split("\n## ", 1)[0]
    rows = [ln for ln in section.splitlines() if ln.startswith("| ") and "%" in ln]
    cells = []
    for row in rows:
        for cell in row.strip("|").split("|")[1:]:
            m = re.match(r"\s*(\*\*)?([0-9.]+) %", cell)
            assert m, f"a road table cell without a coverage: {cell!r}"
            cells.append((float(m.group(2)), bool(m.group(1))))
    return cells


def test_the_road_count_is_the_table_s():
    text = (ROOT / "docs" / "calibration.md").read_text()
    cells = _road_cells(text)
    inside = [c for c, _ in cells if 85.0 <= c <= 95.0]
    assert all(bold == (85.0 <= c <= 95.0) for c, bold in cells), "bold marks the cells in 85-95 %"
    n, total = len(inside), len(cells)
    assert f"| road profile | {n} of {total} (32 draws)" in text
    assert f"Met: {n} of the table's {total} cells ({total // 2} families" in text
    outside = sorted(c for c, _ in cells if not 85.0 <= c <= 95.0)
    met = text.split("Met: ", 1)[1].split("Not met", 1)[0]
    assert all(f"{c:.1f} %" in met for c in outside), f"the cells outside {outside} are named"
    guide = " ".join((ROOT / "docs" / "guide" / "road.md").read_text().split())
    assert f"{n} of its {total} cells ({total // 2} families" in guide
    assert f"between {min(inside):.1f} and {max(inside):.1f} %" in guide
