"""SVG outputs open in Inkscape (Debian's inkscape, headless) without a warning, and keep their
provenance where Inkscape shows it (RDF in <metadata>, Document Properties > Metadata)."""
from __future__ import annotations

import json
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
from PIL import Image

from procgen.cli import main

DC = "{http://purl.org/dc/elements/1.1/}"


def test_svg_opens_in_inkscape_without_warnings_and_keeps_provenance(tmp_path):
    exe = shutil.which("inkscape")
    assert exe, "Inkscape is needed (Debian package 'inkscape'; .ci/run installs it)"
    out = tmp_path / "basics"
    assert main(["run", "demo/basics", "--out", str(out), "--progress", "off"]) == 0
    env = {"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"}     # a fresh profile, the system's tools
    for name in ("outline.svg", "tessellation.svg"):
        png = tmp_path / f"{name}.png"
        r = subprocess.run([exe, "--export-type=png", f"--export-filename={png}", str(out / name)],
                           capture_output=True, text=True, timeout=300, env=env)
        assert r.returncode == 0
        warnings = [line for line in (r.stdout + r.stderr).splitlines()
                    if "WARNING" in line and "GtkRecentManager" not in line]   # GTK's own, headless
        assert warnings == [], warnings
        assert np.asarray(Image.open(png).convert("L")).std() > 5         # drew something
        # Inkscape's own save keeps the provenance in the RDF it knows
        saved = tmp_path / f"saved-{name}"
        subprocess.run([exe, "--export-type=svg", "--export-plain-svg", f"--export-filename={saved}",
                        str(out / name)], capture_output=True, timeout=300, env=env)
        desc = ET.parse(saved).getroot().find(f".//{DC}description")
        assert desc is not None and json.loads(desc.text)["seed"] == 7
