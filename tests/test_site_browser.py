"""The gallery site in a real browser (Playwright driving Debian's Chromium, from file://):
the front page's sections and pictures, an entry page's 3-D view, frame player, recipe download
and reproduce command, which really makes the same run again."""
from __future__ import annotations

import html
import json
import re
import shlex
import shutil
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from PIL import Image

from procgen.gallery import build_gallery

playwright = pytest.importorskip("playwright.sync_api", reason="the test extra installs playwright")

ONLY = ["demo/*", "weathering-life-flat-life"]
ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"]


@pytest.fixture(scope="module")
def site(host, tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    rep = build_gallery(host, only=ONLY, quick=True, out_dir=out, progress=False)
    assert not rep.failed and len(rep.results) == 2
    return out


@pytest.fixture(scope="module")
def browser():
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    assert exe, "Chromium is needed (Debian package 'chromium'; .ci/run installs it)"
    with playwright.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=ARGS)
        yield b
        b.close()


def _open(browser, url):
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    problems: list[str] = []
    page.on("pageerror", lambda e: problems.append(str(e)))
    page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)
    page.goto(url)
    page.wait_for_load_state("load")
    page.evaluate("for (const i of document.images) i.loading = 'eager'")
    page.wait_for_function("Array.from(document.images).every(i => i.complete)", timeout=60_000)
    return page, problems


def test_front_page_sections_pictures_and_links(site, browser):
    page, problems = _open(browser, (site / "index.html").as_uri())
    toc = page.eval_on_selector_all("nav.toc a", "as => as.map(a => a.getAttribute('href'))")
    assert toc == ["#demo", "#weathering"]
    for anchor in toc:
        assert page.locator(f"section{anchor} .card").count() >= 1
    widths = page.eval_on_selector_all("img", "is => is.map(i => i.naturalWidth)")
    assert len(widths) >= 3 and min(widths) > 0, widths
    weight = (site / "index.html").stat().st_size + sum(
        (site / src).stat().st_size for src in page.eval_on_selector_all("img", "is => is.map(i => i.getAttribute('src'))"))
    assert weight < 2_000_000            # light thumbnails, not the runs' own pictures
    page.click("#demo .card h3 a")
    page.wait_for_load_state("load")
    assert page.url.endswith("demo-basics/index.html#seed-7")
    assert problems == []


def test_entry_page_3d_view_renders_the_glb(site, browser):
    page, problems = _open(browser, (site / "demo-basics" / "index.html").as_uri())
    page.click(".view3d button")
    page.wait_for_selector(".view3d[data-loaded], .view3d[data-failed]", timeout=90_000)
    assert page.locator(".view3d[data-failed]").count() == 0
    viewer = page.locator("model-viewer").first
    viewer.scroll_into_view_if_needed()
    page.wait_for_timeout(1500)
    shot = site / "viewer.png"
    viewer.screenshot(path=str(shot))
    px = np.asarray(Image.open(shot).convert("RGB")).astype(float)
    background = np.array([0xdf, 0xe3, 0xe8], float)
    drawn = np.abs(px - background).sum(axis=2) > 40
    assert drawn.mean() > 0.05, "the viewer drew nothing but its background"
    assert px[drawn].std() > 10            # shaded terrain, not a flat silhouette
    assert problems == []


def test_entry_page_frames_play(site, browser):
    page, problems = _open(browser, (site / "weathering-life-flat-life" / "index.html").as_uri())
    big = page.locator(".player img.big").first
    first = big.get_attribute("src")
    page.locator(".player button").first.click()
    page.wait_for_function("s => document.querySelector('.player img.big').getAttribute('src') !== s", arg=first,
                           timeout=5_000)
    assert page.locator(".player .strip img").count() >= 2
    assert problems == []


def test_reproduce_command_and_recipe_download_make_the_same_run(site, host, tmp_path):
    text = (site / "demo-basics" / "index.html").read_text()
    recipe = re.search(r'<a href="([^"]+\.toml)" download>', text).group(1)
    shipped = tomllib.loads((site / "demo-basics" / recipe).read_text())
    assert [s["rule"] for s in shipped["steps"]][0] == "points.poisson_disk"
    cmd = shlex.split(html.unescape(re.search(r'<pre class="cmd">([^<]+)</pre>', text).group(1)))
    assert cmd[:3] == ["procgen", "run", "demo/basics"] and "--seed" in cmd
    cmd[cmd.index("--out") + 1] = str(tmp_path / "again")
    r = subprocess.run([sys.executable, "-m", "procgen.cli", *cmd[1:]], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    again = json.loads((tmp_path / "again" / "run.json").read_text())["reports"]
    gallery = json.loads((site / "demo-basics" / "seed-7" / "run.json").read_text())["reports"]
    assert again == gallery
    a = np.asarray(Image.open(tmp_path / "again" / "terrain_height.png"))
    b = np.asarray(Image.open(site / "demo-basics" / "seed-7" / "terrain_height.png"))
    assert np.array_equal(a, b)
