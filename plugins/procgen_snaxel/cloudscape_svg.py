"""The cloudscape drawn as an illustrator would: lit lobes that shade one another, silver linings,
grey flat bases, aerial perspective, and cloud shadows on the ground.

The thesis grows one outline (section 1.2 names layering outlines into scenes as a use it did not
build). Each snaxel curve is one rounded bulge (section 3.4), so a cloud is drawn as its lobes:
discs lit from a sun direction. What makes a photograph of fair-weather cumulus read as volume
rather than cut-out, and how it is drawn here, all in plain SVG (gradients, clip paths and one
Gaussian-blur filter per cloud, which Inkscape and Chromium both render):

* self-shadowing: a lobe nearer the sun (in front of or above another, seen along the sun
  direction) casts a soft shadow on the lobes behind and below it (a blurred disc offset away
  from the sun), and a lobe whose sunward rim lies inside nearer lobes is itself darker
  (:func:`occlusion`);
* thin edges: the cloud is masked by its own blurred silhouette, so thin fringes and the rim are
  translucent, and the rim facing the sun is brighter than the lit domes (a silver lining);
* flat grey bases, and clouds smaller, flatter and paler toward the horizon (aerial perspective);
* with ``ground``, the land below the horizon carries each cloud's soft shadow, cast away from the
  sun and foreshortened with distance.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import InputError
from procgen.exchange.svg import finish, fmt_number

from .svgdoc import Page, curve_pieces, domain_box, mix, need

RIM_SAMPLES = 9
"""Points on the sunward half of a lobe's rim tested for cover by nearer lobes."""

SHADE_LEVELS = 4
"""Self-shadow darkness is drawn in this many steps per cloud (one gradient each)."""


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


def _blur(dwg: Any, ident: str, std: float) -> str:
    f = dwg.defs.add(dwg.filter(id=ident, x="-50%", y="-50%", width="200%", height="200%"))
    f.feGaussianBlur(in_="SourceGraphic", stdDeviation=fmt_number(std))
    return f"url(#{ident})"


