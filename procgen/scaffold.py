"""``procgen new-plugin NAME``: a ready package (entry point, one rule, one recipe, one test)."""
from __future__ import annotations

import re
from pathlib import Path

from .errors import InputError
from .exchange import write

_PYPROJECT = '''[build-system]
requires = ["hatchling>=1.18"]
build-backend = "hatchling.build"

[project]
name = "procgen-{dash}"
version = "0.1.0"
description = "{title} rules for procgen"
requires-python = ">=3.11"
dependencies = ["procgen-rules", "numpy"]

[project.optional-dependencies]
test = ["pytest"]

# procgen finds the plugin through this entry point
[project.entry-points.procgen]
{name} = "procgen_{name}.plugin"

[tool.hatch.build.targets.wheel]
packages = ["src/procgen_{name}"]
'''

_PLUGIN = '''"""Hooks that register the {name} rules and recipes with procgen."""
from __future__ import annotations

from pathlib import Path

import procgen


@procgen.hookimpl
def procgen_register_rules():
    from .rules import Diffusion

    return [Diffusion]


@procgen.hookimpl
def procgen_recipe_dirs():
    return [Path(__file__).parent / "recipes"]
'''

_RULES = '''"""{name}.diffuse: a starting rule to edit: random heat spread by explicit diffusion."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, Grid, RuleBase, State, param


@dataclass(kw_only=True)
class Diffusion(RuleBase):
    """Random heat on a Grid, spread by diffusion (total heat is conserved).

    Replace this with your phenomenon: parameters are dataclass fields declared with param(),
    fields you write are declared in `fields`, random numbers come from state.rng().
    """

    name: ClassVar[str] = "{name}.diffuse"
    creates: ClassVar[dict[str, str]] = {{"{{grid}}": "Grid"}}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("heat__amount", "{{grid}}", "cell", "out", units="J", doc="heat per cell"),
    )
    default_iterations: ClassVar[int] = 100
    example: ClassVar[tuple[dict, ...]] = ({{"rule": "{name}.diffuse", "params": {{"size": 16}}, "iterations": 5}},)

    grid: str = param("{name}", doc="name of the Grid to create")
    size: int = param(64, ge=4, le=4096, units="cells", doc="cells per side")
    rate: float = param(0.2, gt=0.0, le=0.25, units="1/step", doc="diffusion rate (stable up to 0.25)")

    def setup(self, state: State) -> None:
        g = Grid((self.size, self.size))
        g.add_field("heat__amount", state.rng().random((self.size, self.size)), at="cell", units="J")
        state.add_domain(self.grid, g)

    def step(self, state: State) -> bool:
        h = state.get(self.grid, Grid)["heat__amount"]
        p = np.pad(h, 1, mode="edge")  # insulated borders: no flux leaves the grid
        lap = p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4 * h
        h += self.rate * lap
        return bool(np.abs(lap).max() > 1e-12)
'''

_RECIPE = '''[recipe]
name = "example"
description = "{title}: heat spreading on a grid"
seed = 1

[[steps]]
rule = "{name}.diffuse"
params = {{ size = 64, rate = 0.2 }}
iterations = 200

[[outputs]]
domain = "{name}"
format = "image_png"
file = "heat.png"
options = {{ field = "heat__amount", cmap = "inferno", scale = 4 }}
'''

_TEST = '''"""The plugin passes procgen's rule contract suite and its recipe runs."""
from __future__ import annotations

import numpy as np

from procgen import get_plugin_manager
from procgen.recipes import load_recipe
from procgen.runner import run
from procgen.testing import check_rule_contract
from procgen_{name}.rules import Diffusion


def test_contract():
    check_rule_contract(Diffusion)


def test_recipe_runs_and_conserves_heat(tmp_path):
    host = get_plugin_manager()
    recipe = load_recipe("{name}/example", host, ["steps.0.iterations=20"])
    state = run(recipe, host, seed=3, out_dir=tmp_path).state
    heat = state.get("{name}")["heat__amount"]
    initial = run(load_recipe("{name}/example", host, ["steps.0.iterations=1"]), host, seed=3).state
    assert (tmp_path / "heat.png").is_file() and np.isfinite(heat).all()
    # diffusion with insulated borders conserves the total and shrinks the spread
    assert np.isclose(heat.sum(), initial.get("{name}")["heat__amount"].sum())
    assert heat.std() < initial.get("{name}")["heat__amount"].std()
'''

_README = '''# procgen-{dash}

{title} rules for [procgen](https://pypi.org/project/procgen-rules/).

    pip install -e .          # procgen now lists the rule: procgen rules show {name}.diffuse
    procgen run {name}/example --out out/example
    pytest                    # runs procgen's contract suite on the rule
'''


def new_plugin(name: str, directory: Path) -> Path:
    """Write ``directory/procgen-NAME`` and return its path; refuses to overwrite."""
    if not re.fullmatch(r"[a-z][a-z0-9_]{1,30}", name):
        raise InputError(f"new-plugin: name {name!r} must be lower case letters, digits or _ (e.g. lichen)")
    dash = name.replace("_", "-")
    root = Path(directory) / f"procgen-{dash}"
    if root.exists():
        raise InputError(f"new-plugin: {root} already exists; choose another --dir or name")
    fmt = {"name": name, "dash": dash, "title": name.replace("_", " ").title()}
    files = {
        "pyproject.toml": _PYPROJECT, "README.md": _README,
        f"src/procgen_{name}/__init__.py": '"""{title} rules for procgen."""\n',
        f"src/procgen_{name}/plugin.py": _PLUGIN, f"src/procgen_{name}/rules.py": _RULES,
        f"src/procgen_{name}/recipes/{name}/example.toml": _RECIPE, f"tests/test_{name}.py": _TEST,
    }
    for rel, template in files.items():
        write(root / rel, template.format(**fmt))
    return root
