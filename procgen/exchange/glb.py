"""Binary glTF (GLB) through trimesh: vertex colours or a texture atlas with face-corner UVs."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..domains import Domain, TriMesh
from ..errors import InputError
from .obj import corner_uvs, texture_image, vertex_colors


def glb_export(domain: Domain, *, stem: str = "", provenance: dict[str, Any] | None = None,
               color_field: str | None = None, uv_field: str | None = None,
               texture_field: str | None = None) -> bytes:
    """GLB bytes; textured meshes are unwelded per face corner so every corner has its own UV."""
    import trimesh
    from PIL import Image

    if not isinstance(domain, TriMesh):
        raise InputError(f"glb: expected a TriMesh, got {domain.kind}")
    v = domain.vertices if domain.dim == 3 else np.column_stack([domain.vertices, np.zeros(domain.n_vertices)])
    if uv_field and texture_field:
        uv = corner_uvs(domain, uv_field).reshape(-1, 2)
        verts = v[domain.faces].reshape(-1, 3)
        faces = np.arange(len(verts)).reshape(-1, 3)
        image = Image.fromarray(texture_image(domain, texture_field))
        visual = trimesh.visual.TextureVisuals(uv=uv, image=image)
        mesh = trimesh.Trimesh(vertices=verts, faces=faces, visual=visual, process=False)
    else:
        mesh = trimesh.Trimesh(vertices=np.array(v), faces=np.array(domain.faces), process=False)
        if color_field:
            rgb = np.round(vertex_colors(domain, color_field) * 255).astype(np.uint8)
            mesh.visual.vertex_colors = np.column_stack([rgb, np.full(len(rgb), 255, np.uint8)])
    scene = trimesh.Scene(mesh)
    if provenance:
        scene.metadata["procgen"] = provenance
    return scene.export(file_type="glb")
