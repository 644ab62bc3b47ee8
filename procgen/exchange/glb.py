"""Binary glTF (GLB) through trimesh: vertex colours or a texture atlas with face-corner UVs."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..domains import Domain, TriMesh
from ..errors import InputError
from .gltf_compact import quantize_glb
from .image import png_bytes
from .obj import corner_uvs, texture_image, unique_rows, vertex_colors
from .provenance import provenance_json
from .registry import UpAxis


#: model axis -> the rotation that turns it into glTF's +Y up (right-handed, so nothing mirrors)
TO_GLTF_UP = {"y": np.eye(4),
              "z": np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]]),    # (x, z, -y)
              "x": np.array([[0, -1.0, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])}    # (-y, x, z)


#: 8-bit sRGB -> 8-bit linear: glTF's COLOR_0 is a linear multiplier (glTF 2.0, 3.7.2.1 "Meshes":
#: "vertex colors ... linear"), while procgen's colours are display (sRGB) values as in its PNGs;
#: written unconverted they show washed out in Blender, three.js and model-viewer
_C = np.arange(256) / 255.0
SRGB8_TO_LINEAR8 = np.round(255 * np.where(_C <= 0.04045, _C / 12.92, ((_C + 0.055) / 1.055) ** 2.4)).astype(np.uint8)


class EncodedTexture:
    """A texture already encoded, standing in for a PIL image in trimesh's glTF writer (which calls
    ``save`` and stores what it writes, with ``format`` as its MIME type).

    Why: trimesh re-encodes every texture at zlib's default level, once per material slot (the
    ORM image fills two: occlusion and metallic-roughness); for a large atlas that encoding was
    most of an export's time.  Encoded once here and written as bytes in every slot that uses it
    (trimesh stores equal bytes once).  An opaque map is written as JPEG (quality
    :data:`JPEG_QUALITY`, no chroma subsampling, so the ORM channels do not bleed into each other)
    when that is under :data:`JPEG_SHARE` of its PNG: glTF 2.0 core reads both, and the PNG maps
    written beside an OBJ stay lossless.  Provenance rides in the PNG text chunk or the JPEG
    comment."""

    def __init__(self, array: np.ndarray, provenance: dict[str, Any] | None = None) -> None:
        array = np.ascontiguousarray(array)
        self.size = (int(array.shape[1]), int(array.shape[0]))
        self.mode = "L" if array.ndim == 2 else {1: "L", 3: "RGB", 4: "RGBA"}[int(array.shape[2])]
        self.format, self.data = "PNG", png_bytes(array, provenance)     # the OBJ's maps: encoded once
        opaque = self.mode != "RGBA" or bool((array[..., 3] == 255).all())
        if array.dtype == np.uint8 and opaque:
            jpeg = jpeg_bytes(array[..., :3] if self.mode == "RGBA" else array, provenance)
            if len(jpeg) < JPEG_SHARE * len(self.data):
                self.format, self.data = "JPEG", jpeg

    def save(self, fp: Any, format: str | None = None, **_: Any) -> None:   # noqa: A002 (PIL's name)
        fp.write(self.data)


#: JPEG quality of GLB textures, and how much smaller than the PNG a JPEG must be to be chosen
JPEG_QUALITY, JPEG_SHARE = 85, 0.7


def jpeg_bytes(array: np.ndarray, provenance: dict[str, Any] | None = None) -> bytes:
    """Baseline JPEG of an 8-bit L/RGB image, 4:4:4, provenance in the comment (deterministic)."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="JPEG", quality=JPEG_QUALITY, subsampling=0, optimize=True,
                                comment=provenance_json(provenance).encode())
    return buf.getvalue()


def glb_export(domain: Domain, *, stem: str = "", provenance: dict[str, Any] | None = None,
               color_field: str | None = None, uv_field: str | None = None,
               texture_field: str | None = None, cmap: str = "terrain",
               orm_field: str | None = None, normal_field: str | None = None, up: UpAxis = "z") -> bytes:
    """GLB bytes; a textured mesh splits vertices only where UVs differ (atlas seams).

    ``up`` is the model's up axis (procgen's generated terrains, primitives and solids are z-up;
    scanned meshes such as Spot or the bunny are y-up). glTF is +Y up and Blender, three.js and
    model-viewer turn +Y to their own up, so the mesh is turned (a rotation, never a mirror) for
    the file to stand upright where it is opened, as in the previews.

    ``color_field`` names vertex colours, or a scalar vertex field shown through ``cmap``.
    A textured mesh is a glTF 2.0 metallic-roughness material (trimesh's PBRMaterial): the
    texture is the baseColorTexture; ``orm_field`` (an (h, w, 3) image in [0, 1]: occlusion,
    roughness, metallic) becomes the metallicRoughnessTexture and the occlusionTexture (glTF
    reads G and B, respectively R, of the one image), ``normal_field`` (tangent-space normals
    encoded in [0, 1], +Y = +v) the normalTexture.
    """
    import trimesh

    if not isinstance(domain, TriMesh):
        raise InputError(f"glb: expected a TriMesh, got {domain.kind}")
    if up not in TO_GLTF_UP:
        raise InputError(f"glb: up must be x, y or z (the model's up axis), got {up!r}")
    mesh = mesh_for_export(domain, color_field=color_field, uv_field=uv_field, texture_field=texture_field,
                           cmap=cmap, orm_field=orm_field, normal_field=normal_field,
                           image=lambda a: EncodedTexture(a, provenance))
    if up != "y":
        mesh.apply_transform(TO_GLTF_UP[up])     # vertices and their normals
    scene = trimesh.Scene(mesh if uv_field else with_vertex_colour_material(mesh, color_field is not None))
    if provenance:
        scene.metadata["procgen"] = provenance
    return quantize_glb(scene.export(file_type="glb"))


