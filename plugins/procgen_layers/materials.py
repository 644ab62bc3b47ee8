"""Material table: what each layer of a stack is made of (appearance, liquid relations, behaviour).

The thesis (3DSCA, ch. 2 and App. A) gives every layer a material record with three parts:
appearance (colour, Phong coefficients, opacity), liquid relations (absorption rate, capacity,
erosion) and behaviour (weakness threshold, corrodible, sedimentable).  Rules on grids and on
meshes share this one table (it belongs to the layers family, not to the core), so it is generic: properties come out as per-layer arrays
(``table.array("opacity")``) that broadcast against per-element layer stacks.

Recipes give a table as a list of dicts (or bare preset names)::

    layers = [ "copper", { preset = "patina", color = [0.2, 0.6, 0.4], opacity = 0.7 },
               { name = "glaze", color = [0.9, 0.9, 1.0], opacity = 0.2 } ]
"""
from __future__ import annotations

import dataclasses
import difflib
import re
from dataclasses import dataclass, field, fields, replace
from typing import Any, Iterator, Mapping, Sequence

import numpy as np

from procgen.errors import InputError

__all__ = ["Material", "MaterialTable", "PRESETS", "preset", "parse_materials", "split_layer_specs"]

_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass(frozen=True)
class Material:
    """One layer material.  Units: colours in [0, 1]; thickness-like values in the grid's units.

    absorption_rate: fraction of a drop's volume the layer can take per step when dry (1/step).
    capacity: water held per unit volume of solid at saturation (porosity-like, >= 0).
    erosion_rate: solid volume eroded per unit of liquid volume involved, per step.
    weakness_threshold: saturation (held/capacity) above which the layer can erode.
    roughness: Coulomb friction coefficient a drop feels on this material.
    corrodible: corrosion CA may eat this layer (a metal).
    sedimentable: the thesis's 'sedimentable' type: water is absorbed and the layer may erode.
    metallic: glTF 2.0 metalness in [0, 1] (1 bare metal, 0 a dielectric: oxide, paint, glaze).
    pbr_roughness: glTF 2.0 perceptual roughness in [0, 1] of the exported metallic-roughness
        material (0 mirror-smooth, 1 fully matte); not the drop friction ``roughness``.
    """

    name: str
    color: tuple[float, float, float] = (0.5, 0.5, 0.5)
    ambient: float = 0.25
    diffuse: float = 0.7
    specular: float = 0.1
    exponent: float = 10.0
    density: float = 1.0
    opacity: float = 0.9
    absorption_rate: float = 0.0
    capacity: float = 0.0
    erosion_rate: float = 0.0
    weakness_threshold: float = 0.0
    roughness: float = 0.05
    corrodible: bool = False
    sedimentable: bool = False
    metallic: float = 0.0
    pbr_roughness: float = 0.5

    def __post_init__(self) -> None:
        where = f"material {self.name!r}"
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise InputError(f"material name {self.name!r} must be lower case letters, digits, '_' "
                             "(it becomes part of field names)")
        col = tuple(float(c) for c in np.ravel(self.color))
        if len(col) != 3 or not all(np.isfinite(col)) or min(col) < 0 or max(col) > 1:
            raise InputError(f"{where}: color must be 3 numbers in [0, 1], got {self.color!r}")
        object.__setattr__(self, "color", col)
        for key in ("ambient", "diffuse", "specular", "exponent", "density", "absorption_rate",
                    "capacity", "erosion_rate", "weakness_threshold", "roughness", "metallic",
                    "pbr_roughness"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise InputError(f"{where}: {key} must be a finite number, got {v!r}")
            if v < 0:
                raise InputError(f"{where}: {key} must be >= 0, got {v}")
            object.__setattr__(self, key, float(v))
        if self.density <= 0:
            raise InputError(f"{where}: density must be > 0, got {self.density}")
        op = self.opacity
        if isinstance(op, bool) or not isinstance(op, (int, float)) or not np.isfinite(op):
            raise InputError(f"{where}: opacity must be a number in [0, 1), got {op!r}")
        if not 0.0 <= op < 1.0:
            raise InputError(f"{where}: opacity must be in [0, 1) (1 would be an infinite "
                             f"absorption in f(o) = o/(1-o)), got {op}")
        object.__setattr__(self, "opacity", float(op))
        for key in ("absorption_rate", "weakness_threshold", "roughness", "metallic", "pbr_roughness"):
            if getattr(self, key) > 1.0:
                raise InputError(f"{where}: {key} must be in [0, 1], got {getattr(self, key)}")
        for key in ("corrodible", "sedimentable"):
            if not isinstance(getattr(self, key), bool):
                raise InputError(f"{where}: {key} must be true or false, got {getattr(self, key)!r}")

    @property
    def absorbs(self) -> bool:
        """Water can enter this layer (sedimentable, with a rate and a capacity)."""
        return self.sedimentable and self.absorption_rate > 0 and self.capacity > 0

    @property
    def erodible(self) -> bool:
        """Water can wash this layer away."""
        return self.sedimentable and self.erosion_rate > 0


MATERIAL_KEYS: tuple[str, ...] = tuple(f.name for f in fields(Material))

#: Where the ``metallic`` / ``pbr_roughness`` of the presets come from.  Metalness follows the
#: metallic-roughness convention of the glTF 2.0 specification (Khronos, section 3.9.2 and
#: Appendix B: conductors 1, everything else 0; oxides, patina and rust are dielectrics) and
#: Allegorithmic's "The PBR Guide" part 2 (Substance, 2018: raw metal 1, corroded or painted
#: metal 0).  Roughness values are mid-range picks from the Substance material-value charts and
#: physicallybased.info (Anders Lindqvist et al., https://physicallybased.info: water 0 with
#: ior 1.33, metals 0 polished to ~0.5 worn), adjusted for the weathered state these layers
#: model: polished copper 0.3, worn iron 0.45, gold 0.2, bronze 0.35; glossy ceramic glaze
#: 0.05, satin paint 0.45; patina 0.8, rust 0.9, dry stone/concrete 0.85-0.9, mud and soil 0.95.
PBR_SOURCES = ("glTF 2.0 specification, 3.9.2 metallic-roughness material (Khronos Group)",
               "The PBR Guide, part 2 (Allegorithmic/Substance, 2018)",
               "https://physicallybased.info (physically based material values)")

PRESETS: dict[str, Material] = {m.name: m for m in (
    Material(name="copper", color=(0.80, 0.45, 0.25), ambient=0.2, diffuse=0.6, specular=0.6,
             exponent=40.0, density=8.96, opacity=0.995, roughness=0.02, corrodible=True,
             metallic=1.0, pbr_roughness=0.3),
    Material(name="iron", color=(0.55, 0.55, 0.57), ambient=0.2, diffuse=0.6, specular=0.5,
             exponent=30.0, density=7.87, opacity=0.995, roughness=0.04, corrodible=True,
             metallic=1.0, pbr_roughness=0.45),
    Material(name="patina", color=(0.30, 0.68, 0.52), ambient=0.3, diffuse=0.75, specular=0.05,
             exponent=5.0, density=3.9, opacity=0.8, absorption_rate=0.3, capacity=0.5,
             erosion_rate=0.05, weakness_threshold=0.2, roughness=0.3, sedimentable=True,
             metallic=0.0, pbr_roughness=0.8),
    Material(name="red_patina", color=(0.72, 0.22, 0.15), ambient=0.3, diffuse=0.75,
             specular=0.05, exponent=5.0, density=3.0, opacity=0.85, absorption_rate=0.3,
             capacity=0.5, erosion_rate=0.08, weakness_threshold=0.15, roughness=0.2,
             sedimentable=True,
             metallic=0.0, pbr_roughness=0.75),
    Material(name="rust", color=(0.55, 0.25, 0.10), ambient=0.3, diffuse=0.75, specular=0.02,
             exponent=4.0, density=5.2, opacity=0.9, absorption_rate=0.2, capacity=0.3,
             erosion_rate=0.04, weakness_threshold=0.3, roughness=0.35, sedimentable=True,
             metallic=0.0, pbr_roughness=0.9),
    Material(name="rock", color=(0.52, 0.48, 0.42), ambient=0.3, diffuse=0.7, specular=0.02,
             exponent=4.0, density=2.6, opacity=0.99, absorption_rate=0.0, capacity=0.0,
             erosion_rate=0.3, weakness_threshold=0.0, roughness=0.05, sedimentable=True,
             metallic=0.0, pbr_roughness=0.9),
    Material(name="stone", color=(0.62, 0.62, 0.62), ambient=0.3, diffuse=0.7, specular=0.05,
             exponent=8.0, density=2.4, opacity=0.99, absorption_rate=0.25, capacity=0.4,
             erosion_rate=0.0, weakness_threshold=1.0, roughness=0.1, sedimentable=True,
             metallic=0.0, pbr_roughness=0.85),
    Material(name="soil", color=(0.45, 0.33, 0.20), ambient=0.3, diffuse=0.75, specular=0.0,
             exponent=2.0, density=1.6, opacity=0.95, absorption_rate=0.2, capacity=0.4,
             erosion_rate=0.5, weakness_threshold=0.1, roughness=0.1, sedimentable=True,
             metallic=0.0, pbr_roughness=0.95),
    Material(name="paint", color=(0.85, 0.85, 0.80), ambient=0.3, diffuse=0.7, specular=0.3,
             exponent=20.0, density=1.4, opacity=0.9, absorption_rate=0.05, capacity=0.1,
             erosion_rate=0.02, weakness_threshold=0.5, roughness=0.05, sedimentable=True,
             metallic=0.0, pbr_roughness=0.45),
    Material(name="glaze", color=(0.85, 0.90, 0.95), ambient=0.2, diffuse=0.5, specular=0.8,
             exponent=60.0, density=2.5, opacity=0.15, roughness=0.01,
             metallic=0.0, pbr_roughness=0.05),
    Material(name="water", color=(0.25, 0.45, 0.85), ambient=0.2, diffuse=0.4, specular=0.9,
             exponent=60.0, density=1.0, opacity=0.5, roughness=0.0,
             metallic=0.0, pbr_roughness=0.02),
    Material(name="gold", color=(1.00, 0.77, 0.34), ambient=0.2, diffuse=0.6, specular=0.7,
             exponent=50.0, density=19.3, opacity=0.995, roughness=0.02, metallic=1.0, pbr_roughness=0.2),
    Material(name="bronze", color=(0.70, 0.48, 0.25), ambient=0.2, diffuse=0.6, specular=0.5,
             exponent=30.0, density=8.8, opacity=0.995, roughness=0.03, corrodible=True,
             metallic=1.0, pbr_roughness=0.35),
    Material(name="mud", color=(0.55, 0.42, 0.30), ambient=0.35, diffuse=0.65, specular=0.05,
             exponent=4.0, density=1.8, opacity=0.99, absorption_rate=0.2, capacity=0.4,
             erosion_rate=0.3, weakness_threshold=0.1, roughness=0.1, sedimentable=True,
             metallic=0.0, pbr_roughness=0.95),
    Material(name="concrete", color=(0.60, 0.59, 0.56), ambient=0.3, diffuse=0.7, specular=0.02,
             exponent=4.0, density=2.4, opacity=0.99, absorption_rate=0.1, capacity=0.2,
             erosion_rate=0.01, weakness_threshold=0.6, roughness=0.1, sedimentable=True,
             metallic=0.0, pbr_roughness=0.9),
    Material(name="wood", color=(0.60, 0.42, 0.25), ambient=0.3, diffuse=0.7, specular=0.05,
             exponent=6.0, density=0.7, opacity=0.99, absorption_rate=0.1, capacity=0.3,
             erosion_rate=0.01, weakness_threshold=0.5, roughness=0.1, sedimentable=True,
             metallic=0.0, pbr_roughness=0.7),
    Material(name="ceramic", color=(0.90, 0.88, 0.84), ambient=0.25, diffuse=0.7, specular=0.2,
             exponent=15.0, density=2.4, opacity=0.99, roughness=0.05, metallic=0.0, pbr_roughness=0.5),
)}


def preset(name: str) -> Material:
    """The named preset material; InputError with a suggestion if unknown."""
    try:
        return PRESETS[name]
    except (KeyError, TypeError):
        near = difflib.get_close_matches(str(name), list(PRESETS), n=1)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        raise InputError(f"unknown material preset {name!r}{hint}; presets: "
                         f"{', '.join(sorted(PRESETS))}") from None


def material_from_spec(spec: Any, where: str = "materials") -> Material:
    """A Material from a preset name or a dict ``{preset=..., name=..., <property>=...}``."""
    if isinstance(spec, Material):
        return spec
    if isinstance(spec, str):
        return preset(spec)
    if not isinstance(spec, Mapping):
        raise InputError(f"{where}: a material is a preset name or a table, got {spec!r}")
    spec = dict(spec)
    base_name = spec.pop("preset", None)
    unknown = [k for k in spec if k not in MATERIAL_KEYS]
    if unknown:
        near = difflib.get_close_matches(unknown[0], MATERIAL_KEYS, n=1)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        raise InputError(f"{where}: unknown material property {unknown[0]!r}{hint}")
    if base_name is None and "name" not in spec:
        raise InputError(f"{where}: give a 'preset' or a 'name'")
    if base_name is not None:
        base = preset(base_name)
        try:
            return replace(base, **spec)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    try:
        return Material(**spec)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    except TypeError as exc:  # wrong value types reaching the dataclass
        raise InputError(f"{where}: {exc}") from None


@dataclass(frozen=True)
class MaterialTable:
    """An ordered list of layer materials, bottom (index 0) to top; names are unique."""

    materials: tuple[Material, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        names = [m.name for m in self.materials]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"material table: layer name {dup[0]!r} appears twice; give each "
                             "layer its own 'name'")

    def __len__(self) -> int:
        return len(self.materials)

    def __iter__(self) -> Iterator[Material]:
        return iter(self.materials)

    def __getitem__(self, key: int | str) -> Material:
        if isinstance(key, str):
            return self.materials[self.index(key)]
        return self.materials[key]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.materials)

    def index(self, name: str, where: str = "") -> int:
        """Layer index of ``name``; InputError (with did-you-mean) if it is not in the table."""
        names = self.names
        if name in names:
            return names.index(name)
        near = difflib.get_close_matches(str(name), names, n=1)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        pre = f"{where}: " if where else ""
        raise InputError(f"{pre}no layer named {name!r}{hint}; layers: {', '.join(names) or 'none'}")

    def array(self, key: str) -> np.ndarray:
        """Per-layer values of one property: (L,) floats/bools, or (L, 3) for ``color``."""
        if key not in MATERIAL_KEYS or key == "name":
            raise InputError(f"material table: no numeric property {key!r}")
        vals = [getattr(m, key) for m in self.materials]
        if key == "color":
            return np.asarray(vals, dtype=float).reshape(len(vals), 3)
        if key in ("corrodible", "sedimentable"):
            return np.asarray(vals, dtype=bool)
        return np.asarray(vals, dtype=float)

    @property
    def absorbs(self) -> np.ndarray:
        return np.array([m.absorbs for m in self.materials], dtype=bool)

    @property
    def erodible(self) -> np.ndarray:
        return np.array([m.erodible for m in self.materials], dtype=bool)

    def to_records(self) -> list[dict[str, Any]]:
        """JSON-able list of dicts (round-trips through :func:`parse_materials`)."""
        out = []
        for m in self.materials:
            d = dataclasses.asdict(m)
            d["color"] = list(d["color"])
            out.append(d)
        return out

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Every property as a per-layer array (for storing the table as fields of a domain)."""
        return {k: self.array(k) for k in MATERIAL_KEYS if k != "name"}

    @classmethod
    def from_arrays(cls, names: Sequence[str], arrays: Mapping[str, np.ndarray]) -> "MaterialTable":
        """Inverse of :meth:`to_arrays` (missing properties take the Material defaults)."""
        mats = []
        for i, n in enumerate(names):
            kw: dict[str, Any] = {}
            for k, arr in arrays.items():
                if k not in MATERIAL_KEYS or k == "name":
                    continue
                v = np.asarray(arr)[i]
                kw[k] = tuple(float(c) for c in v) if k == "color" else (
                    bool(v) if k in ("corrodible", "sedimentable") else float(v))
            mats.append(Material(name=str(n), **kw))
        return cls(tuple(mats))


def parse_materials(specs: Sequence[Any], where: str = "layers") -> MaterialTable:
    """A MaterialTable from a recipe list of preset names / dicts (bottom layer first)."""
    if isinstance(specs, (str, bytes)) or not isinstance(specs, Sequence):
        raise InputError(f"{where}: expected a list of materials, got {specs!r}")
    if len(specs) == 0:
        raise InputError(f"{where}: the material list is empty")
    mats = tuple(material_from_spec(s, f"{where}[{i}]") for i, s in enumerate(specs))
    return MaterialTable(mats)


def split_layer_specs(specs: Any, geometry_keys: Sequence[str],
                      where: str = "layers") -> tuple[MaterialTable, list[dict[str, Any]]]:
    """Recipe layers (preset names, or tables mixing material and geometry keys) -> materials
    and the raw geometry tables, bottom first.

    Both layered plugins (2.5-D grids and mesh cells) read the same layer syntax through this;
    each then checks the geometry keys it knows.
    """
    if isinstance(specs, (str, bytes)) or not isinstance(specs, Sequence) or len(specs) == 0:
        raise InputError(f"{where}: give a non-empty list of layers (preset names or tables)")
    mats, geos = [], []
    for i, spec in enumerate(specs):
        w = f"{where}[{i}]"
        spec = {"preset": spec} if isinstance(spec, str) else spec
        if not isinstance(spec, Mapping):
            raise InputError(f"{w}: a layer is a preset name or a table, got {spec!r}")
        geo = {k: v for k, v in spec.items() if k in geometry_keys}
        mat = {k: v for k, v in spec.items() if k not in geometry_keys}
        unknown = [k for k in mat if k not in MATERIAL_KEYS and k != "preset"]
        if unknown:
            near = difflib.get_close_matches(unknown[0], list(MATERIAL_KEYS) + list(geometry_keys), n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise InputError(f"{w}: unknown layer key {unknown[0]!r}{hint}")
        mats.append(material_from_spec(mat, w))
        geos.append(geo)
    return MaterialTable(tuple(mats)), geos
