"""The cloudscape drawn as an illustrator would: soft lit lobes, light that dims through the cloud's
depth, silver linings, grey flat bases, aerial perspective down to many small hazy clouds at the
horizon, and each cloud's own shadow projected on the ground.

The thesis grows one outline (section 1.2 names layering outlines into scenes as a use it did not
build). Each snaxel curve is one rounded bulge (section 3.4), so a cloud is drawn as its lobes:
soft-edged domes lit from a sun direction. What makes a photograph of fair-weather cumulus read as
volume rather than cut-out, and how it is drawn here, all in plain SVG (gradients, clip paths,
masks, ``<use>`` clones and Gaussian-blur / turbulence / diffuse-lighting filters, which Inkscape
and Chromium both render):

* soft lobes: each lobe's radial gradient fades to transparent at its rim, so no circle edge shows
  inside the silhouette; a lobe whose sunward rim lies inside lobes nearer the sun is darker
  (:func:`occlusion`);
* volume light: the silhouette, shifted away from the sun by growing distances and blurred, greys
  the cloud where light has crossed more cloud to reach it (:func:`light_depth` counts it);
* texture finer than a lobe (``texture``): fractal noise lit from the sun (cauliflower bumps);
* rounded edges (``outline = "rounded"``): the snaxel fringe opened and closed by a disc (shapely
  buffers), the thesis outline (``"snaxel"``) kept as the default; thin edges translucent through
  a blurred silhouette mask, the sunward rim brighter than the domes (a silver lining);
* broad bases (``neck``): a cloud grown as a tower on a narrow neck is filled out to a flat-based
  heap (:func:`broaden`) whose added flanks are built of lobes like the grown outline
  (:func:`flank_lobes`); lobes the filling buried are not drawn (:func:`rim_lobes`);
* aerial perspective: far clouds smaller, flatter and paler, down to ``haze_clouds`` small clones
  of the grown outlines in the band above the horizon;
* with ``ground``, each cloud's shadow is its own outline projected along the sun onto the ground
  (:func:`ground_projection`), foreshortened and blurred.
"""
from __future__ import annotations

import hashlib
from typing import Any, Literal, get_args

import numpy as np
import shapely
import shapely.affinity

from procgen import InputError
from procgen.exchange.svg import finish, fmt_number

from .svgdoc import Page, curve_pieces, domain_box, mix, need

RIM_SAMPLES = 9
"""Points on the sunward half of a lobe's rim tested for cover by nearer lobes."""

SHADE_LEVELS = 4
"""Lobe occlusion darkness is drawn in this many steps per cloud (one gradient each)."""

DEPTH_STEPS = 3
"""Shifted silhouettes drawn for the light's path through a cloud (each one more step of cloud)."""

DEPTH_REACH = 0.45
"""The deepest shift, as a fraction of the cloud's height."""

GROUND_REACH = 0.9
"""How far down the ground band (horizon .. page bottom) the nearest cloud's shadow base lands."""

NECK_SAMPLES = 96
"""Heights at which :func:`neck_ratio` measures a cloud's cross-section."""

NECK_FLOOR = 0.1
"""The bottom share of a cloud's height :func:`neck_ratio` leaves out (its base's rounded corners)."""

NECK_SPREAD, BELL_POINTS = 0.3, 7
"""The bell :func:`broaden` hangs below each point reaches NECK_SPREAD x the cloud's height to either
side at the base; it is drawn with BELL_POINTS points a side."""

FLANK_GAP, FLANK_LOBE, FLANK_SINK, FLANK_STEP = 0.02, (0.05, 0.17), 0.4, 1.4
"""Lobes on a broadened flank (:func:`flank_lobes`): where the outline lies more than FLANK_GAP x the
cloud's height outside the grown cloud; radii FLANK_LOBE x the height; centres FLANK_SINK of a
radius inside the outline, FLANK_STEP radii apart."""

SIDE_TOL, SIDE_RUN = 0.01, 0.15
"""A side cut by the page's side: consecutive outline points within SIDE_TOL of the page width from
it, spanning at least SIDE_RUN of the cloud's height."""

LOBE_DIM = 0.6
"""How far toward the shade colour a lobe lit from straight behind the cloud darkens (:func:`lobe_light`)."""

HAZE_BLUR = 0.6
"""Blur (page units) softening the horizon clouds' edges."""

Outline = Literal["snaxel", "rounded"]
"""The thesis's snaxel contour, or that contour rounded by :func:`rounded` (``procgen check`` reads this)."""


def lobes(pts: np.ndarray, cv: np.ndarray, min_len: float) -> list[tuple[np.ndarray, float]]:
    """(centre, radius) of the bulge each curve draws (thesis section 3.4: one rounded bulge per
    curve), for curves at least ``min_len`` long: the centroid of the arc, with the radius
    reaching the arc's farthest point."""
    out = []
    for _, arc in curve_pieces(pts, cv):
        seg = np.hypot(*np.diff(arc, axis=0).T).sum() if len(arc) > 1 else 0.0
        if seg < min_len:
            continue
        c = arc.mean(0)
        out.append((c, float(np.hypot(*(arc - c).T).max())))
    return out