def cloudscape_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: float = 1000,
                   units: str = "px", sky: bool = True, sky_top: str = "#3f78c0", sky_horizon: str = "#c9def2",
                   lit: str = "#ffffff", shade: str = "#9aa6b8", sun_x: float = -0.55, sun_y: float = 0.85,
                   lobe_min: float = 0.04, perspective: float = 0.45, flatten: float = 0.35,
                   soft: float = 0.0, horizon: float | None = 0.08, base_level: float = 0.42,
                   self_shadow: float = 0.5, silver: float = 0.9, thin_edge: float = 0.012,
                   ground: str | None = None, ground_shadow: float = 0.35, title: str = "") -> bytes:
    """Clouds as an illustrator draws them, back to front, one Inkscape layer per cloud.

    Each cloud, clipped to its silhouette and masked by its blurred silhouette (``thin_edge``: the
    blur as a fraction of the cloud's height), so its rim fades into the sky and fringes thinner
    than about twice that are translucent: the body lit above and greyer below, one disc per lobe (each snaxel curve is a
    bulge, thesis section 3.4), drawn from the far side of the sun to the near side, each first
    casting a soft shadow away from the sun onto the lobes already drawn and filled with a radial
    gradient whose bright focus leans towards the sun (``sun_x``, ``sun_y``, y up), darkened by
    up to ``self_shadow`` of the way to the shade colour by its :func:`occlusion`; then a grey band
    along the base (the shadowed underside of a cumulus) and a bright rim on the sunward edge
    (``silver``: its opacity). Far clouds (low cloud__depth) are drawn smaller and flatter about
    their base (``perspective``, ``flatten``) and mixed towards the horizon colour. With
    ``horizon`` (a fraction of the page height from the bottom; None: bases stay where they grew)
    every base is moved onto one condensation plane seen in perspective: a cloud drawn at scale s
    has its base at horizon + s (base_level - horizon). ``ground`` (a colour; needs ``horizon``)
    fills the page below the horizon on a "ground" layer carrying each cloud's blurred shadow
    (opacity ``ground_shadow``), cast away from the sun and nearer the viewer for nearer clouds.
    ``soft`` > 0 blurs the edges by that fraction of a cloud's height; ``sky`` = false leaves the
    background empty.
    """
    if horizon is not None and not 0.0 <= horizon < base_level <= 1.0:
        raise InputError(f"cloudscape_svg: need 0 <= horizon < base_level <= 1, got {horizon}, {base_level}")
    if ground is not None and horizon is None:
        raise InputError("cloudscape_svg: ground needs a horizon (a fraction of the page height)")
    for name, v in (("self_shadow", self_shadow), ("silver", silver), ("thin_edge", thin_edge),
                    ("ground_shadow", ground_shadow)):
        if not 0.0 <= v <= 1.0:
            raise InputError(f"cloudscape_svg: {name} = {v!r}: expected 0..1")
    dom = need(domain, "cloudscape_svg", "cloud__depth")
    norm = float(np.hypot(sun_x, sun_y))
    if norm == 0:
        raise InputError("cloudscape_svg: sun_x and sun_y are both 0 (no sun direction)")
    sun = np.array([sun_x, sun_y]) / norm
    page = Page(domain_box(dom), width, units)
    dwg = page.dwg
    if sky:
        grad = dwg.linearGradient(start=(0, 0), end=(0, 1), id="sky")
        grad.add_stop_color(0, sky_top)
        grad.add_stop_color(1, sky_horizon)
        dwg.defs.add(grad)
        page.layer("sky").add(dwg.rect(insert=(0, 0), size=(fmt_number(page.w), fmt_number(page.h)), fill="url(#sky)"))
    land = None
    if ground is not None:
        y_h = page.h * (1.0 - horizon)
        grad = dwg.linearGradient(start=(0, 0), end=(0, 1), id="ground")
        grad.add_stop_color(0, mix(ground, sky_horizon, 0.6))      # haze at the horizon
        grad.add_stop_color(1, ground)
        dwg.defs.add(grad)
        land = page.layer("ground")
        land.add(dwg.rect(insert=(0, fmt_number(y_h)), size=(fmt_number(page.w), fmt_number(page.h - y_h)),
                          fill="url(#ground)"))
    depth = dom["cloud__depth"]
    curve = dom["snaxel__curve"] if "snaxel__curve" in dom else np.zeros(len(dom.points), np.int64)
    n = max(int(depth.max()) + 1, 1)
    for i in np.argsort(depth, kind="stable"):
        far = 1.0 - (float(depth[i]) / (n - 1) if n > 1 else 1.0)
        a, b = dom.offsets[i], dom.offsets[i + 1]
        pts, cv = dom.points[a:b], curve[a:b]
        (qx, qy) = page.xy(np.array([[pts[:, 0].mean(), pts[:, 1].min()]]))[0]
        height = float(np.ptp(pts[:, 1]))
        sc = 1.0 - perspective * far
        top = mix(lit, sky_horizon, 0.45 * far)
        bottom = mix(shade, sky_horizon, 0.55 * far)
        body = mix(top, bottom, 0.3)
        ty = qy if horizon is None else page.h * (1.0 - horizon - sc * (base_level - horizon))
        tf = (f"translate({fmt_number(qx)},{fmt_number(ty)}) scale({fmt_number(sc)},{fmt_number(sc * (1 - flatten * far))}) "
              f"translate({fmt_number(-qx)},{fmt_number(-qy)})")
        if land is not None:
            _ground_shadow(dwg, land, page, i, pts, qx, sc, perspective, sun, horizon, ground, ground_shadow)
        attrs: dict[str, Any] = {"transform": tf}
        if soft > 0:
            attrs["filter"] = _blur(dwg, f"soft{i}", soft * height)
        layer = page.layer(f"cloud {int(i) + 1} (depth {int(depth[i])})", **attrs)
        d = page.d(pts)
        clip = dwg.defs.add(dwg.clipPath(id=f"cloud{i}"))
        clip.add(dwg.path(d=d))
        g = dwg.g(clip_path=f"url(#cloud{i})")
        if thin_edge > 0:     # the silhouette's alpha blurred: the rim fades, thin fringes are see-through
            mask = dwg.defs.add(dwg.mask(id=f"edge{i}"))
            mask.add(dwg.path(d=d, fill="#ffffff", filter=_blur(dwg, f"edge-blur{i}", thin_edge * height)))
            g["mask"] = f"url(#edge{i})"
        fill = dwg.linearGradient(start=(0, 0), end=(0, 1), id=f"body{i}")    # lit above, greyer below
        fill.add_stop_color(0.0, top)
        fill.add_stop_color(1.0, body)
        dwg.defs.add(fill)
        g.add(dwg.path(d=d, fill=f"url(#body{i})"))
        found = lobes(pts, cv, lobe_min * height)
        if found:
            _draw_lobes(dwg, g, page, i, found, sun, top, bottom, self_shadow)
        base = dwg.linearGradient(start=(0, 0), end=(0, 1), id=f"base{i}")
        base.add_stop_color(0.55, bottom, 0.0)
        base.add_stop_color(1.0, bottom, 0.85)
        dwg.defs.add(base)
        x0, y0 = page.xy(np.array([[pts[:, 0].min(), pts[:, 1].max()]]))[0]
        g.add(dwg.rect(insert=(fmt_number(x0), fmt_number(y0)), size=(fmt_number(np.ptp(pts[:, 0])), fmt_number(height)),
                       fill=f"url(#base{i})"))
        if silver > 0:     # the sunward edge, brighter than the domes: a stroke whose inner half the clip keeps
            rim = dwg.linearGradient(start=(fmt_number(0.5 - 0.5 * sun[0]), fmt_number(0.5 + 0.5 * sun[1])),
                                     end=(fmt_number(0.5 + 0.5 * sun[0]), fmt_number(0.5 - 0.5 * sun[1])), id=f"rim{i}")
            rim.add_stop_color(0.0, "#ffffff", 0.0)
            rim.add_stop_color(0.55, "#ffffff", 0.0)
            rim.add_stop_color(1.0, "#ffffff", silver)
            dwg.defs.add(rim)
            g.add(dwg.path(d=d, fill="none", stroke=f"url(#rim{i})", stroke_width=fmt_number(0.05 * height),
                           stroke_linejoin="round"))
        layer.add(g)
    return finish(dwg, provenance, title or "snaxel cloudscape")


