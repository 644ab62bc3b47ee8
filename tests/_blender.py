"""Running a probe script in headless Blender (Debian's package) on one file, for the import tests."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path


def run_blender_probe(script: str, path: Path, tmp_path: Path, name: str = "probe.py") -> list[str]:
    """stdout lines of ``script`` run by ``blender -b`` with ``path`` as its last argument."""
    exe = shutil.which("blender")
    assert exe, "Blender is needed (Debian package 'blender'; .ci/run installs it)"
    probe = tmp_path / name
    probe.write_text(script)
    # Debian's Blender embeds the system Python and finds its home from the first python on PATH:
    # under a virtualenv or pyenv that is the test's interpreter, without Blender's numpy
    env = {**os.environ, "PATH": f"{Path(exe).resolve().parent}:{os.environ.get('PATH', '')}"}
    r = subprocess.run([exe, "-b", "--factory-startup", "--python", str(probe), "--", str(path)],
                       capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stderr[-800:]
    return r.stdout.splitlines()
