"""Built-in plugins ship their recipes and gallery lists through the hooks: disabling one removes them."""
from __future__ import annotations

import pytest

from procgen import get_plugin_manager
from procgen.gallery import load_gallery
from procgen.recipes import list_recipes

FAMILY = {"snaxel": "clouds", "water": "terrain", "surface": "meshes"}
# the cross-family recipes the core ships (chains, users' data), and the families whose rules
# each one needs
CHAINS = {"chains/cloud-voronoi": {"snaxel", "surface"}, "chains/eroded-patina": {"water", "surface"},
          "chains/voronoi-grains-corrosion": {"surface"}, "data/leaf-logo-patina": {"surface"},
          "data/terrain-from-png": {"water"}, "data/dem-geotiff": {"water"},
          "data/painted-corrosion": {"water"}}


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
    dropped = {s for s, e in all_entries.items() if e.recipe.startswith(f"{family}/")
               or plugin in CHAINS.get(e.recipe, ())}
    assert dropped and set(entries) == set(all_entries) - dropped
    notes = capsys.readouterr().err.strip().splitlines()
    chains = sorted(all_entries[s].recipe for s in dropped if all_entries[s].recipe in CHAINS)
    assert len(notes) == len(chains)          # one line per left-out chain entry, none for the family
    for note, recipe in zip(sorted(notes), chains):
        assert note.startswith("gallery: left out") and recipe in note and f"{plugin}." in note


def test_an_outside_plugin_lists_its_recipes_like_a_builtin(host):
    """The example plugin (installed by the test extra's setup) and the core ship the same way."""
    recipes = list_recipes(host)
    assert "grayscott/coral" in recipes and "demo/basics" in recipes
    slugs = [e.slug for e in load_gallery(host)]
    assert "grayscott-coral" in slugs and "demo-basics" in slugs
