"""The HTML report as a reader sees it, in a real headless browser (Debian's chromium, installed by
packaging/setup.sh for the tests): it renders, every image loads, nothing is wider than a 1280 px
window with every folded table opened, and no cell of prose is right-aligned. Checked on a small
report the test writes with `harness summary` (the report's opening answer, with its figure and a
table long enough to be folded), not on the full demo."""

import csv
import json
import shutil
import subprocess

import pytest

from harness_support import run_harness

HEADER = ["source", "case", "model", "estimator", "wheel_speeds", "rmse_deg", "nees", "zero_rmse_deg",
          "yardstick_rmse_deg", "max_vx_error_mps"]

WIDTH = 1280

# Runs in the page once it has loaded: opens every folded table, then reports the layout.
PROBE = """
<script>
window.addEventListener("load", () => {
  document.querySelectorAll("details").forEach(d => { d.open = true; });
  const root = document.documentElement;
  const images = [...document.images];
  const leftWhereProse = [...document.querySelectorAll("td, th")]
    .filter(c => !c.classList.contains("num"))
    .filter(c => !["left", "start"].includes(getComputedStyle(c).textAlign))
    .map(c => c.textContent);
  const wide = [...document.body.querySelectorAll("*")]
    .filter(e => e.getBoundingClientRect().right > root.clientWidth + 1)
    .map(e => e.tagName + ": " + e.textContent.slice(0, 60));
  const probe = document.createElement("pre");
  probe.id = "probe";
  probe.textContent = JSON.stringify({
    scrollWidth: root.scrollWidth, clientWidth: root.clientWidth,
    images: images.length,
    broken: images.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute("src")),
    folded: document.querySelectorAll("details").length,
    tables: document.querySelectorAll("table").length,
    rightAlignedProse: leftWhereProse, wide: wide,
  });
  document.body.appendChild(probe);
});
</script>
"""


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    pytest.fail("no chromium on PATH: packaging/setup.sh installs Debian's chromium for the tests",
                pytrace=False)


def layout_in_browser(html_path):
    """Opens `html_path` (with the probe added, next to it so relative images resolve) in headless
    chromium at a 1280 px wide window; returns what the probe measured."""
    probed = html_path.with_name("probed_" + html_path.name)
    probed.write_text(html_path.read_text().replace("</body>", PROBE + "</body>"))
    completed = subprocess.run(
        [chromium(), "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         f"--window-size={WIDTH},900", "--virtual-time-budget=10000", "--dump-dom", probed.as_uri()],
        capture_output=True, text=True, timeout=120)
    assert completed.returncode == 0, completed.stderr
    dom = completed.stdout
    start = dom.find('<pre id="probe">')
    assert start >= 0, f"the page's script did not run:\n{dom[:2000]}\n{completed.stderr[-2000:]}"
    text = dom[start + len('<pre id="probe">'):dom.index("</pre>", start)]
    return json.loads(text.replace("&quot;", '"').replace("&lt;", "<").replace("&gt;", ">")
                      .replace("&amp;", "&"))


@pytest.fixture(scope="module")
def small_report(harness_binary, tmp_path_factory):
    """A report of two sources with 22 estimator/model groups: figure, verdicts, headline table and
    a folded table of every group."""
    out = tmp_path_factory.mktemp("report")
    rows = out / "rows.csv"
    with open(rows, "w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(HEADER)
        for m, model in enumerate(["A", "B", "A+grip"]):
            for e, estimator in enumerate(["LKF", "EKF", "UKF", "UKF_scaled", "PF", "Luenberger"]):
                for c, case in enumerate(["ford_escort step_steer", "bmw_320i sine_with_dwell"]):
                    rmse = 0.05 + 0.1 * m + 0.07 * e + 0.3 * c
                    writer.writerow(["simulated cars", case, model, estimator, "yes", rmse, 1.0 + 0.2 * e,
                                     1.2, "", ""])
        for model in ["A", "A+grip"]:
            for speeds in ["yes", "no"]:
                writer.writerow(["a recorded track drive with a long name to wrap", "laps 2-6", model, "EKF",
                                 speeds, 0.6, 30.0, 1.82, 0.81, 0.4])
    run_harness(harness_binary, "summary", rows, "--out", out / "report")
    return out / "report"


def test_the_report_renders_with_its_images_within_1280_px_and_prose_left_aligned(small_report):
    layout = layout_in_browser(small_report / "report.html")
    assert layout["images"] >= 1 and not layout["broken"], layout
    assert layout["folded"] >= 1 and layout["tables"] >= 2, layout
    assert layout["scrollWidth"] <= layout["clientWidth"] <= WIDTH, layout
    assert not layout["wide"], layout["wide"][:5]
    assert not layout["rightAlignedProse"], layout["rightAlignedProse"][:5]


def test_the_markdown_report_opens_with_the_answer(small_report):
    md = (small_report / "report.md").read_text()
    lines = md.splitlines()
    assert lines[0].startswith("# ") and lines[2].startswith("## The answer")
    assert "![" in md.split("\n## ")[1].split("| source")[0], "the figure comes before the tables"
    assert "<details><summary>Table of 22 rows" in md
