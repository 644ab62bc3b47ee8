"""Reading mesh files (OBJ, PLY, STL, OFF, glTF/GLB) and the files they name, safely.

Why: an OBJ names its material library (``mtllib``) and the MTL names textures; a glTF names
external buffers and images. trimesh would open any of them as it finds them, so one that is a
named pipe hangs the run and one that is huge exhausts memory. Here every file a mesh names is
found first (``mesh_references``, also what ``procgen check`` runs) and refused in one line if
it is not a regular file or is too large; trimesh then reads the mesh from bytes procgen read
itself, through a resolver that applies the same bounds, with materials skipped (procgen keeps
geometry and texture coordinates only, so no texture is ever decoded). trimesh's own messages
never reach the user: they name its internals or repeat the file's bytes.
"""
from __future__ import annotations

import io
import json
import os
import re
import struct
import warnings
from pathlib import Path
from typing import Any
from urllib.parse import unquote

from ..errors import InputError, printable
from .input_files import check_input, read_input

#: the mesh formats procgen reads (trimesh's loaders)
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")

_MTLLIB = re.compile(rb"^[ \t]*mtllib[ \t]+([^\r\n]+)", re.MULTILINE)
_MTL_MAP = re.compile(r"^[ \t]*(?:map_\w+|bump|disp|decal|refl|norm)[ \t]+([^\r\n]+)", re.MULTILINE | re.IGNORECASE)


def check_mesh_file(path: Path) -> int:
    """Refuse (InputError, one line) a mesh file of an unknown type, not regular, too large, or
    naming a file that is not regular or too large; nothing is parsed beyond the names and the
    face count, which is returned (``face_count``)."""
    name = printable(path.name)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise InputError(f"{name}: not a mesh file type procgen reads ({', '.join(MESH_SUFFIXES)})")
    check_input(path, "mesh", name)
    data = read_input(path, "mesh", name)
    mesh_references(path, data)
    return face_count(path, data)


_PLY_FACES = re.compile(rb"^element[ \t]+face[ \t]+(\d+)", re.MULTILINE)


def face_count(path: Path, data: bytes) -> int:
    """About how many faces the mesh file holds, from its header or a count of its face
    records (an OBJ's ``f`` lines, an n-gon counted once); 0 when it cannot tell."""
    suffix = path.suffix.lower()
    if suffix == ".obj":
        return data.count(b"\nf ") + data.count(b"\nf\t") + (data[:2] in (b"f ", b"f\t"))
    if suffix == ".ply":
        m = _PLY_FACES.search(data[: data.find(b"end_header") + 1 or 65536])
        return int(m.group(1)) if m else 0
    if suffix == ".stl":
        if len(data) >= 84 and len(data) == 84 + 50 * struct.unpack_from("<I", data, 80)[0]:
            return struct.unpack_from("<I", data, 80)[0]
        return data.count(b"facet normal")
    if suffix == ".off":
        lines = (ln.split(b"#")[0].split() for ln in data[:65536].splitlines())
        counts = [t for t in lines if t and t[0] not in (b"OFF", b"COFF", b"NOFF")]
        return int(counts[0][1]) if counts and len(counts[0]) >= 2 and counts[0][1].isdigit() else 0
    doc = _gltf_json(path, data)
    acc = doc.get("accessors") if isinstance(doc.get("accessors"), list) else []
    total = 0
    for mesh in doc.get("meshes", []) if isinstance(doc.get("meshes"), list) else []:
        for prim in mesh.get("primitives", []) if isinstance(mesh, dict) else []:
            i = prim.get("indices", (prim.get("attributes") or {}).get("POSITION")) if isinstance(prim, dict) else None
            if isinstance(i, int) and 0 <= i < len(acc) and isinstance(acc[i], dict):
                count = acc[i].get("count", 0)
                total += count // 3 if isinstance(count, int) else 0
    return total


def mesh_references(path: Path, data: bytes) -> list[Path]:
    """The files the mesh file ``data`` (read from ``path``) names and trimesh would open, each
    checked (regular, within MAX_BYTES["mesh part"]); a named file that does not exist is left
    out (trimesh skips a missing material), a missing glTF buffer is refused."""
    suffix = path.suffix.lower()
    found: list[Path] = []
    if suffix == ".obj":
        for m in _MTLLIB.finditer(data):
            mtl = _check_part(path, m.group(1).decode("utf-8", "replace").strip(), required=False)
            if mtl is None:
                continue
            found.append(mtl)
            text = read_input(mtl, "mesh part", _part_name(path, mtl.name)).decode("utf-8", "replace")
            for t in _MTL_MAP.finditer(text):
                tokens = t.group(1).split()
                tex = _check_part(path, tokens[-1], required=False) if tokens else None
                if tex is not None:
                    found.append(tex)
    elif suffix in (".gltf", ".glb"):
        doc = _gltf_json(path, data)
        for key, required in (("buffers", True), ("images", False)):
            items = doc.get(key, [])
            for item in items if isinstance(items, list) else []:
                uri = item.get("uri") if isinstance(item, dict) else None
                if isinstance(uri, str) and not uri.startswith("data:"):
                    part = _check_part(path, unquote(uri), required)
                    if part is not None:
                        found.append(part)
    return found


