"""Built-in plugins ship their recipes and gallery lists through the hooks: disabling one removes them."""
from __future__ import annotations

import tomllib

import pytest

from procgen import get_plugin_manager
from procgen.gallery import load_gallery
from procgen.recipes import list_recipes

FAMILY = {"snaxel": "clouds", "water": "terrain", "surface": "meshes"}
# a recipe of another family that runs a rule of a disabled plugin (chains, users' data,
# weathering on surface cells) is left out of the gallery with a note


@pytest.mark.parametrize("plugin", sorted(FAMILY))
def test_disabling_a_plugin_removes_its_recipes_and_gallery_entries(plugin, monkeypatch, capsys):
    everything = get_plugin_manager()
    all_recipes = list_recipes(everything)
    all_entries = {e.slug: e for e in load_gallery(everything)}
    capsys.readouterr()
    monkeypatch.setenv("PROCGEN_DISABLE_PLUGINS", plugin)
    host = get_plugin_manager()
    recipes = list_recipes(host)
    family = FAMILY[plugin]
    assert any(n.startswith(f"{family}/") for n in all_recipes)
    assert not any(n.startswith(f"{family}/") for n in recipes)
    # every other family keeps all of its recipes (the core ships demo/, chains/ and data/)
    assert {n for n in all_recipes if not n.startswith(f"{family}/")} == set(recipes)
    entries = {e.slug: e for e in load_gallery(host)}
    gone = set(everything.rules) - set(host.rules)          # the disabled plugin's rules
    crossing = {s for s, e in all_entries.items() if not e.recipe.startswith(f"{family}/")
                and gone & {st["rule"] for st in tomllib.loads(all_recipes[e.recipe].read_text())["steps"]}}
    dropped = {s for s, e in all_entries.items() if e.recipe.startswith(f"{family}/")} | crossing
    assert dropped and set(entries) == set(all_entries) - dropped
    # another plugin's entries of this family's recipes (the cracks plates in rules/meshes)
    foreign = {s for s in dropped - crossing if not all_entries[s].source.startswith(f"{family}.toml")}
    notes = capsys.readouterr().err.strip().splitlines()
    assert len(notes) == len(crossing) + len(foreign)   # one line per left-out entry of another list
    for slug in foreign:
        assert any(f"left out {slug}: no loaded plugin ships recipe" in n for n in notes)
    for slug in crossing:
        note = next(n for n in notes if f"left out {slug}:" in n)
        assert all_entries[slug].recipe in note and any(rule in note for rule in gone)


def test_an_outside_plugin_lists_its_recipes_like_a_builtin(host):
    """The example plugin (installed by the test extra's setup) and the core ship the same way."""
    recipes = list_recipes(host)
    assert "grayscott/coral" in recipes and "demo/basics" in recipes
    slugs = [e.slug for e in load_gallery(host)]
    assert "grayscott-coral" in slugs and "demo-basics" in slugs
