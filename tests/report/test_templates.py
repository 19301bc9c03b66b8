"""Every HTML page of report/ is rendered from its Jinja2 template in report/templates/ (issue 12)."""

from __future__ import annotations

import dataclasses
import fnmatch
import re
import tomllib
from pathlib import Path

import pytest

from tests.report.test_report_folders import _profile

ROOT = Path(__file__).resolve().parents[2]
TEMPLATES = ROOT / "src" / "longprofile" / "report" / "templates"
MARK = "<!-- rendered from the test's copy of {} -->"

#: Each report: its template and the sections its page shows.
SECTIONS = {
    "road": ("road_report.html", ["Profile", "IRI per segment", "Localised roughness", "Files"]),
    "rail": ("rail_report.html", ["Warnings", "Flagged sensors (excluded)", "Alarms", "Control surveys",
                                  "Maximum settlement (Monte Carlo, §4.3)", "Initial profile and angles (§4.4)"]),
    "acceptance": ("acceptance_report.html", ["Lots", "Localized roughness", "Grinding simulation (target 1 m/km)",
                                              "Histogram"]),
    "network": ("network_report.html", ["Condition along each route", "Distribution of the segment IRI",
                                        "Worst segments", "Routes, worst mean IRI first", "Files that failed (1)",
                                        "Run"]),
}


def _write_road(out):
    from longprofile.report import write_road_report
    from longprofile.road import analyse_roughness

    write_road_report(analyse_roughness(_profile(), segment_length=100.0), out, title="T <&>")


def _write_rail(out):
    from longprofile.rail import estimate_settlement, simulate_site, validate_site
    from longprofile.report import write_rail_report

    syn = simulate_site("mittersheim-like", seed=2, sampling_minutes=120, n_days=6)
    controls = syn.survey.assign(date=str(syn.truth.days[3])[:10])  # a control survey: the page's controls section
    write_rail_report(estimate_settlement(validate_site(syn.sensors, syn.readings, syn.survey, controls)), out,
                      title="T <&>")


def _write_acceptance(out):
    from longprofile.report import write_acceptance_report
    from longprofile.road import default_spec, simulate_grinding, smoothness_acceptance

    prof = _profile()
    spec = dataclasses.replace(default_spec(), localized_threshold=1.0)
    result = smoothness_acceptance(prof, spec)
    write_acceptance_report(result, out, grinding=simulate_grinding(prof, spec, acceptance=result), title="T <&>")


def _write_network(out):
    from longprofile.batch import summarize_network
    from longprofile.report import write_network_report
    from tests.batch.test_network_report import _results

    summary = summarize_network(_results({"a": (0.0, 100.0, [1.0, 2.0]), "b": (0.0, 100.0, [3.0])},
                                         failed=[("c.erd", "bad <file>")]))
    write_network_report(summary, out, title="T <&>")


WRITERS = {"road": _write_road, "rail": _write_rail, "acceptance": _write_acceptance, "network": _write_network}


@pytest.fixture
def marked_templates(tmp_path, monkeypatch):
    """The report templates copied with a mark at the top of each, and the render helper reading the copies."""
    import jinja2

    from longprofile.report import _html

    copies = tmp_path / "templates"
    copies.mkdir()
    for src in TEMPLATES.iterdir():
        (copies / src.name).write_text(MARK.format(src.name) + src.read_text(encoding="utf-8"), encoding="utf-8")
    env = _html._environment.__wrapped__()  # the same options; only the folder differs
    env.loader = jinja2.FileSystemLoader(copies)
    monkeypatch.setattr(_html, "_environment", lambda: env)
    return copies


@pytest.mark.parametrize("report", list(SECTIONS))
def test_each_report_page_is_rendered_from_its_template(report, tmp_path, marked_templates):
    template, sections = SECTIONS[report]
    assert (TEMPLATES / template).is_file()
    WRITERS[report](tmp_path / report)
    page = (tmp_path / report / "index.html").read_text(encoding="utf-8")
    assert page.startswith(MARK.format(template))  # the page comes from the template, not from Python code
    found = re.findall(r"<h2>([^<]*)</h2>", page)
    assert [s for s in found if s in sections] == sections, found  # every section, in this order
    assert "<title>T &lt;&amp;&gt;</title>" in page and "<h1>T &lt;&amp;&gt;</h1>" in page  # escaped once
    assert page.count('src="data:image/png;base64,') >= 3
    assert "{{" not in page and "{%" not in page


def test_no_report_writer_builds_a_page_in_python():
    """The HTML skeleton of a page (doctype, head, body) is only in the templates."""
    for module in sorted((ROOT / "src" / "longprofile" / "report").glob("*.py")):
        text = module.read_text(encoding="utf-8").lower()
        assert "<!doctype" not in text and "<body" not in text and "</html>" not in text, module.name


def test_every_template_is_package_data():
    """pyproject's package data takes every file in report/templates/ (an installed wheel has them)."""
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["longprofile"]
    files = [f"report/templates/{p.name}" for p in TEMPLATES.iterdir()]
    assert len(files) >= 4
    for f in files:
        assert any(fnmatch.fnmatch(f, pattern) for pattern in data), f


def test_a_missing_context_value_is_an_error_not_an_empty_string():
    import jinja2

    from longprofile.report._html import _environment

    with pytest.raises(jinja2.UndefinedError, match="'sigma' is undefined"):
        _environment().from_string("sigma = {{ sigma }} deg").render(title="x")