def with_vertex_colour_material(mesh: Any, coloured: bool) -> Any:
    """``mesh`` with a material a viewer shows: white times the vertex colours (glTF 2.0 multiplies
    COLOR_0 into the base colour; Blender's importer wires it to the Principled BSDF's Base Color),
    or a plain light grey when the mesh has no colours. Without a material, Blender's default
    material hides vertex colours. The colours are written linear (:data:`SRGB8_TO_LINEAR8`), as
    glTF reads COLOR_0."""
    import trimesh

    base = [255, 255, 255, 255] if coloured else [200, 200, 200, 255]
    material = trimesh.visual.material.PBRMaterial(name="vertex_colours" if coloured else "plain",
                                                   baseColorFactor=base, metallicFactor=0.0,
                                                   roughnessFactor=0.8, doubleSided=True)
    visual = trimesh.visual.TextureVisuals(material=material)
    if coloured:
        rgba = np.asarray(mesh.visual.vertex_colors, np.uint8)
        visual.vertex_attributes["color"] = np.column_stack([SRGB8_TO_LINEAR8[rgba[:, :3]], rgba[:, 3]])
    return trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces, visual=visual, process=False)


def mesh_for_export(domain: TriMesh, *, color_field: str | None = None, uv_field: str | None = None,
                    texture_field: str | None = None, cmap: str = "terrain",
                    orm_field: str | None = None, normal_field: str | None = None,
                    image: Any = None) -> Any:
    """A ``trimesh.Trimesh`` carrying the domain's vertex colours or UV-mapped texture.

    ``image``: how a texture array becomes the material's image (default a PIL image, which the
    preview renderer samples; the GLB writer passes :class:`EncodedTexture`)."""
    import trimesh
    from PIL import Image

    image = image or Image.fromarray
    if (uv_field is None) != (texture_field is None):
        raise InputError("glb: give both uv_field and texture_field for a textured mesh")
    v = domain.vertices if domain.dim == 3 else np.column_stack([domain.vertices, np.zeros(domain.n_vertices)])
    if uv_field and texture_field:
        # glTF has one UV per vertex: split a vertex only where its corners' UVs differ
        corner_uv = corner_uvs(domain, uv_field).reshape(-1, 2)
        pairs = np.column_stack([domain.faces.reshape(-1, 1).astype(np.float64), corner_uv])
        uniq, inverse = unique_rows(pairs)
        verts = v[uniq[:, 0].astype(np.int64)]
        tex = texture_image(domain, texture_field)
        alpha = tex.shape[2] == 4 and bool((tex[..., 3] < 255).any())     # an opaque map needs no alpha test
        maps: dict[str, Any] = {"metallicFactor": 0.0, "roughnessFactor": 0.8}
        if orm_field:
            orm = image(texture_image(domain, orm_field))
            maps = {"metallicFactor": 1.0, "roughnessFactor": 1.0, "metallicRoughnessTexture": orm,
                    "occlusionTexture": orm}
        if normal_field:
            maps["normalTexture"] = image(texture_image(domain, normal_field))
        material = trimesh.visual.material.PBRMaterial(
            name="procgen", baseColorTexture=image(tex), **maps,
            alphaMode="MASK" if alpha else "OPAQUE", alphaCutoff=0.5 if alpha else None, doubleSided=True)
        visual = trimesh.visual.TextureVisuals(uv=uniq[:, 1:], material=material)
        mesh = trimesh.Trimesh(vertices=verts, faces=inverse.reshape(-1, 3), visual=visual, process=False)
        if domain.dim == 3:          # normals of the welded mesh: atlas seams split vertices, not the surface
            from ..geometry import vertex_normals as welded_normals
            mesh.vertex_normals = welded_normals(v, domain.faces)[uniq[:, 0].astype(np.int64)]
    else:
        mesh = trimesh.Trimesh(vertices=np.array(v), faces=np.array(domain.faces), process=False)
        if color_field:
            rgb = np.round(vertex_colors(domain, color_field, cmap) * 255).astype(np.uint8)
            mesh.visual.vertex_colors = np.column_stack([rgb, np.full(len(rgb), 255, np.uint8)])
    return mesh