def occlusion(centres: np.ndarray, radii: np.ndarray, sun: np.ndarray) -> np.ndarray:
    """Share (0..1) of each lobe's sunward rim that lies inside a lobe nearer the sun.

    Lobes are ranked by how far they reach toward the sun (centre . sun + radius); a lobe's
    sunward rim (``RIM_SAMPLES`` points within 80 degrees of the sun direction) is shaded where it
    falls inside a higher-ranked lobe: that lobe stands between it and the sun, in front of or
    above it. The foremost lobe toward the sun is never shaded."""
    reach = centres @ sun + radii
    a = np.arctan2(sun[1], sun[0]) + np.radians(np.linspace(-80.0, 80.0, RIM_SAMPLES))
    rim = centres[:, None, :] + radii[:, None, None] * np.stack([np.cos(a), np.sin(a)], axis=-1)   # (n, k, 2)
    d = np.linalg.norm(rim[:, :, None, :] - centres[None, None, :, :], axis=-1)                       # (n, k, n)
    nearer = reach[None, :] > reach[:, None]                                                          # (n, n)
    inside = (d < radii[None, None, :]) & nearer[:, None, :]
    return inside.any(axis=2).mean(axis=1)


def depth_shifts(sun: np.ndarray, height: float) -> np.ndarray:
    """(DEPTH_STEPS, 2) model-space shifts of the silhouette away from the sun: a point covered by
    the k-th shifted copy has cloud at k/DEPTH_STEPS of DEPTH_REACH x height toward the sun."""
    k = np.arange(1, DEPTH_STEPS + 1)[:, None] / DEPTH_STEPS
    return -k * DEPTH_REACH * height * sun[None, :]


def light_depth(outline: np.ndarray, sun: np.ndarray, height: float, probes: np.ndarray) -> np.ndarray:
    """How many shifted silhouettes cover each probe point (0 .. DEPTH_STEPS): the steps of cloud
    the sunlight crossed to reach it, as the drawing shades it (before the blur)."""
    poly = shapely.Polygon(outline)
    cover = np.zeros(len(probes), int)
    for s in depth_shifts(sun, height):
        cover += shapely.contains_xy(poly, probes[:, 0] - s[0], probes[:, 1] - s[1])
    return cover


def rounded(pts: np.ndarray, radius: float) -> np.ndarray:
    """The outline opened then closed by a disc of ``radius``: fringe spikes and necks thinner than
    the disc are cut, notches narrower than it filled, every convex corner rounded. The largest
    part's exterior, counter-clockwise like the snake (model, y up)."""
    poly = shapely.make_valid(shapely.Polygon(pts))
    return _largest_ccw(poly.buffer(-radius, quad_segs=4).buffer(2 * radius, quad_segs=4).buffer(-radius, quad_segs=4),
                        pts)


