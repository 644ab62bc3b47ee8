"""`procgen new-plugin` writes a package that installs and passes its own tests unchanged."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from procgen import InputError
from procgen.cli import main
from procgen.scaffold import new_plugin


def test_new_plugin_installs_and_passes_its_tests(tmp_path):
    assert main(["new-plugin", "lichen", "--dir", str(tmp_path)]) == 0
    pkg = tmp_path / "procgen-lichen"
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                    "--target", str(site), str(pkg)], check=True, capture_output=True, timeout=300)
    env = {**os.environ, "PYTHONPATH": str(site) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(pkg / "tests")],
                       capture_output=True, text=True, env=env, cwd=pkg, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "2 passed" in r.stdout
    r = subprocess.run([sys.executable, "-m", "procgen.cli", "rules", "show", "lichen.diffuse"],
                       capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0 and "rate" in r.stdout


def test_new_plugin_refuses_bad_name_and_overwrite(tmp_path):
    with pytest.raises(InputError, match="lower case"):
        new_plugin("Bad-Name", tmp_path)
    new_plugin("moss", tmp_path)
    with pytest.raises(InputError, match="already exists"):
        new_plugin("moss", tmp_path)
