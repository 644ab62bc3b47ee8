"""The contact sheet opens in a real browser (headless Chromium) with every thumbnail loaded."""
from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
from PIL import Image

from procgen.gallery import build_gallery

CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--allow-file-access-from-files", "--virtual-time-budget=15000"]


def _chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    assert exe, "headless Chromium is needed (Debian package 'chromium'; .ci/run installs it)"
    return exe


def test_index_html_shows_every_thumbnail_in_chromium(host, tmp_path):
    out = tmp_path / "gallery"
    rep = build_gallery(host, only=["demo/*"], jobs=1, quick=True, out_dir=out, progress=False)
    assert not rep.failed
    index = out / "index.html"
    profile = tmp_path / "profile"
    r = subprocess.run([_chromium(), *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--enable-logging=stderr",
                        "--v=0", "--dump-dom", index.as_uri()], capture_output=True, text=True, timeout=180)
    dom = r.stdout
    m = re.search(r'data-images="(\d+)"[^>]*data-broken="(\d+)"', dom)
    assert m, f"page script did not run; chromium said: {r.stderr[-800:]}"
    images, broken = int(m.group(1)), int(m.group(2))
    assert images >= 2 and broken == 0
    errors = [line for line in r.stderr.splitlines() if "CONSOLE" in line and ("Error" in line or "Uncaught" in line)]
    assert errors == []
    shot = tmp_path / "shot.png"
    subprocess.run([_chromium(), *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--window-size=1200,900",
                    f"--screenshot={shot}", index.as_uri()], capture_output=True, timeout=180)
    px = np.asarray(Image.open(shot).convert("RGB")).astype(float)
    assert px.std() > 20     # the page painted thumbnails, not a blank or error page
