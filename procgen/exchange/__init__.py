"""Exporters (one module per format) and ``write``, the only function that writes files."""
from __future__ import annotations

from .glb import glb_export
from .heightmap import heightmap_npy, heightmap_png16
from .image import image_png, png_bytes, to_rgb8
from .obj import obj_export
from .preview import preview_png, render_mesh_png
from .registry import Exporter, FieldName, UpAxis, field_options
from .svg import mesh_svg, polylines_svg
from .write import write, write_many

BUILTIN_EXPORTERS: tuple[Exporter, ...] = (
    Exporter("svg", ("Polylines",), ".svg", polylines_svg,
             "closed lines as filled paths, open ones stroked; fill, stroke, gradient, background"),
    Exporter("svg_mesh", ("TriMesh", "PointSet"), ".svg", mesh_svg,
             "2-D tessellation wireframe with vertex dots (or just the points)"),
    Exporter("heightmap_png16", ("Grid",), ".png", heightmap_png16,
             "a Grid field as 16-bit greyscale PNG with a JSON sidecar (scale, provenance)"),
    Exporter("npy", ("Grid",), ".npy", heightmap_npy, "a Grid field as float64 NPY with a JSON sidecar"),
    Exporter("image_png", ("Grid",), ".png", image_png, "a Grid field colour-mapped, or RGB, as 8-bit PNG"),
    Exporter("obj", ("TriMesh",), ".obj", obj_export,
             "Wavefront OBJ + MTL; vertex colours and/or texture atlas PNG with UVs"),
    Exporter("glb", ("TriMesh",), ".glb", glb_export, "binary glTF via trimesh (Blender, web viewers)"),
    Exporter("preview_png", ("TriMesh",), ".png", preview_png,
             "a mesh seen from a fixed camera (software renderer): thumbnails, quick looks"),
)

__all__ = ["Exporter", "FieldName", "UpAxis", "field_options", "write", "write_many", "BUILTIN_EXPORTERS", "png_bytes", "to_rgb8",
           "polylines_svg", "mesh_svg", "heightmap_png16", "heightmap_npy", "image_png",
           "obj_export", "glb_export", "preview_png", "render_mesh_png"]