def _draw_lobes(dwg: Any, g: Any, page: Page, i: int, found: list[tuple[np.ndarray, float]], sun: np.ndarray,
                top: str, bottom: str, self_shadow: float) -> None:
    """Lobes from the far side of the sun to the near side; each casts a blurred shadow away from
    the sun on those drawn before it, and is darkened by its occlusion (in SHADE_LEVELS steps)."""
    centres = np.array([c for c, _ in found])
    radii = np.array([r for _, r in found])
    occ = occlusion(centres, radii, sun)
    level = np.rint(occ * (SHADE_LEVELS - 1)).astype(int)
    for k in np.unique(level):
        lit = mix(top, bottom, self_shadow * k / (SHADE_LEVELS - 1))
        grad = dwg.radialGradient(center=(0.5, 0.5), r=0.5, focal=(0.5 + 0.35 * sun[0], 0.5 - 0.35 * sun[1]),
                                  id=f"lobe{i}-{k}")
        for off, colour in ((0.0, lit), (0.62, lit), (1.0, mix(lit, bottom, 0.45))):   # white domes, grey rim
            grad.add_stop_color(off, colour)
        dwg.defs.add(grad)
    cast = _blur(dwg, f"cast{i}", 0.25 * float(np.median(radii))) if self_shadow > 0 else None
    page_c = page.xy(centres)
    away = np.array([-sun[0], sun[1]])        # away from the sun, page y-down
    for j in np.argsort(centres @ sun + radii, kind="stable"):
        cx, cy = page_c[j]
        r = 1.15 * radii[j]
        if cast is not None:
            sx, sy = page_c[j] + 0.35 * r * away
            g.add(dwg.circle(center=(fmt_number(sx), fmt_number(sy)), r=fmt_number(r), fill=bottom,
                             fill_opacity=fmt_number(0.6 * self_shadow), filter=cast))
        g.add(dwg.circle(center=(fmt_number(cx), fmt_number(cy)), r=fmt_number(r), fill=f"url(#lobe{i}-{level[j]})"))


def _ground_shadow(dwg: Any, land: Any, page: Page, i: int, pts: np.ndarray, qx: float, sc: float,
                   perspective: float, sun: np.ndarray, horizon: float, ground: str, opacity: float) -> None:
    """The cloud's shadow on the ground: an ellipse as wide as the drawn cloud, shifted away from
    the sun, lower on the page (nearer the viewer) and less foreshortened for nearer clouds."""
    y_h = page.h * (1.0 - horizon)
    near = 1.0 if perspective == 0 else (sc - (1.0 - perspective)) / perspective      # 0 far .. 1 near
    rx = 0.5 * float(np.ptp(pts[:, 0])) * sc
    ry = rx * (0.06 + 0.12 * near)
    cx = qx - sun[0] * 0.6 * rx
    cy = y_h + (page.h - y_h) * (0.15 + 0.7 * near)
    land.add(dwg.ellipse(center=(fmt_number(cx), fmt_number(cy)), r=(fmt_number(rx), fmt_number(ry)),
                         fill=mix(ground, "#000000", 0.55), fill_opacity=fmt_number(opacity),
                         filter=_blur(dwg, f"ground-shadow{i}", 0.35 * ry), id=f"shadow-of-cloud-{int(i) + 1}"))