def read_mesh(path: Path) -> Any:
    """The mesh file as one trimesh.Trimesh (or whatever trimesh makes of it): the file and
    what it names checked first, then parsed from bytes; InputError naming the file otherwise."""
    import trimesh

    name = printable(path.name)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise InputError(f"{name}: not a mesh file type procgen reads ({', '.join(MESH_SUFFIXES)})")
    data = read_input(path, "mesh", name)
    mesh_references(path, data)
    if path.suffix.lower() in (".obj", ".off"):
        # text formats: bytes that are not UTF-8 (a Latin-1 comment) would send trimesh guessing
        # the encoding with an optional module; they only ever sit in names and comments
        data = data.decode("utf-8", "replace").encode("utf-8")
    resolver = _bounded_resolver(path)
    try:
        with warnings.catch_warnings():      # trimesh warns about materials it skips
            warnings.simplefilter("ignore")
            loaded = trimesh.load(io.BytesIO(data), file_type=path.suffix.lower()[1:], resolver=resolver,
                                  force="mesh", process=False, skip_materials=True)
    except InputError:
        raise
    except Exception:  # trimesh raises many types for broken files; its text is not for users
        if resolver.refused is not None:
            raise resolver.refused from None
        raise InputError(f"{name}: not a readable {path.suffix.lower()[1:].upper()} mesh "
                         "(damaged, or not the format its name says)") from None
    if resolver.refused is not None:
        raise resolver.refused
    return loaded


def _part_name(path: Path, ref: str) -> str:
    return f"{printable(path.name)}: {printable(ref)[:80]}"


def _check_part(path: Path, ref: str, required: bool) -> Path | None:
    """The file ``ref`` names beside ``path``, checked; None if it does not exist, or lies
    outside the mesh's folder (trimesh will not open it), and is not required."""
    if not ref or "\x00" in ref:
        raise InputError(f"{_part_name(path, ref)}: not a valid file name")
    folder = path.parent.resolve()
    target = Path(os.path.normpath(folder / ref.strip()))
    if not target.is_relative_to(folder):
        if required:
            raise InputError(f"{_part_name(path, ref)}: names a file outside the mesh's folder")
        return None
    if not target.exists() and not target.is_symlink():
        if required:
            raise InputError(f"{_part_name(path, ref)}: file not found")
        return None
    check_input(target, "mesh part", _part_name(path, ref))
    return target


def _gltf_json(path: Path, data: bytes) -> dict:
    """The JSON part of a .gltf or .glb file (a GLB's first chunk)."""
    name = printable(path.name)
    if path.suffix.lower() == ".glb":
        if len(data) < 20 or data[:4] != b"glTF":
            raise InputError(f"{name}: not a GLB file (no glTF signature at its start)")
        length, kind = struct.unpack_from("<I4s", data, 12)
        if kind != b"JSON" or 20 + length > len(data):
            raise InputError(f"{name}: GLB file is damaged (no JSON chunk of the length it says)")
        text = data[20:20 + length]
    else:
        text = data
    try:
        doc = json.loads(text.decode("utf-8"))
    except (ValueError, RecursionError):
        raise InputError(f"{name}: not a readable glTF file (its JSON is damaged)") from None
    if not isinstance(doc, dict):
        raise InputError(f"{name}: not a readable glTF file (its JSON is not an object)")
    return doc


def _bounded_resolver(source: Path) -> Any:
    """trimesh's file resolver with procgen's checks on every file it opens; the first refusal
    is kept in ``refused``, because trimesh swallows some loader errors and goes on without
    the file."""
    from trimesh.resolvers import FilePathResolver

    class BoundedResolver(FilePathResolver):
        refused: InputError | None = None

        def get(self, name: str) -> bytes:
            try:
                target = _check_part(source, name, required=True)
                assert target is not None
                return read_input(target, "mesh part", _part_name(source, name))
            except InputError as exc:
                if self.refused is None:
                    self.refused = exc
                raise

        def namespaced(self, namespace: str) -> "BoundedResolver":
            raise InputError(f"{_part_name(source, namespace)}: names a folder, not a file")

    return BoundedResolver(str(source))
