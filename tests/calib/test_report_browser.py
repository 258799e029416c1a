"""The reports as a reader sees them: each page opened in a real headless Chromium, which must load every
image and lay out no figure wider than the page (skipped where no ``chromium`` is installed)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from sogdd.calib.demo import demo_calibration
from sogdd.calib.detection import Thumbnail
from sogdd.calib.report import write_report
from sogdd.calib.rig.demo import demo_rig
from sogdd.calib.rig.report import write_rig_report

CHROMIUM = shutil.which("chromium")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="needs chromium (a headless browser)")

#: the window the pages are laid out in (a laptop's browser window)
WINDOW = (1200, 1600)

#: appended to a copy of the page: once everything has loaded, what the browser made of each image
PROBE = """<script>
window.addEventListener("load", () => {
  const page = document.documentElement.clientWidth, body = document.body.clientWidth;
  const images = [...document.images].map(im => ({src: im.getAttribute("src"), complete: im.complete,
    natural: im.naturalWidth, right: im.getBoundingClientRect().right}));
  const out = document.createElement("pre");
  out.id = "probe";
  out.textContent = JSON.stringify({page, body, scroll: document.documentElement.scrollWidth, images});
  document.body.appendChild(out);
});
</script>"""


def browse(page: Path, tmp: Path) -> dict:
    """Open a copy of ``page`` (beside the original, so its figures resolve) in headless Chromium with
    :data:`PROBE` appended, and return what the probe wrote into the DOM."""
    probe = page.with_name(page.stem + ".probe.html")
    probe.write_text(page.read_text().replace("</body>", PROBE + "</body>"))
    profile = tmp / f"chromium-{page.parent.name}"
    cmd = [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={profile}", f"--window-size={WINDOW[0]},{WINDOW[1]}",
           "--virtual-time-budget=5000", "--dump-dom", probe.as_uri()]
    dom = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    found = re.search(r'<pre id="probe">(.*?)</pre>', dom, flags=re.S)
    assert found, f"the probe did not run in {page}: {dom[-500:]}"
    probe.unlink()
    return json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<")
                      .replace("&gt;", ">"))


def problems(seen: dict) -> list[str]:
    """What a reader would see wrong: an image that did not load, a figure drawn wider than the page's
    column (shrunk to fit, its text unreadable) or reaching past the window, a page that scrolls sideways."""
    out = [f"{im['src']}: not loaded" for im in seen["images"] if not im["complete"] or im["natural"] == 0]
    out += [f"{im['src']}: {im['natural']} px wide, the page {seen['body']}" for im in seen["images"]
            if im["natural"] > seen["body"]]
    out += [f"{im['src']}: reaches {im['right']:.0f} px, the window {seen['page']}" for im in seen["images"]
            if im["right"] > seen["page"] + 0.5]
    if seen["scroll"] > seen["page"]:
        out.append(f"the page scrolls sideways: {seen['scroll']} px for {seen['page']}")
    return out


@pytest.fixture(scope="module")
def reports(tmp_path_factory) -> dict[str, Path]:
    """The one-camera report of the demo calibration (pictures on grey arrays) and the demo rig's report
    with its cameras' own reports."""
    tmp = tmp_path_factory.mktemp("reports")
    cal = demo_calibration()
    mono = write_report(cal, tmp / "mono", images=[np.full((480, 640), 120, np.uint8)] * len(cal.names))
    rig = demo_rig()
    thumbs = {c.name: [Thumbnail(np.full((180, 240), 128, np.uint8), 0.375)] * len(rig.frames)
              for c in rig.cameras}
    page = write_rig_report(rig, tmp / "rig", thumbnails=thumbs)
    return {"mono": mono, "rig": page, "rig-left": page.parent / "left" / "report.html"}


@pytest.mark.parametrize("which", ["mono", "rig", "rig-left"])
def test_every_image_loads_and_no_figure_is_wider_than_the_page(which, reports, tmp_path):
    page = reports[which]
    seen = browse(page, tmp_path)
    srcs = {im["src"] for im in seen["images"]}
    assert srcs == set(re.findall(r"<img src=['\"]([^'\"]+)['\"]", page.read_text()))  # the browser saw all
    assert len(srcs) >= 5
    assert problems(seen) == []


def test_the_check_fails_on_a_missing_image_and_on_a_wide_figure(tmp_path):
    """The checks above can fail: a figure removed, and a figure drawn wider than the page, are found."""
    cal = demo_calibration()
    page = write_report(cal, tmp_path / "mono")
    (page.parent / "report" / "distortion.png").unlink()
    from sogdd.calib.figures import pyplot, save_figure

    fig = pyplot().figure(figsize=(16, 3))  # 1600 px at save_figure's 100 dpi
    save_figure(fig, page.parent / "report" / "wide.png")
    page.write_text(page.read_text().replace(
        "</body>", "<img src='report/wide.png' style='max-width:none' alt='wide'></body>"))
    found = problems(browse(page, tmp_path))
    assert any(p.startswith("report/distortion.png: not loaded") for p in found), found
    assert any(p.startswith("report/wide.png: 1600 px wide") for p in found), found
    assert any(p.startswith("report/wide.png: reaches") for p in found), found
    assert any(p.startswith("the page scrolls sideways") for p in found), found
