"""Material table parsing, presets and bad-input messages."""
import numpy as np
import pytest

from procgen.errors import InputError
from procgen_layers.materials import PRESETS, MaterialTable, parse_materials


def test_presets_and_overrides_parse_to_arrays():
    tab = parse_materials(["copper", {"preset": "patina", "opacity": 0.6},
                           {"name": "glaze2", "color": [0.9, 0.9, 1.0], "opacity": 0.2}])
    assert tab.names == ("copper", "patina", "glaze2")
    assert np.allclose(tab.array("opacity"), [PRESETS["copper"].opacity, 0.6, 0.2])
    assert tab.array("color").shape == (3, 3)
    assert list(tab.array("corrodible")) == [True, False, False]
    assert list(tab.absorbs) == [False, True, False]
    back = MaterialTable.from_arrays(tab.names, tab.to_arrays())
    assert back == tab
    assert parse_materials(tab.to_records()) == tab


@pytest.mark.parametrize("spec,msg", [
    (["coper"], "did you mean 'copper'"),
    ([{"preset": "rock", "capacity": -1}], "capacity must be >= 0"),
    ([{"preset": "rock", "opacity": 1.0}], "opacity must be in [0, 1)"),
    ([{"preset": "rock", "colour": [1, 0, 0]}], "did you mean 'color'"),
    ([{"name": "x", "color": [2, 0, 0]}], "color must be 3 numbers"),
    (["rock", "rock"], "appears twice"),
    ([], "empty"),
])
def test_bad_materials_give_one_line_errors(spec, msg):
    with pytest.raises(InputError) as ei:
        parse_materials(spec)
    assert msg in str(ei.value) and "\n" not in str(ei.value)


def test_index_lookup_suggests():
    tab = parse_materials(["copper", "patina"])
    assert tab.index("patina") == 1
    with pytest.raises(InputError, match="did you mean 'patina'"):
        tab.index("patna")
