"""Render a GLB the way a 3-D pipeline would take it: Blender (headless, Cycles), its own lights.

Why: the PBR material set (issue 35) is only right if a renderer that knows nothing of procgen
shows what the simulation made: bare copper metallic and reflective, patina matte, cracks as
grooves lit by the normal map.  The GLB is imported with Blender's glTF add-on as it is (no
material edits); the script adds a camera framing the object, a key sun, a fill area light and
a sky-like gradient world (a metal reflects its surroundings: under a uniform world it renders
as flat grey), and renders a small, few-sample Cycles image.

    python benchmarks/render_blender.py cup.glb /work/notes/renders/cup.png --azimuth 30 --elevation 25
    python benchmarks/render_blender.py plate.glb plate.png --elevation 55 --samples 32

Runs Blender as ``blender -b --factory-startup --python <this file> -- <args>``; Debian's
Blender 3.4 glTF add-on needs ``numpy.bool`` (removed in numpy 1.24) set first.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path


def parse(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("glb")
    ap.add_argument("png")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--azimuth", type=float, default=35.0, help="camera azimuth, degrees from +x")
    ap.add_argument("--elevation", type=float, default=25.0, help="camera elevation, degrees")
    ap.add_argument("--distance", type=float, default=2.6, help="camera distance in object radii")
    ap.add_argument("--sun-azimuth", type=float, default=-40.0)
    ap.add_argument("--sun-elevation", type=float, default=50.0)
    ap.add_argument("--sun-strength", type=float, default=3.0)
    ap.add_argument("--world", type=float, default=0.6, help="strength of the gradient world")
    ap.add_argument("--lens", type=float, default=50.0)
    return ap.parse_args(argv)


def in_blender(args: argparse.Namespace) -> None:
    import math

    import numpy
    numpy.bool = bool                       # Debian's glTF add-on on numpy >= 1.24
    import bpy
    from mathutils import Vector

    bpy.ops.wm.read_factory_settings(use_empty=True)
    # procgen's GLBs are +Y up (each writer turns the model's own up axis), and the importer
    # turns glTF's +Y to Blender's +Z: the model stands upright as imported, with no turn here
    bpy.ops.import_scene.gltf(filepath=args.glb)
    bpy.context.view_layer.update()
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    pts = [o.matrix_world @ Vector(c) for o in meshes for c in o.bound_box]
    lo = Vector((min(p.x for p in pts), min(p.y for p in pts), min(p.z for p in pts)))
    hi = Vector((max(p.x for p in pts), max(p.y for p in pts), max(p.z for p in pts)))
    centre, radius = (lo + hi) / 2, max((hi - lo).length / 2, 1e-6)
    for o in meshes:                         # what the importer made of the material, for the log
        for slot in o.material_slots:
            bsdf = next((n for n in slot.material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
            if bsdf is not None:
                linked = {k: (bsdf.inputs[k].links[0].from_node.type if bsdf.inputs[k].links else "unlinked")
                          for k in ("Base Color", "Metallic", "Roughness", "Normal")}
                print("MATERIAL", o.name, slot.material.name, linked)
    print("BOUNDS", tuple(round(v, 4) for v in lo), tuple(round(v, 4) for v in hi))

    scene = bpy.context.scene
    # glTF is +Y up; the importer turns it to Blender's +Z up, so elevation is about +Z
    az, el = math.radians(args.azimuth), math.radians(args.elevation)
    d = args.distance * radius
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = args.lens
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = centre + Vector((d * math.cos(el) * math.cos(az), d * math.cos(el) * math.sin(az), d * math.sin(el)))
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam

    sun_data = bpy.data.lights.new("sun", type="SUN")
    sun_data.energy = args.sun_strength
    sun_data.angle = math.radians(3.0)
    sun = bpy.data.objects.new("sun", sun_data)
    scene.collection.objects.link(sun)
    saz, sel = math.radians(args.sun_azimuth), math.radians(args.sun_elevation)
    towards = Vector((math.cos(sel) * math.cos(saz), math.cos(sel) * math.sin(saz), math.sin(sel)))
    sun.rotation_euler = (-towards).to_track_quat("-Z", "Y").to_euler()

    fill_data = bpy.data.lights.new("fill", type="AREA")
    fill_data.energy = 40.0 * radius * radius
    fill_data.size = 2.0 * radius
    fill = bpy.data.objects.new("fill", fill_data)
    scene.collection.objects.link(fill)
    fill.location = centre + Vector((-d * 0.8 * math.sin(az), d * 0.8 * math.cos(az), d * 0.3))
    fill.rotation_euler = (centre - fill.location).to_track_quat("-Z", "Y").to_euler()

    # world: a vertical gradient (bright sky above, darker ground below) for the metal to reflect
    world = bpy.data.worlds.new("world")
    scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    bg = nt.nodes["Background"]
    coord = nt.nodes.new("ShaderNodeTexCoord")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position, ramp.color_ramp.elements[0].color = 0.35, (0.12, 0.11, 0.10, 1)
    ramp.color_ramp.elements[1].position, ramp.color_ramp.elements[1].color = 0.75, (0.75, 0.82, 0.95, 1)
    mapr = nt.nodes.new("ShaderNodeMapRange")
    mapr.inputs["From Min"].default_value, mapr.inputs["From Max"].default_value = -1.0, 1.0
    nt.links.new(coord.outputs["Generated"], sep.inputs[0])      # in a world: the view direction
    nt.links.new(sep.outputs["Z"], mapr.inputs["Value"])
    nt.links.new(mapr.outputs["Result"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = args.world

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = args.width, args.height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Filmic"
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = args.png
    bpy.ops.render.render(write_still=True)
    print("WROTE", args.png)


def main() -> None:
    args = parse(sys.argv[1:])
    exe = shutil.which("blender")
    if not exe:
        raise SystemExit("render_blender: Blender is needed (Debian package 'blender')")
    Path(args.png).parent.mkdir(parents=True, exist_ok=True)
    # Debian's Blender finds its Python home from the first python on PATH (see tests/_blender.py)
    env = {**os.environ, "PATH": f"{Path(exe).resolve().parent}:{os.environ.get('PATH', '')}"}
    argv = [str(Path(args.glb).resolve()), str(Path(args.png).resolve())] + sys.argv[3:]
    r = subprocess.run([exe, "-b", "--factory-startup", "--python", __file__, "--", *argv], env=env,
                       capture_output=True, text=True)
    for line in r.stdout.splitlines():
        if line.startswith(("MATERIAL", "BOUNDS", "WROTE")):
            print(line)
    if r.returncode != 0 or not Path(args.png).is_file():
        raise SystemExit(f"render_blender: Blender failed:\n{r.stderr[-2000:]}")


if __name__ == "__main__":
    try:
        import bpy  # noqa: F401  (inside Blender)
    except ImportError:
        main()
    else:
        in_blender(parse(sys.argv[sys.argv.index("--") + 1:]))
