"""The reports in a real browser: headless Chromium opens each page, with no console error, every figure loaded.

Chromium comes from the distribution's packages (``apt-get install chromium``;
``.ci/run`` installs it). Without it the tests skip and say so, except on CI
(``CI`` set), where a missing browser is an error. Screenshots are saved in
the test's temporary folder; with ``SINDYBENCH_SCREENSHOTS=<folder>`` they
are copied there too (``docs/_static`` for the docs page).
"""

import os
import shutil

import pytest

from _chromium import Browser, find_chromium
from _report_data import write_reports

PAGES = ("identified", "plain", "benchmark", "index")


@pytest.fixture(scope="module")
def browser():
    executable = find_chromium()
    if executable is None:
        reason = "no Chromium installed (apt-get install chromium): the reports are not opened in a browser"
        if os.environ.get("CI"):
            pytest.fail(f"CI must run the browser tests: {reason}")
        pytest.skip(reason)
    with Browser(executable, width=1280, height=1600) as b:
        yield b


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    return write_reports(tmp_path_factory.mktemp("browser"))[0]


@pytest.fixture(scope="module")
def screenshots(tmp_path_factory):
    folder = tmp_path_factory.mktemp("screenshots")
    yield folder
    target = os.environ.get("SINDYBENCH_SCREENSHOTS")
    if target:
        for png in folder.glob("*.png"):
            shutil.copy(png, target)


_FIGURES = """(() => {
  const broken = [];
  document.querySelectorAll("img").forEach((img, i) => {
    if (!img.complete || img.naturalWidth === 0) broken.push("img " + i + " " + img.alt);
  });
  document.querySelectorAll("svg").forEach((svg, i) => {
    const box = svg.getBoundingClientRect();
    if (box.width === 0 || box.height === 0) broken.push("svg " + i);
  });
  return {n_img: document.images.length, broken: broken};
})()"""

# each equation laid out on one line by the browser's MathML (not as a column of loose tokens)
_MATHS = """Array.from(document.querySelectorAll("math")).map(m => {
  const box = m.getBoundingClientRect();
  return [getComputedStyle(m).display, Math.round(box.width), Math.round(box.height)];
})"""


@pytest.mark.parametrize("name", PAGES)
def test_page_opens_fast_without_errors(browser, pages, screenshots, name):
    load_s = browser.open(pages[name].as_uri())
    assert browser.console_errors() == []
    figures = browser.evaluate(_FIGURES)
    assert figures["broken"] == []
    assert figures["n_img"] >= {"identified": 5, "plain": 1, "benchmark": 1, "index": 0}[name]
    assert load_s < 1.0, f"{name} took {load_s:.2f} s to load"
    for display, width, height in browser.evaluate(_MATHS):
        assert display in ("math", "inline math", "block math") and width > 20 and height < 60, (display, width, height)
    browser.screenshot(screenshots / f"report_{name}.png")
    assert (screenshots / f"report_{name}.png").stat().st_size > 10_000


def test_a_broken_figure_and_a_console_error_are_caught(browser, tmp_path):
    """The checks above can fail: a page with a broken image and a script error is reported as such."""
    page = tmp_path / "broken.html"
    page.write_text('<!DOCTYPE html><html><body><img alt="x" src="data:image/png;base64,AAAA">'
                    "<script>console.error('boom'); undefinedFunction();</script></body></html>")
    browser.open(page.as_uri())
    errors = browser.console_errors()
    assert any("boom" in e for e in errors) and any("undefinedFunction" in e for e in errors)
    assert browser.evaluate(_FIGURES)["broken"] == ["img 0 x"]


def test_the_candidates_table_sorts_on_a_click(browser, pages):
    browser.open(pages["identified"].as_uri())
    column = """Array.from(document.querySelectorAll("#candidates tbody tr")).map(r => r.cells[%d].textContent)"""
    headers = browser.evaluate("""Array.from(document.querySelectorAll("#candidates th")).map(h => h.textContent)""")
    mean = headers.index("mean")
    browser.evaluate(f"""document.querySelectorAll("#candidates th")[{mean}].click()""")
    values = [float(v) for v in browser.evaluate(column % mean)]
    assert values == sorted(values) and len(values) > 3
    browser.evaluate(f"""document.querySelectorAll("#candidates th")[{mean}].click()""")
    assert [float(v) for v in browser.evaluate(column % mean)] == sorted(values, reverse=True)
    assert browser.console_errors() == []


def test_what_a_person_sees_first(browser, pages, screenshots):
    """The first screen of the identified model's page: the scores, the equations, the test record's error."""
    browser.open(pages["identified"].as_uri())
    first = browser.evaluate("""(() => {
      const top = el => el.getBoundingClientRect().top;
      return {cards: top(document.querySelector(".cards")), eq: top(document.querySelector(".eq")),
              figure: top(document.querySelector("#summary figure")), height: window.innerHeight};
    })()""")
    assert first["cards"] < first["eq"] < first["figure"] < first["height"]
    browser.screenshot(screenshots / "report_first_screen.png")