def chord_widths(pts: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Length of the outline's horizontal cross-section (all its pieces) at each height in ``ys``."""
    poly = shapely.make_valid(shapely.Polygon(pts))
    x0, _, x1, _ = poly.bounds
    rows = np.stack([np.column_stack([np.full(len(ys), x0 - 1.0), ys]),
                     np.column_stack([np.full(len(ys), x1 + 1.0), ys])], axis=1)
    return shapely.length(shapely.intersection(shapely.linestrings(rows), poly))


def neck_ratio(pts: np.ndarray, samples: int = NECK_SAMPLES) -> float:
    """The narrowest cross-section over the widest one at or above it (0..1), above the bottom
    NECK_FLOOR of the height. A domed, broad-based cumulus is about 1 (no level wider than one below
    it); a tower on a narrow neck is small."""
    y0, y1 = pts[:, 1].min(), pts[:, 1].max()
    w = chord_widths(pts, np.linspace(y0 + NECK_FLOOR * (y1 - y0), y1, samples + 1)[:-1])
    above = np.maximum.accumulate(w[::-1])[::-1]
    return float(np.min(w / np.maximum(above, 1e-12)))


def broaden(pts: np.ndarray, spread: float = NECK_SPREAD) -> tuple[np.ndarray, list[tuple[np.ndarray, float]]]:
    """The outline with a bell below every point added down to its base (the Minkowski sum with
    the convex region |x| <= spread sqrt(depth x height): each level at least as wide as any level
    above it, necks and overhangs filled, the base flat), its added flanks then built of lobes
    (:func:`flank_lobes`) so they bulge like the rest of a cumulus instead of a smooth bell.
    Returns the outline (counter-clockwise, model y up) and the added lobes (centre, radius)."""
    poly = shapely.make_valid(shapely.Polygon(pts))
    x0, base, x1, top = poly.bounds
    h = top - base
    a = np.asarray(shapely.simplify(poly, 0.002 * h).exterior.coords)[:-1] if isinstance(poly, shapely.Polygon) else pts
    b = np.roll(a, -1, axis=0)
    d = h * np.linspace(0.0, 1.0, BELL_POINTS) ** 2
    half = spread * np.sqrt(d * h)
    bell = np.concatenate([np.column_stack([-half, -d]), np.column_stack([half, -d])])          # (2k, 2)
    corners = np.concatenate([a[:, None, :] + bell[None], b[:, None, :] + bell[None]], axis=1)  # (n, 4k, 2)
    bells = shapely.convex_hull(shapely.multipoints(corners))
    frame = shapely.box(x0 - 3 * spread * h - 1, base, x1 + 3 * spread * h + 1, top)
    filled = shapely.union_all(np.append(bells, poly)).intersection(frame)
    bell_outline = _largest_ccw(filled, pts)
    added = flank_lobes(bell_outline, poly, base, h, _hash_rng(pts))
    if not added:
        return bell_outline, added
    discs = shapely.buffer(shapely.points([c for c, _ in added]), [r for _, r in added], quad_segs=8)
    return _largest_ccw(shapely.union_all([shapely.Polygon(bell_outline), *discs]).intersection(frame), pts), added


def flank_lobes(outline: np.ndarray, cloud: Any, base: float, h: float,
                rng: np.random.Generator) -> list[tuple[np.ndarray, float]]:
    """Lobes (centre, radius) along the part of ``outline`` added to the ``cloud`` polygon (more
    than FLANK_GAP x its height ``h`` outside it, above its ``base``): radii drawn in FLANK_LOBE x
    h, each centre FLANK_SINK of its radius inside the outline, FLANK_STEP radii apart along it,
    so their union with the outline scallops the added flank like the grown bumps."""
    ring = shapely.LinearRing(outline)
    step = 0.005 * h
    s = np.arange(0.0, ring.length, step)
    p = shapely.get_coordinates(shapely.line_interpolate_point(ring, s))
    new = (shapely.distance(cloud, shapely.points(p)) > FLANK_GAP * h) & (p[:, 1] > base + FLANK_GAP * h)
    if not new.any() or new.all():
        return []
    shift = int(np.flatnonzero(~new)[0])          # start the walk outside every added run
    p, new = np.roll(p, -shift, axis=0), np.roll(new, -shift)
    t = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    inward = np.column_stack([-t[:, 1], t[:, 0]]) / np.maximum(np.hypot(*t.T), 1e-12)[:, None]   # left of a CCW walk
    out, k = [], 0
    while k < len(p):
        if not new[k]:
            k += 1
            continue
        r = h * rng.uniform(*FLANK_LOBE)
        out.append((p[k] + FLANK_SINK * r * inward[k], float(r)))
        k += max(1, int(FLANK_STEP * r / step))
    return out


def round_sides(pts: np.ndarray, walls: tuple[float, float], tol: float) -> np.ndarray:
    """Sides cut flat by a vertical wall (the growth domain's side, or a crop) swapped for a
    half-ellipse bulge, so no cloud shows the cut: a side is cut where consecutive outline points
    within ``tol`` of a wall's x span at least SIDE_RUN of the cloud's height."""
    poly = shapely.make_valid(shapely.Polygon(pts))
    x0, base, x1, top = poly.bounds
    w, h = x1 - x0, top - base
    bulges = []
    for wall in walls:
        on = _longest_run(pts, np.abs(pts[:, 0] - wall) <= tol)
        if len(on) and np.ptp(on[:, 1]) >= SIDE_RUN * h:
            lo, hi, x = on[:, 1].min(), on[:, 1].max(), float(np.median(on[:, 0]))
            disc = shapely.Point(x, 0.5 * (lo + hi)).buffer(1.0, quad_segs=8)
            bulges.append(shapely.affinity.scale(disc, 0.2 * (hi - lo), 0.5 * (hi - lo), origin=(x, 0.5 * (lo + hi))))
    if not bulges:
        return pts
    grown = shapely.union_all([poly, *bulges]).intersection(
        shapely.box(x0 - w, base, x1 + w, top))
    return _largest_ccw(grown, pts)


def _longest_run(pts: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The points of the tallest run of consecutive ``mask`` points along the closed outline."""
    if mask.all() or not mask.any():
        return pts[mask]
    shift = int(np.flatnonzero(~mask)[0])           # start the cycle outside every run
    m, p = np.roll(mask, -shift), np.roll(pts, -shift, axis=0)
    edges = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    runs = [p[a:b] for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))]
    return max(runs, key=lambda r: np.ptp(r[:, 1]))


def _largest_ccw(geom: Any, fallback: np.ndarray) -> np.ndarray:
    parts = [g for g in getattr(geom, "geoms", [geom]) if isinstance(g, shapely.Polygon) and not g.is_empty]
    if not parts:
        return fallback
    best = shapely.orient_polygons(max(parts, key=lambda g: g.area))
    return np.asarray(best.exterior.coords)[:-1]


def silhouette(pts: np.ndarray, outline: str, radius: float, neck: float, walls: tuple[float, float] | None,
               tol: float) -> tuple[np.ndarray, list[tuple[np.ndarray, float]]]:
    """The outline a cloud is drawn with: sides cut flat by the growth domain's ``walls`` rounded
    (:func:`round_sides`; None: kept),
    rounded by a disc of ``radius`` (``outline = "rounded"``), and, when its :func:`neck_ratio` is
    under ``neck``, broadened (:func:`broaden`) and rounded again: no tower on a narrow neck.
    Returns the outline and the lobes the broadening added (none when it did not)."""
    shape = round_sides(pts, walls, tol) if walls is not None else pts
    soft = (lambda p: rounded(p, radius)) if outline == "rounded" else (lambda p: p)
    shape = soft(shape)
    if neck > 0 and neck_ratio(shape) < neck:
        heap, added = broaden(shape)
        return soft(heap), added
    return shape, []


def rim_lobes(found: list[tuple[np.ndarray, float]], shape: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """The lobes whose disc reaches the drawn outline: a lobe lying wholly inside the body (a grown
    bulge a broadening buried) is no dome on the surface, and drawn it would show as a grey disc."""
    if not found:
        return found
    reach = shapely.distance(shapely.LinearRing(shape), shapely.points([c for c, _ in found]))
    return [lobe for lobe, d in zip(found, reach) if d <= lobe[1]]


def framed(drawn: np.ndarray, qx: float, qy: float, ty: float, sc: float, sy: float, page_w: float,
           margin: float) -> tuple[float, float, float]:
    """(sc, sy, dx) keeping a cloud whole inside the page by ``margin``: scaled down about its base
    if its top would rise above the margin, shifted sideways (``dx``) off the left and right
    margins (centred when wider than the room between them). ``drawn``: its page outline before
    the layer's transform translate(qx + dx, ty) scale(sc, sy) translate(-qx, -qy)."""
    top = ty + sy * (drawn[:, 1].min() - qy)
    if top < margin < ty:
        f = (ty - margin) / (ty - top)
        sc, sy = sc * f, sy * f
    lo, hi = qx + sc * (drawn[:, 0].min() - qx), qx + sc * (drawn[:, 0].max() - qx)
    if hi - lo > page_w - 2 * margin:
        return sc, sy, 0.5 * page_w - 0.5 * (lo + hi)
    return sc, sy, max(margin - lo, 0.0) + min(page_w - margin - hi, 0.0)


def ground_projection(sun3: np.ndarray, y_h: float, y_g: float, y_b: float, page_h: float) -> tuple[float, ...]:
    """SVG matrix (a, b, c, d, e, f) taking a drawn cloud point (page, y down) to its shadow.

    A point at height Z above its cloud's base (Z = y_b - y on the page) stands base_height + Z
    above the ground, base_height = y_g - y_b (the base's height over where its shadow lands); light along the unit sun vector (x right, y up, z toward the viewer) carries
    it sideways by (base_height + Z) sun_x / sun_y (away from the sun) and back, away from the
    viewer, by Z sun_z / sun_y. On the page the shadow of the base lands at y_g (nearer clouds
    lower), and depth is foreshortened by the ground's slope there, (y_g - y_h) / page_h per page
    unit: to first order (one affine map per cloud) x' = x - (base_height + y_b - y) sun_x/sun_y,
    y' = y_g - q (y_b - y), q = sun_z/sun_y (y_g - y_h)/page_h.
    """
    base_height = y_g - y_b
    rho = -sun3[0] / sun3[1]
    q = sun3[2] / sun3[1] * (y_g - y_h) / page_h
    return (1.0, 0.0, -rho, q, rho * (base_height + y_b), y_g - q * y_b)


def _blur(dwg: Any, ident: str, std: float) -> str:
    f = dwg.defs.add(dwg.filter(id=ident, x="-50%", y="-50%", width="200%", height="200%"))
    f.feGaussianBlur(in_="SourceGraphic", stdDeviation=fmt_number(std))
    return f"url(#{ident})"


def _matrix(m: tuple[float, ...]) -> str:
    return "matrix(" + " ".join(fmt_number(v) for v in m) + ")"


def _hash_rng(pts: np.ndarray) -> np.random.Generator:
    """A random stream fixed by the outlines themselves: the same recipe and seed draw the same haze."""
    return np.random.default_rng(int.from_bytes(hashlib.sha256(np.ascontiguousarray(pts).tobytes()).digest()[:8], "little"))


def _compose(p: tuple[float, ...], t: tuple[float, ...]) -> tuple[float, ...]:
    """SVG matrix p after t (p(t(x)))."""
    a, b, c, d, e, f = p
    A, B, C, D, E, F = t
    return (a * A + c * B, b * A + d * B, a * C + c * D, b * C + d * D, a * E + c * F + e, b * E + d * F + f)


def cloudscape_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: float = 1000,
                   units: str = "px", sky: bool = True, sky_top: str = "#3f78c0", sky_horizon: str = "#c9def2",
                   lit: str = "#ffffff", shade: str = "#9aa6b8", sun_x: float = -0.55, sun_y: float = 0.85,
                   sun_z: float = 1.2, lobe_min: float = 0.04, perspective: float = 0.45, flatten: float = 0.35,
                   soft: float = 0.0, horizon: float | None = 0.08, base_level: float = 0.42,
                   self_shadow: float = 0.5, silver: float = 0.9, thin_edge: float = 0.012,
                   outline: Outline = "snaxel", round_radius: float = 0.03, texture: float = 0.0,
                   haze_clouds: int = 0, ground: str | None = None, ground_shadow: float = 0.35,
                   neck: float = 0.0, bleed: bool = False, frame_margin: float = 0.02, title: str = "") -> bytes:
    """Clouds as an illustrator draws them, back to front, one Inkscape layer per cloud.

    Each cloud's outline is the snaxel contour (``outline = "snaxel"``, the thesis) or that
    contour opened and closed by a disc of ``round_radius`` x its height (``"rounded"``: spikes
    cut, edges rounded). The cloud is clipped to it and masked by its blurred copy (``thin_edge``:
    the blur as a fraction of the cloud's height), so its rim fades into the sky and thin fringes
    are translucent. Inside: the body lit above and greyer below; one soft disc per lobe (each
    snaxel curve is a bulge, thesis section 3.4) whose radial gradient leans its bright focus to
    the sun (``sun_x``, ``sun_y``, y up) and fades out at its rim, darkened by up to
    ``self_shadow`` of the way to the shade colour by its :func:`occlusion`; the silhouette
    shifted away from the sun in DEPTH_STEPS steps and blurred, each at ``self_shadow`` / 2
    opacity, so light dims with the cloud it crossed (:func:`light_depth`); with ``texture`` > 0
    (0..1) fractal bumps a few percent of the cloud's height across, lit from the sun; a grey
    band along the base; a bright sunward rim (``silver``: its opacity). Far clouds (low
    cloud__depth) are drawn smaller and flatter (``perspective``, ``flatten``) and paler. With
    ``horizon`` (a fraction of the page height from the bottom; None: bases stay where they grew)
    every base sits on one condensation plane seen in perspective: a cloud drawn at scale s has
    its base at horizon + s (base_level - horizon); ``haze_clouds`` more clouds, clones of the
    grown outlines at a fraction of the farthest cloud's scale, flatter and paler, fill the band
    above the horizon (placed by a random stream fixed by the outlines). ``ground`` (a colour;
    needs ``horizon``) fills the page below the horizon on a "ground" layer carrying each cloud's
    shadow: its drawn outline projected along the sun vector (``sun_x``, ``sun_y``, ``sun_z``
    toward the viewer) by :func:`ground_projection`, blurred, at opacity ``ground_shadow``.
    ``soft`` > 0 blurs whole clouds by that fraction of their height; ``sky`` = false leaves the
    background empty.
    """
    if horizon is not None and not 0.0 <= horizon < base_level <= 1.0:
        raise InputError(f"cloudscape_svg: need 0 <= horizon < base_level <= 1, got {horizon}, {base_level}")
    if ground is not None and horizon is None:
        raise InputError("cloudscape_svg: ground needs a horizon (a fraction of the page height)")
    if haze_clouds and horizon is None:
        raise InputError("cloudscape_svg: haze_clouds needs a horizon (a fraction of the page height)")
    for name, v in (("self_shadow", self_shadow), ("silver", silver), ("thin_edge", thin_edge),
                    ("ground_shadow", ground_shadow), ("texture", texture), ("round_radius", round_radius),
                    ("neck", neck), ("frame_margin", frame_margin)):
        if not 0.0 <= v <= 1.0:
            raise InputError(f"cloudscape_svg: {name} = {v!r}: expected 0..1")
    if outline not in get_args(Outline):
        raise InputError(f"cloudscape_svg: outline = {outline!r}: expected one of {', '.join(get_args(Outline))}")
    if not 0 <= int(haze_clouds) <= 500:
        raise InputError(f"cloudscape_svg: haze_clouds = {haze_clouds!r}: expected 0..500")
    if ground is not None and not (sun_y > 0 and sun_z > 0):
        raise InputError(f"cloudscape_svg: ground shadows need the sun above the ground and toward the viewer "
                         f"(sun_y > 0, sun_z > 0), got sun_y = {sun_y}, sun_z = {sun_z}")
    dom = need(domain, "cloudscape_svg", "cloud__depth")
    norm = float(np.hypot(sun_x, sun_y))
    if norm == 0:
        raise InputError("cloudscape_svg: sun_x and sun_y are both 0 (no sun direction)")
    sun = np.array([sun_x, sun_y]) / norm
    sun3 = np.array([sun_x, sun_y, sun_z]) / float(np.linalg.norm([sun_x, sun_y, sun_z]))
    page = Page(domain_box(dom), width, units)
    dwg = page.dwg
    if sky:
        grad = dwg.linearGradient(start=(0, 0), end=(0, 1), id="sky")
        grad.add_stop_color(0, sky_top)
        grad.add_stop_color(1, sky_horizon)
        dwg.defs.add(grad)
        page.layer("sky").add(dwg.rect(insert=(0, 0), size=(fmt_number(page.w), fmt_number(page.h)), fill="url(#sky)"))
    y_h = page.h * (1.0 - horizon) if horizon is not None else page.h
    land = None
    if ground is not None:
        grad = dwg.linearGradient(start=(0, 0), end=(0, 1), id="ground")
        grad.add_stop_color(0, mix(ground, sky_horizon, 0.6))      # haze at the horizon
        grad.add_stop_color(1, ground)
        dwg.defs.add(grad)
        layer = page.layer("ground")
        layer.add(dwg.rect(insert=(0, fmt_number(y_h)), size=(fmt_number(page.w), fmt_number(page.h - y_h)),
                           fill="url(#ground)"))
        clip = dwg.defs.add(dwg.clipPath(id="land"))
        clip.add(dwg.rect(insert=(0, fmt_number(y_h)), size=(fmt_number(page.w), fmt_number(page.h - y_h))))
        land = layer.add(dwg.g(clip_path="url(#land)"))
    depth = dom["cloud__depth"]
    curve = dom["snaxel__curve"] if "snaxel__curve" in dom else np.zeros(len(dom.points), np.int64)
    n = max(int(depth.max()) + 1, 1)
    heights = np.array([np.ptp(dom.points[dom.offsets[i]:dom.offsets[i + 1], 1]) for i in range(len(depth))])
    shapes, added = [], []
    for i in range(len(depth)):     # each outline once, in defs; every other use is a <use> clone
        shape, extra = silhouette(dom.points[dom.offsets[i]:dom.offsets[i + 1]], outline, round_radius * heights[i],
                                  neck, None if bleed else page.box[:2], SIDE_TOL * page.w)
        shapes.append(shape)
        added.append(extra)
        dwg.defs.add(dwg.path(d=page.d(shapes[-1]), id=f"outline{i}"))
    if haze_clouds:
        _haze(dwg, page, dom, shapes, int(haze_clouds), y_h, perspective, flatten, base_level - horizon,
              lit, shade, sky_horizon, None if bleed else frame_margin * page.w)
    for i in np.argsort(depth, kind="stable"):
        far = 1.0 - (float(depth[i]) / (n - 1) if n > 1 else 1.0)
        pts, cv = dom.points[dom.offsets[i]:dom.offsets[i + 1]], curve[dom.offsets[i]:dom.offsets[i + 1]]
        (qx, qy) = page.xy(np.array([[pts[:, 0].mean(), pts[:, 1].min()]]))[0]
        height = float(heights[i])
        sc = 1.0 - perspective * far
        sy = sc * (1 - flatten * far)
        top = mix(lit, sky_horizon, 0.45 * far)
        bottom = mix(shade, sky_horizon, 0.55 * far)
        ty = qy if horizon is None else page.h * (1.0 - horizon - sc * (base_level - horizon))
        dx = 0.0
        if not bleed:
            sc, sy, dx = framed(page.xy(shapes[i]), qx, qy, ty, sc, sy, page.w, frame_margin * page.w)
        tf = (sc, 0.0, 0.0, sy, qx + dx - sc * qx, ty - sy * qy)
        if land is not None:
            y_g = y_h + GROUND_REACH * (page.h - y_h) * sc
            sh = _compose(ground_projection(sun3, y_h, y_g, ty, page.h), tf)
            std = 0.25 * sh[3] * height + 0.004 * page.h
            land.add(dwg.use(f"#outline{i}", transform=_matrix(sh), fill=mix(ground, "#000000", 0.55),
                             fill_opacity=fmt_number(ground_shadow), filter=_blur(dwg, f"ground-shadow{i}", std),
                             id=f"shadow-of-cloud-{int(i) + 1}"))
        attrs: dict[str, Any] = {"transform": f"translate({fmt_number(qx + dx)},{fmt_number(ty)}) scale({fmt_number(sc)},"
                                              f"{fmt_number(sy)}) translate({fmt_number(-qx)},{fmt_number(-qy)})"}
        if soft > 0:
            attrs["filter"] = _blur(dwg, f"soft{i}", soft * height)
        layer = page.layer(f"cloud {int(i) + 1} (depth {int(depth[i])})", **attrs)
        _draw_cloud(dwg, layer, page, int(i), pts, cv, shapes[i], added[i], height, sun, sun3, top, bottom, lobe_min,
                    self_shadow, silver, thin_edge, texture)
    return finish(dwg, provenance, title or "snaxel cloudscape")


def _draw_cloud(dwg: Any, layer: Any, page: Page, i: int, pts: np.ndarray, cv: np.ndarray, shape: np.ndarray,
                added: list[tuple[np.ndarray, float]], height: float, sun: np.ndarray, sun3: np.ndarray, top: str,
                bottom: str, lobe_min: float, self_shadow: float, silver: float, thin_edge: float,
                texture: float) -> None:
    """One cloud inside its clip (and edge mask), in the cloud's own page coordinates."""
    ref = f"#outline{i}"
    clip = dwg.defs.add(dwg.clipPath(id=f"cloud{i}"))
    clip.add(dwg.use(ref))
    g = dwg.g(clip_path=f"url(#cloud{i})")
    if thin_edge > 0:     # the silhouette's alpha blurred: the rim fades, thin fringes are see-through
        mask = dwg.defs.add(dwg.mask(id=f"edge{i}"))
        mask.add(dwg.use(ref, fill="#ffffff", filter=_blur(dwg, f"edge-blur{i}", thin_edge * height)))
        g["mask"] = f"url(#edge{i})"
    fill = dwg.linearGradient(start=(0, 0), end=(0, 1), id=f"body{i}")    # lit above, greyer below
    fill.add_stop_color(0.0, top)
    fill.add_stop_color(1.0, mix(top, bottom, 0.3))
    dwg.defs.add(fill)
    g.add(dwg.use(ref, fill=f"url(#body{i})"))
    found = rim_lobes(lobes(pts, cv, lobe_min * height) + added, shape)
    if found:
        _draw_lobes(dwg, g, page, i, found, shape, height, sun, sun3, top, bottom, self_shadow)
    if self_shadow > 0:   # light dims through the cloud: its silhouette shifted away from the sun, blurred
        blur = _blur(dwg, f"depth{i}", 0.12 * height)
        for s in depth_shifts(sun, height):
            g.add(dwg.use(ref, transform=f"translate({fmt_number(s[0])},{fmt_number(-s[1])})", fill=bottom,
                          fill_opacity=fmt_number(0.5 * self_shadow), filter=blur))
    x0, y0 = page.xy(np.array([[shape[:, 0].min(), shape[:, 1].max()]]))[0]
    box = {"insert": (fmt_number(x0), fmt_number(y0)), "size": (fmt_number(np.ptp(shape[:, 0])), fmt_number(np.ptp(shape[:, 1])))}
    if texture > 0:
        tex = g.add(dwg.rect(**box, fill=bottom, filter=_texture(dwg, i, height, sun, bottom, texture)))
        if found:
            tex["mask"] = _lobe_mask(dwg, page, i, found, sun)
    base = dwg.linearGradient(start=(0, 0), end=(0, 1), id=f"base{i}")
    base.add_stop_color(0.55, bottom, 0.0)
    base.add_stop_color(1.0, bottom, 0.85)
    dwg.defs.add(base)
    g.add(dwg.rect(**box, fill=f"url(#base{i})"))
    silver = min(1.0, silver * (1.0 + max(0.0, -float(sun3[2]))))    # a backlit cloud's rim glows more
    if silver > 0:     # the sunward edge, brighter than the domes: a stroke whose inner half the clip keeps
        rim = dwg.linearGradient(start=(fmt_number(0.5 - 0.5 * sun[0]), fmt_number(0.5 + 0.5 * sun[1])),
                                 end=(fmt_number(0.5 + 0.5 * sun[0]), fmt_number(0.5 - 0.5 * sun[1])), id=f"rim{i}")
        rim.add_stop_color(0.0, "#ffffff", 0.0)
        rim.add_stop_color(0.55, "#ffffff", 0.0)
        rim.add_stop_color(1.0, "#ffffff", silver)
        dwg.defs.add(rim)
        g.add(dwg.use(ref, fill="none", stroke=f"url(#rim{i})", stroke_width=fmt_number(0.06 * height),
                      stroke_linejoin="round", filter=_blur(dwg, f"rim-blur{i}", 0.012 * height)))
    layer.add(g)


def _lobe_mask(dwg: Any, page: Page, i: int, found: list[tuple[np.ndarray, float]], sun: np.ndarray) -> str:
    """Where the fine bumps show: a ring on each lobe (a mask of the lobe discs, each filled with one
    shared radial gradient, black over the smooth lit dome, white toward its rim, black past it),
    its dark centre leaning to the sun so the ring is widest on the lobe's shaded flank: the
    cauliflower texture follows the lobes instead of lying over the cloud as one sheet."""
    ident = "lobe-texture"
    if not any(e.attribs.get("id") == ident for e in dwg.defs.elements):
        grad = dwg.radialGradient(center=(0.5, 0.5), r=0.5, focal=(0.5 + 0.3 * sun[0], 0.5 - 0.3 * sun[1]), id=ident)
        for off, grey in ((0.0, "#000000"), (0.45, "#000000"), (0.8, "#ffffff"), (1.0, "#000000")):
            grad.add_stop_color(off, grey)
        dwg.defs.add(grad)
    mask = dwg.defs.add(dwg.mask(id=f"texture-mask{i}"))
    for (cx, cy), (_, r) in zip(page.xy(np.array([c for c, _ in found])), found):
        mask.add(dwg.circle(center=(fmt_number(cx), fmt_number(cy)), r=fmt_number(1.15 * r), fill=f"url(#{ident})"))
    return f"url(#texture-mask{i})"


def _texture(dwg: Any, i: int, height: float, sun: np.ndarray, colour: str, strength: float) -> str:
    """Cauliflower bumps finer than a lobe: fractal noise as a height map lit from the sun
    (feDiffuseLighting), its dark sides turned into ``colour`` at up to ``strength`` opacity."""
    f = dwg.defs.add(dwg.filter(id=f"texture{i}", x="0", y="0", width="1", height="1"))
    f.feTurbulence(type="fractalNoise", baseFrequency=fmt_number(1.0 / (0.05 * height)), numOctaves=3,
                   seed=i + 1, result="bumps")
    light = f.feDiffuseLighting(in_="bumps", surfaceScale=fmt_number(0.04 * height), diffuseConstant=1,
                                lighting_color="#ffffff", result="lit")
    light.feDistantLight(azimuth=fmt_number(np.degrees(np.arctan2(-sun[1], sun[0]))), elevation=35)
    r, gr, b = (int(colour[k:k + 2], 16) / 255 for k in (1, 3, 5))
    a = strength / 3
    f.feColorMatrix(in_="lit", type="matrix", values=" ".join(fmt_number(v) for v in (
        0, 0, 0, 0, r, 0, 0, 0, 0, gr, 0, 0, 0, 0, b, -a, -a, -a, 0, strength)))
    return f"url(#texture{i})"


def haze_shape(outline: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A far cloud of its own cut from a grown outline: a random 45-100 % of its width (the part in a
    random vertical band), the cut sides bulged by :func:`round_sides`, simplified to 0.5 % of the
    width (a few dozen points). Counter-clockwise, model y up."""
    poly = shapely.make_valid(shapely.Polygon(outline))
    x0, y0, x1, y1 = poly.bounds
    w = (x1 - x0) * rng.uniform(0.45, 1.0)
    a = x0 + (x1 - x0 - w) * rng.uniform()
    piece = _largest_ccw(poly.intersection(shapely.box(a, y0 - 1, a + w, y1 + 1)), outline)
    out = round_sides(piece, (a, a + w), 1e-6 * w)
    return _largest_ccw(shapely.simplify(shapely.Polygon(out), 0.005 * np.ptp(out[:, 0])), out)


def _haze(dwg: Any, page: Page, dom: Any, shapes: list[np.ndarray], count: int, y_h: float,
          perspective: float, flatten: float, base_rise: float, lit: str, shade: str, sky_horizon: str,
          margin: float | None) -> None:
    """``count`` small far clouds above the horizon, each its own :func:`haze_shape` (a cut of a
    drawn outline, mirrored at random) drawn at 12-60 % of the farthest cloud's scale, on the
    same condensation plane (so smaller sits lower), flatter and paler the farther; a layer
    "horizon clouds" with one sub-layer per cloud, farthest first. With a ``margin`` each lies
    whole inside the page by it (moved sideways); None lets them bleed off the sides."""
    rng = _hash_rng(dom.points)
    u = np.sort(rng.uniform(0.12, 0.6, count))
    src = rng.integers(0, len(shapes), count)
    flip = rng.choice([-1.0, 1.0], count)
    xs = rng.uniform(0.0, page.w, count)
    group = page.layer("horizon clouds")
    blur = _blur(dwg, "haze-blur", HAZE_BLUR)
    for j in range(count):
        shape = haze_shape(shapes[src[j]], rng)
        s = (1.0 - perspective) * u[j]
        sx, sy = flip[j] * s, s * (1.0 - flatten) * (0.5 + 0.5 * u[j])
        cx, base = 0.5 * (shape[:, 0].min() + shape[:, 0].max()), shape[:, 1].min()
        ty = y_h - s * base_rise * page.h
        half = 0.5 * s * np.ptp(shape[:, 0])
        x = xs[j] if margin is None else float(np.clip(xs[j], margin + half, max(page.w - margin - half, margin + half)))
        drawn = np.column_stack([x + sx * (shape[:, 0] - cx), ty - sy * (shape[:, 1] - base)])
        pale = 1.0 - u[j]
        grad = dwg.linearGradient(start=(0, 0), end=(0, 1), id=f"haze{j}")
        grad.add_stop_color(0.0, mix(lit, sky_horizon, 0.35 + 0.5 * pale))
        grad.add_stop_color(1.0, mix(shade, sky_horizon, 0.55 + 0.4 * pale))
        dwg.defs.add(grad)
        page.sublayer(group, f"horizon cloud {j + 1}", f"horizon-cloud-{j + 1}").add(
            dwg.path(d=page.ds([np.round(drawn, 1)], True, page=True)[0], fill=f"url(#haze{j})", filter=blur))


def lobe_light(sun3: np.ndarray) -> tuple[tuple[float, float], float]:
    """How a round lobe (a sphere seen from the front) is lit by the unit sun vector (x right, y up,
    z toward the viewer): its brightest point is where the surface normal is the sun vector,
    seen at (x, y) x the lobe's radius from its centre (on the rim, toward the sun, when z < 0),
    so a high sun behind the viewer lights the dome head-on and a grazing sun lights its rim; the lit share of the visible half is
    (1 + z) / 2, so a lobe darkens by LOBE_DIM x (1 - z) / 2 toward the shade colour (the whole
    face darkening as the sun moves behind the cloud). Returns ((fx, fy) the gradient's focal
    point in the disc's box, y down, and the darkening 0..LOBE_DIM)."""
    x, y, z = (float(v) for v in sun3)
    if z < 0:                       # sun behind the cloud: the brightest visible point is on the rim
        n = float(np.hypot(x, y))
        x, y = (x / n, y / n) if n > 0 else (0.0, 0.0)
    return (0.5 + 0.45 * x, 0.5 - 0.45 * y), LOBE_DIM * (1.0 - z) / 2.0


def _draw_lobes(dwg: Any, g: Any, page: Page, i: int, found: list[tuple[np.ndarray, float]], shape: np.ndarray,
                height: float, sun: np.ndarray, sun3: np.ndarray, top: str, bottom: str, self_shadow: float) -> None:
    """Soft lobes from the far side of the sun to the near side, each darkened (in SHADE_LEVELS
    steps) by the larger of its occlusion and the share of DEPTH_STEPS of cloud the light crossed
    to reach its sunward face (:func:`light_depth`); each gradient fades to transparent at the rim,
    so no circle edge shows."""
    centres = np.array([c for c, _ in found])
    radii = np.array([r for _, r in found])
    face = light_depth(shape, sun, height, centres + radii[:, None] * sun) / DEPTH_STEPS
    level = np.rint(np.maximum(occlusion(centres, radii, sun), face) * (SHADE_LEVELS - 1)).astype(int)
    (fx, fy), dim = lobe_light(sun3)
    for k in np.unique(level):
        lit = mix(top, bottom, min(1.0, self_shadow * k / (SHADE_LEVELS - 1) + dim))
        grad = dwg.radialGradient(center=(0.5, 0.5), r=0.5, focal=(fx, fy), id=f"lobe{i}-{k}")
        for off, colour, alpha in ((0.0, lit, 1.0), (0.6, lit, 0.9), (0.85, mix(lit, bottom, 0.25), 0.45),
                                   (1.0, mix(lit, bottom, 0.35), 0.0)):     # white dome, greyer flank, no edge
            grad.add_stop_color(off, colour, alpha)
        dwg.defs.add(grad)
    page_c = page.xy(centres)
    for j in np.argsort(centres @ sun + radii, kind="stable"):
        cx, cy = page_c[j]
        g.add(dwg.circle(center=(fmt_number(cx), fmt_number(cy)), r=fmt_number(1.15 * radii[j]),
                         fill=f"url(#lobe{i}-{level[j]})"))
