"""Sun and rain exposure per cell: not in the thesis (it models no weather, its 2.2 only names
sunlight and moisture as causes), an extension from the wood-weathering literature.

E = mean over directions d of max(0, n . d) * vis(d), vis = 0 if a ray from the cell towards d
hits the mesh.  Sun: an equinox day's path at a latitude (hour angle h in (-90, 90) degrees:
d = -sin h east + cos h (cos(lat) up - sin(lat) north)), so equator-facing and upward faces get
most.  Rain: directions in a cone about ``up`` (wind-driven rain), a golden-angle spiral, so
upward faces open to the sky get most and sheltered undersides none.  Ray queries go through
trimesh: Embree (``embreex``, the ``embree`` extra) when installed, else trimesh's own
triangle intersector (needs ``rtree``, and is about 10^4 times slower).
"""
from __future__ import annotations

import numpy as np

from procgen import InputError, MissingExtra


def unit(v: np.ndarray, what: str) -> np.ndarray:
    a = np.asarray(v, float)
    n = float(np.linalg.norm(a))
    if a.shape != (3,) or n == 0:
        raise InputError(f"{what} must be a non-zero [x, y, z] vector, got {v!r}")
    return a / n


def sun_directions(count: int, latitude: float, up: np.ndarray, south: np.ndarray) -> np.ndarray:
    """(count, 3) unit directions towards the sun over an equinox day (hour angles evenly spaced)."""
    u = unit(up, "up")
    s = unit(south, "south")
    s = s - (s @ u) * u
    if np.linalg.norm(s) < 1e-9:
        raise InputError("exposure: 'south' must not be parallel to 'up'")
    s /= np.linalg.norm(s)
    north, east = -s, np.cross(-s, u)            # east = north x up (right-handed, up = z: +x)
    h = np.radians(-90 + 180 * (np.arange(count) + 0.5) / count)[:, None]
    lat = np.radians(latitude)
    return -np.sin(h) * east + np.cos(h) * (np.cos(lat) * u - np.sin(lat) * north)


def cone_directions(count: int, half_angle: float, up: np.ndarray) -> np.ndarray:
    """(count, 3) unit directions spread evenly (golden-angle spiral) over a cone about ``up``."""
    u = unit(up, "up")
    a = np.cross(u, [1.0, 0, 0] if abs(u[0]) < 0.9 else [0, 1.0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(u, a)
    k = np.arange(count) + 0.5
    cz = 1 - (1 - np.cos(np.radians(half_angle))) * k / count
    r = np.sqrt(np.clip(1 - cz * cz, 0, None))
    phi = k * np.pi * (3 - np.sqrt(5))
    return (cz[:, None] * u + (r * np.cos(phi))[:, None] * a + (r * np.sin(phi))[:, None] * b)


NO_ENGINE = ("exposure with occlusion = 'rays' needs a ray engine: pip install "
             "'procgen-rules[embree]' (or rtree), or set occlusion = 'none'")


def ray_engine() -> str | None:
    """'embree', 'triangle' (trimesh's own, needs rtree) or None: what ray queries can run on."""
    import importlib.util
    for name, module in (("embree", "embreex"), ("triangle", "rtree")):
        try:
            if importlib.util.find_spec(module) is not None:
                __import__(module)
                return name
        except (ImportError, ValueError):
            continue
    return None


def intersector(vertices: np.ndarray, faces: np.ndarray):
    """A trimesh ray intersector: Embree when ``embreex`` is installed, else trimesh's own."""
    import trimesh
    engine = ray_engine()
    if engine is None:
        raise MissingExtra(NO_ENGINE, "embree")
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    if engine == "embree":
        from trimesh.ray.ray_pyembree import RayMeshIntersector
    else:
        from trimesh.ray.ray_triangle import RayMeshIntersector
    return RayMeshIntersector(mesh)


def exposure(points: np.ndarray, normals: np.ndarray, directions: np.ndarray, *,
             rays=None, offset: float = 1e-4, chunk: int = 2_000_000) -> np.ndarray:
    """Mean of max(0, n . d) * vis(d) over ``directions``; vis = 1 everywhere if ``rays`` is None."""
    n = len(points)
    total = np.zeros(n)
    for d in np.asarray(directions, float):
        cos = normals @ d
        lit = np.nonzero(cos > 0)[0]
        if rays is not None and len(lit):
            vis = np.ones(len(lit), bool)
            for lo in range(0, len(lit), chunk):
                idx = lit[lo:lo + chunk]
                org = points[idx] + offset * normals[idx]
                vis[lo:lo + chunk] = ~rays.intersects_any(org, np.broadcast_to(d, org.shape).copy())
            lit = lit[vis]
        total[lit] += cos[lit]
    return total / max(len(directions), 1)


def birth_probability(sun: np.ndarray, rain: np.ndarray, floor: float) -> np.ndarray:
    """Per-cell probability that a birth the CA rule calls for happens (ca.life ``birth_field``).

    floor + (1 - floor) * (sun / max sun + rain / max rain) / 2: a cell as sunny and as wet as
    the object gets follows the plain rule, a fully sheltered cell is born with probability
    ``floor``.
    Sun and rain weigh alike, as both drive weathering (UV breaks the lignin down, rain washes
    the fragments off and feeds the grey fungi; the thesis's 2.2 names sunlight and moisture).
    """
    def share(e: np.ndarray) -> np.ndarray:
        top = float(e.max(initial=0.0))
        return e / top if top > 0 else np.zeros_like(e)
    return np.clip(floor + (1.0 - floor) * 0.5 * (share(sun) + share(rain)), 0.0, 1.0)
