"""What a layer stack looks like, baked into generic cell fields every exporter can read.

Why: the mesh exporters (procgen_surface, a plugin of its own) must not import this family to
colour cells.  Light through the layers (App. B 1.2) is linear in the per-layer lit colours,
so the Phong shading of a whole stack seen from any eye is, per cell,

    c = A + max(N.L, 0) D + [N.L > 0] sum_j s_j max(R.E, 0)^e_j

with A = sum_j w_j ka_j C_j, D = sum_j w_j kd_j C_j and s_j = w_j ks_j (w the layers' light
shares): a few view-independent arrays (``shade__*``) that a previewer evaluates for its own
camera, exactly as :func:`procgen_layers.light.shade_stack` would (white highlights).  The same
shares mix the layers' glTF metallic-roughness properties (``bake__metallic``,
``bake__roughness``) and unlit colour (``bake__color``, the albedo of a texture).  Every rule of
this family that changes the thickness re-bakes (through :func:`put_thickness`), so the fields
always describe the current stack.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen.ca.cells import cell_values, n_cells

from .light import layer_weights
from .materials import MaterialTable

#: cell fields written by :func:`bake_stack` (and their units), documented in docs/fields.md
BAKED = {"bake__color": "rgb", "bake__metallic": "1", "bake__roughness": "1",
         "shade__ambient": "rgb", "shade__diffuse": "rgb", "shade__specular": "1"}


def stack_terms(thickness: np.ndarray, table: MaterialTable) -> dict[str, np.ndarray]:
    """Per-cell baked terms of a flat (n, L) bottom-first stack (see the module docstring)."""
    t = np.asarray(thickness, float)
    w = layer_weights(t[:, ::-1], table.array("opacity")[::-1])[:, ::-1]     # bottom first again
    col = table.array("color")
    return {"bake__color": w @ col,
            "bake__metallic": w @ table.array("metallic"),
            "bake__roughness": w @ table.array("pbr_roughness") + (1.0 - w.sum(axis=1)),
            "shade__ambient": w @ (table.array("ambient")[:, None] * col),
            "shade__diffuse": w @ (table.array("diffuse")[:, None] * col),
            "shade__specular": w * table.array("specular")}


def bake_stack(domain: Any, table: MaterialTable) -> None:
    """Write the baked terms of the domain's current ``layers__thickness`` as cell fields, and
    the layers' Phong exponents as ``shade__exponent`` (domain, (L,))."""
    from procgen.ca.cells import put_cell_values

    terms = stack_terms(cell_values(domain, "layers__thickness").reshape(n_cells(domain), -1), table)
    for name, arr in terms.items():
        put_cell_values(domain, name, arr, units=BAKED[name], doc=f"baked stack appearance ({name})")
    domain.add_field("shade__exponent", table.array("exponent"), at="domain",
                     doc="Phong exponent of each specular lobe of shade__specular (per layer)")


def bake_field_specs(domain: str) -> tuple[Any, ...]:
    """FieldSpecs of what :func:`bake_stack` writes on ``domain`` (for the rules' declarations)."""
    from procgen import FieldSpec

    return (*(FieldSpec(name, domain, "cell", "out", units=units, doc="baked stack appearance")
              for name, units in BAKED.items()),
            FieldSpec("shade__exponent", domain, "domain", "out", doc="Phong exponent per specular lobe"))
