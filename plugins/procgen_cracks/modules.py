"""Crack modules (CM): the heads of cracks walking over the surface cells (thesis 5.2.4.b-c).

Every live CM advances together, one sub-cell step per call of :meth:`Modules.step`, as numpy
arrays (no per-CM Python loop): it reads the interpolated stress spectrum ahead of it, turns
towards the direction across the strongest axis by (1 - Iip) of the angle, gains or loses
kinetic potential K, cracks every cell it enters, releases the stress across its step on both
sides, forks at +-pi/3 when its two strongest axes tie, crosses facet edges by unfolding into
the neighbour's frame, and ends on entering a cracked cell or when K <= 0.  Paths are stored
as merged segments (a vertex where the chord turns by more than CSa), split at facet edges,
with widths growing with the stress released (Figure 5.12).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen.ca.subcell import AXIS_ANGLES, across_share, wrap_angle
from procgen_surface.geometry import edge_half_planes
from procgen_surface.neighbours import edge_frames, edge_topology

from .stress import FaceSampler, frame_weights

_STATE = ("layer", "face", "xy", "ang", "K", "R", "crack", "ctype", "line", "cell", "prev",
          "anchor", "seg", "turn", "steps")


class FacetEdges:
    """Per (facet, edge k): the neighbour facet, and the rigid map of 2-D frames across it."""

    def __init__(self, sc: Any) -> None:
        layout = sc.layout
        faces = np.asarray(sc.faces)
        m = len(faces)
        topo = edge_topology(faces, sc.valid)
        f = np.repeat(np.arange(m), 3)
        k = np.tile(np.arange(3), m)
        e = topo.face_edges[f, k]
        a, b = topo.edge_faces[e, 0], topo.edge_faces[e, 1]
        g = np.where(a == f, b, np.where(b == f, a, -1))
        ok = (g >= 0) & sc.valid[np.maximum(g, 0)] & sc.valid[f]
        fr = edge_frames(layout, faces, f, np.where(ok, g, f), k)
        self.nb = np.where(ok, g, -1).reshape(m, 3)
        # vector map f -> g: v -> (v . t_f) t_g + (v . n_out) n_in   (M @ v)
        mat = fr.t_g[:, :, None] * fr.t_f[:, None, :] + fr.n_in[:, :, None] * fr.n_out[:, None, :]
        self.mat = mat.reshape(m, 3, 2, 2)
        self.u_f = fr.u_f.reshape(m, 3, 2)
        self.u_g = fr.u_g.reshape(m, 3, 2)
        self.nrm, self.off = edge_half_planes(layout.frames.corners2d)
        self.tol = 1e-9 * float(sc.size)                 # on an edge counts as on the facet

    def outside(self, face: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """(m, 3) signed distances inside each edge's half-plane (negative: beyond edge k)."""
        return np.einsum("mkd,md->mk", self.nrm[face], xy) - self.off[face]

    def walk(self, face: np.ndarray, xy: np.ndarray, disp: np.ndarray, points: tuple = (),
             dirs: tuple = (), max_hops: int = 256) -> tuple:
        """Move points (face, xy) by a 2-D displacement in their facet's frame, straight over
        the surface: a step leaving the facet is unfolded across the edge it leaves by into
        the neighbour's frame, as many edges as it takes (a geodesic on the unfolded strip).

        Why: the 2-D frames are per facet, so a point some cells away across one or more
        facet edges (a release band, a look ahead) only has a meaning once unfolded edge by
        edge; without it the band stops at the first edge and small facets (a few cells each)
        see no neighbourhood at all.  ``points``/``dirs``: further 2-D points and vectors in
        the start frame, carried along (mapped by every unfolding) into the end frame.
        Returns (face, xy, points, dirs); face -1 where the walk left the surface (a border
        edge) or took more than ``max_hops`` edges.
        """
        face, p = face.copy(), np.array(xy, float, copy=True)
        rest = np.array(disp, float, copy=True)
        pts = [np.array(a, float, copy=True) for a in points]
        vec = [np.array(a, float, copy=True) for a in dirs]
        live = np.arange(len(face))
        for _ in range(max_hops):
            if len(live) == 0:
                break
            f, pp = face[live], p[live]
            q = pp + rest[live]
            dq = self.outside(f, q)
            out = (dq < -self.tol).any(axis=1)
            p[live[~out]] = q[~out]
            rest[live[~out]] = 0.0
            live, f, pp, q, dq = live[out], f[out], pp[out], q[out], dq[out]
            if len(live) == 0:
                break
            dp = np.maximum(self.outside(f, pp), 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.where(dq < -self.tol, np.clip(dp / (dp - dq), 0.0, 1.0), np.inf)
            k = np.argmin(t, axis=1)
            tk = t[np.arange(len(live)), k]
            e = pp + tk[:, None] * (q - pp)
            g = self.nb[f, k]
            gone = g < 0
            face[live[gone]] = -1
            live, f, k, g, e, q = live[~gone], f[~gone], k[~gone], g[~gone], e[~gone], q[~gone]
            mat, uf, ug = self.mat[f, k], self.u_f[f, k], self.u_g[f, k]
            face[live] = g
            p[live] = ug + np.einsum("mij,mj->mi", mat, e - uf)
            rest[live] = np.einsum("mij,mj->mi", mat, q - e)
            for a in pts:
                a[live] = ug + np.einsum("mij,mj->mi", mat, a[live] - uf)
            for a in vec:
                a[live] = np.einsum("mij,mj->mi", mat, a[live])
        face[live] = -1
        return face, p, tuple(pts), tuple(vec)


def _centroids(layout: Any) -> np.ndarray:
    """(n, 2) centroid of each cell's part of its facet, in the facet's frame.

    A cell cut by a facet edge (PART-IN) keeps its grid square's centre, which may lie off the
    facet, up to half a cell from the cell's material: the release band tests centroids, so
    that such cells are released where they are.  Whole cells: the centre itself.
    """
    out = np.array(layout.center2d, dtype=float, copy=True)
    cut = np.nonzero(layout.area < (1.0 - 1e-9) * layout.size ** 2)[0]
    if len(cut):
        poly, cnt = layout.cell_polygons(cut)
        slot = np.arange(poly.shape[1])
        nxt = np.where(slot[None, :] + 1 < cnt[:, None], slot[None, :] + 1, 0)
        pn = np.take_along_axis(poly, nxt[..., None], axis=1)
        cr = np.where(slot[None, :] < cnt[:, None],
                      poly[..., 0] * pn[..., 1] - pn[..., 0] * poly[..., 1], 0.0)
        a = cr.sum(axis=1)
        ok = np.abs(a) > 1e-18 * layout.size ** 2
        c = np.einsum("ks,ksd->kd", cr, poly + pn) / np.where(ok, 3.0 * a, 1.0)[:, None]
        out[cut[ok]] = c[ok]
    return out


class Modules:
    """All crack modules of one propagation run, their paths and the cells they crack."""

    def __init__(self, sc: Any, spec: np.ndarray, active: np.ndarray, rule: Any,
                 slots: np.ndarray) -> None:
        self.sc, self.rule = sc, rule
        self.spec = spec                                      # (n, L, 4), released in place
        self.flat = spec.reshape(-1, 4)
        self.active = active                                  # (n, L) cells of crackable layers
        self.n, self.n_layers = active.shape
        self.size = float(sc.size)
        self.sampler = FaceSampler(sc.layout)
        self.edges = FacetEdges(sc)
        self.slots = slots
        self.center2d = np.asarray(sc.center2d)
        self.centroid2d = _centroids(sc.layout)
        self.cut = np.asarray(sc.layout.area) < (1.0 - 1e-9) * self.size ** 2
        self.cell_face = np.asarray(sc.face)
        self.cracked = np.zeros((self.n, self.n_layers), bool)
        self.width = np.zeros((self.n, self.n_layers))
        self.crack_of = np.full((self.n, self.n_layers), -1, np.int64)
        self.cm = {k: np.zeros((0,) + ((2,) if k in ("xy", "anchor") else ()),
                               float if k in ("xy", "ang", "K", "R", "anchor", "seg", "turn") else np.int64)
                   for k in _STATE}
        self.n_cracks = 0
        self.n_lines = 0
        self.released = 0.0                                   # stress released so far (active cells)
        self._drive = np.zeros(0)
        self._pts: list[tuple[np.ndarray, ...]] = []
        self._line_meta: list[tuple[np.ndarray, ...]] = []
        self._seq = 0
        self.stats = {"steps": 0, "modules": 0, "forks": 0, "collisions": 0, "stopped_by_potential": 0,
                      "lost_at_border": 0, "max_step": 0.0}

    # -- bookkeeping ------------------------------------------------------------------------
    @property
    def n_live(self) -> int:
        return len(self.cm["face"])

    def _width(self, R: np.ndarray) -> np.ndarray:
        r0 = self.rule.width_scale * self.rule.resistance_value
        return self.rule.max_width * R / (R + r0)

    def _emit(self, sel: np.ndarray, xy: np.ndarray, face: np.ndarray) -> None:
        """Append a vertex (3-D point, width, facet) to the current line of CMs ``sel``."""
        if len(sel) == 0:
            return
        p3 = self.sc.layout.frames.to_3d(face, xy)
        seq = self._seq + np.arange(len(sel))
        self._seq += len(sel)
        self._pts.append((self.cm["line"][sel].copy(), seq, p3, self._width(self.cm["R"][sel]), face.copy()))

    def _new_lines(self, sel: np.ndarray) -> None:
        ids = self.n_lines + np.arange(len(sel))
        self.n_lines += len(sel)
        self.cm["line"][sel] = ids
        self._line_meta.append((ids, self.cm["layer"][sel].copy(), self.cm["ctype"][sel].copy(),
                                self.cm["crack"][sel].copy()))

    def _append(self, **vals: np.ndarray) -> np.ndarray:
        k = len(vals["face"])
        start = self.n_live
        for key in _STATE:
            v = vals.get(key)
            if v is None:
                shape = (k, 2) if key in ("xy", "anchor") else (k,)
                v = np.full(shape, np.nan) if key == "seg" else np.zeros(shape, self.cm[key].dtype)
            self.cm[key] = np.concatenate([self.cm[key], np.asarray(v, self.cm[key].dtype)])
        sel = np.arange(start, start + k)
        self._new_lines(sel)
        self._emit(sel, self.cm["xy"][sel], self.cm["face"][sel])
        self.stats["modules"] += k
        return sel

    def _keep(self, keep: np.ndarray) -> None:
        for key in _STATE:
            self.cm[key] = self.cm[key][keep]

    # -- birth --------------------------------------------------------------------------------
    def birth(self, cells: np.ndarray, layers: np.ndarray, types: np.ndarray,
              who: np.ndarray, heading: np.ndarray) -> None:
        """Start cracks at cells (their centres, moved onto the facet for PART-IN cells);
        ``who``/``heading``: one row per CM."""
        crack_ids = self.n_cracks + np.arange(len(cells))
        self.n_cracks += len(cells)
        face = self.cell_face[cells]
        start = self._inside(face, self.center2d[cells])
        self.cracked[cells, layers] = True
        self.crack_of[cells, layers] = crack_ids
        imax = self.spec[cells, layers].max(axis=1)
        lay = layers[who]
        K0 = self.rule.potential * imax[who]
        # the CM starts in the birth cell (a PART-IN cell's start point may lie in the next
        # one: its first step enters that cell as any step does, bridged if need be)
        self._append(layer=lay, face=face[who], xy=start[who], ang=heading, K=K0,
                     R=imax[who], crack=crack_ids[who], ctype=types[who], cell=cells[who],
                     prev=cells[who], anchor=start[who])
        np.maximum.at(self.width, (cells[who], lay), self._width(self.cm["R"][-len(who):]))

    def _inside(self, face: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Points moved towards their facet's centroid just far enough to lie on the facet
        (a PART-IN cell's centre is off its triangle)."""
        d = self.edges.outside(face, xy)
        cen = self.sc.layout.frames.corners2d[face].mean(axis=1)
        dc = self.edges.outside(face, cen)
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = np.where(d < 0, -d / (dc - d), 0.0).max(axis=1)
        lam = np.where(lam > 0, np.minimum(lam + 1e-3, 1.0), 0.0)
        return xy + lam[:, None] * (cen - xy)

    # -- one step of every CM -----------------------------------------------------------------
    def step(self) -> None:
        r, cm, s = self.rule, self.cm, self.size
        m = self.n_live
        if m == 0:
            return
        face, xy, ang, lay = cm["face"].copy(), cm["xy"].copy(), cm["ang"].copy(), cm["layer"]
        hvec = np.column_stack([np.cos(ang), np.sin(ang)])
        # 1. the spectrum ahead of the head (its own release band covers the head's cells);
        # where the point ahead is off the facet, the spectrum at the head
        spec, found = self._sample_ahead(lay, face, xy, r.lookahead * s * hvec)
        if not found.all():
            here, _ = self._sample(lay, face, xy)
            spec = np.where(found[:, None], spec, here)
        srt = np.sort(spec, axis=1)
        s1, s2 = srt[:, -1], srt[:, -2]
        k1 = np.argmax(spec, axis=1)
        mr = r.resistance_value
        above = s1 > mr
        # what turns a CM: stress above mR only, or (steer = "any") the strongest axis wherever
        # the spectrum has one, so that a head coasting on K through a crack's release band turns
        # across the stress left along that crack and meets it at about a right angle
        steer = above if r.steer == "unstable" else s1 > srt[:, 0]
        infl = AXIS_ANGLES[k1] + np.pi / 2                    # across the strongest axis
        d = wrap_angle(infl - ang)
        d = np.where(d > np.pi / 2, d - np.pi, np.where(d <= -np.pi / 2, d + np.pi, d))
        # influence nearly across the heading: either sense is as near, so turn to the side
        # with less stress ahead (towards a crack that released it: plate 5.5's "drawn into")
        amb = np.nonzero(steer & (np.abs(np.abs(d) - np.pi / 2) < np.radians(15.0)))[0]
        if len(amb):
            left = self._side_stress(amb, lay, face, xy, hvec, 1.0)
            right = self._side_stress(amb, lay, face, xy, hvec, -1.0)
            d[amb] = np.where(left < right, 1.0, np.where(right < left, -1.0, np.sign(d[amb]))) * np.abs(d[amb])
        turn = np.where(steer, (1.0 - r.inertia / 100.0) * d, 0.0)
        new_ang = ang + turn
        fork = above & (s1 - s2 < r.fork_epsilon * mr) & (s2 > mr) & (cm["steps"] >= 2)
        # K grows with the excess over mR and falls with the deficit below it, times the drag
        excess = s1 - mr
        cm["K"] = cm["K"] + r.potential * np.where(excess > 0, excess, r.drag * excess) * r.step_length
        self._drive = s1                                      # the stress each CM relieves
        # 2. move, crossing facet edges
        step_vec = r.step_length * s * np.column_stack([np.cos(new_ang), np.sin(new_ang)])
        q = xy + step_vec
        old3 = self.sc.layout.frames.to_3d(face, xy)
        # merged segments: a vertex where the chord from the last vertex turns by > CSa (before
        # the facet crossing, so that a turn in a crossing step is stored before its edge point)
        cm["xy"] = q
        self._segments(xy, new_ang - ang)
        new_face, q, new_ang, lost, crossed = self._cross(face, xy, q, new_ang)
        new3 = self.sc.layout.frames.to_3d(new_face, q)
        self.stats["max_step"] = max(self.stats["max_step"], float(np.linalg.norm(new3 - old3, axis=1).max()))
        cell_new = self.sampler.cell_of(new_face, q)
        lost |= cell_new < 0
        cell_new = np.where(lost, cm["cell"], cell_new)
        entering = (cell_new != cm["cell"]) & ~lost
        collide = entering & self.cracked[cell_new, lay] & (cell_new != cm["prev"])
        # two CMs entering one cell in the same step: the first (in CM order) cracks it and
        # the others collide with it, as if the CMs had moved one after the other
        cand = np.nonzero(entering & ~collide)[0]
        _, first = np.unique(cell_new[cand] * self.n_layers + lay[cand], return_index=True)
        late = np.ones(len(cand), bool)
        late[first] = False
        collide[cand[late]] = True
        new = entering & ~collide
        stuck = self._bridge(np.nonzero(new)[0], cell_new, lay)
        collide[stuck] = True
        new[stuck] = False
        self.cracked[cell_new[new], lay[new]] = True
        self.crack_of[cell_new[new], lay[new]] = cm["crack"][new]
        cm["prev"] = np.where(entering, cm["cell"], cm["prev"])
        cm["cell"] = cell_new
        cm["face"], cm["xy"], cm["ang"] = new_face, q, new_ang
        cm["steps"] = cm["steps"] + 1
        # 3. release the stress across the step, widen the crack
        go = ~lost
        cm["R"] = cm["R"] + self._release(np.nonzero(go)[0])
        wide = go & self.cracked[cell_new, lay]                 # not a CM stuck at a facet edge
        np.maximum.at(self.width, (cell_new[wide], lay[wide]), self._width(cm["R"][wide]))
        self.stats["steps"] += 1
        # 4. endings and forks
        ended = collide | (cm["K"] <= 0) | lost | (cm["steps"] >= r.max_module_steps)
        self.stats["collisions"] += int(collide.sum())
        self.stats["stopped_by_potential"] += int(((cm["K"] <= 0) & ~collide & ~lost).sum())
        self.stats["lost_at_border"] += int(lost.sum())
        fork &= ~ended
        fin = np.nonzero(ended | fork)[0]
        self._emit(fin, cm["xy"][fin], cm["face"][fin])
        kids = np.nonzero(fork)[0]
        keep = ~(ended | fork)
        if len(kids):
            self.stats["forks"] += len(kids)
            par = np.repeat(kids, 2)
            sign = np.tile([1.0, -1.0], len(kids))
            vals = {key: cm[key][par] for key in _STATE if key not in ("line", "seg", "turn", "steps")}
            vals["ang"] = cm["ang"][par] + sign * np.pi / 3
            vals["anchor"] = cm["xy"][par]
            self._keep(keep)
            self._append(**vals)
        else:
            self._keep(keep)

    # -- helpers ------------------------------------------------------------------------------
    def _sample(self, lay: np.ndarray, face: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Interpolated spectrum of each CM's layer at points (missing cells drop out), and
        whether any cell was found."""
        cells, w = self.sampler.stencil(face, xy)
        ok = cells >= 0
        w = np.where(ok, w, 0.0)
        tot = w.sum(axis=1, keepdims=True)
        vals = self.spec[np.maximum(cells, 0), lay[:, None]]          # (m, 4 cells, 4 axes)
        return np.einsum("mq,mqk->mk", w / np.where(tot > 0, tot, 1.0), vals), tot[:, 0] > 0

    def _sample_ahead(self, lay: np.ndarray, face: np.ndarray, xy: np.ndarray,
                      disp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The spectrum at ``disp`` from each head, walked over the facet edges between and
        turned from the frame of the facet it lands on into the head's (the axes of a
        spectrum are its facet's; the head compares them with its heading)."""
        m = len(face)
        e1, e2 = np.tile([1.0, 0.0], (m, 1)), np.tile([0.0, 1.0], (m, 1))
        wf, wxy, _, (m1, m2) = self.edges.walk(face, xy, disp, dirs=(e1, e2))
        ok = wf >= 0
        spec, found = self._sample(lay, np.where(ok, wf, face), np.where(ok[:, None], wxy, xy))
        moved = np.nonzero(ok & (wf != face))[0]
        if len(moved):
            w = frame_weights(np.stack([m1[moved], m2[moved]], axis=2))
            spec[moved] = np.einsum("mkj,mj->mk", w, spec[moved])
        return spec, found & ok

    def _bridge(self, idx: np.ndarray, cell_new: np.ndarray, lay: np.ndarray) -> np.ndarray:
        """Keep every crack one 8-connected set of cells in the cross-edge graph.

        Inside a facet a step (< 1 cell) always reaches a Moore neighbour, but across a facet
        edge the two grids do not line up and the new cell can be two or three hops from the
        old one.  Crack the one or two cells between them (free or this crack's own, the
        shortest path over cell centres).  Returns the CMs of ``idx`` with no such path (every
        way through is cracked by another crack): they stop there, as on meeting that crack.
        """
        cm, L = self.cm, self.n_layers
        old, new = cm["cell"][idx], cell_new[idx]
        far = ~(self.slots[old] == new[:, None]).any(axis=1)
        idx, old, new = idx[far], old[far], new[far]
        m = len(idx)
        if m == 0:
            return idx
        li, own = lay[idx], cm["crack"][idx]
        claimed = cell_new[cm["cell"] != cell_new] * L + lay[cm["cell"] != cell_new]
        c3 = np.asarray(self.sc.center3d)

        def free(c: np.ndarray) -> np.ndarray:                 # c (m, k) -> usable as a bridge
            cc = np.maximum(c, 0)
            lk = np.broadcast_to(li[:, None], c.shape)
            mine = self.crack_of[cc, lk] == own[:, None]
            untaken = ~self.cracked[cc, lk] & ~np.isin(cc * L + lk, claimed)
            return (c >= 0) & self.active[cc, lk] & (mine | untaken)

        def hop(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            return np.linalg.norm(c3[np.maximum(a, 0)] - c3[np.maximum(b, 0)], axis=-1)

        nb_new = self.slots[new]                                          # (m, 8)
        a = self.slots[old]                                               # (m, 8)
        touches = lambda c: (c[..., None] == nb_new.reshape((m,) + (1,) * (c.ndim - 1) + (8,))).any(-1)
        one = touches(a) & free(a)
        cost1 = np.where(one, hop(old[:, None], a) + hop(a, new[:, None]), np.inf)
        b = self.slots[np.maximum(a, 0)]                                  # (m, 8, 8)
        two = free(a)[:, :, None] & free(b.reshape(m, 64)).reshape(m, 8, 8) & touches(b) & \
            (b != old[:, None, None])
        cost2 = np.where(two, hop(old[:, None, None], a[:, :, None]) + hop(a[:, :, None], b)
                         + hop(b, new[:, None, None]), np.inf).reshape(m, 64)
        r = np.arange(m)
        k1, k2 = np.argmin(cost1, axis=1), np.argmin(cost2, axis=1)
        use1 = np.isfinite(cost1[r, k1])
        use2 = ~use1 & np.isfinite(cost2[r, k2])
        first = np.where(use1, a[r, k1], np.where(use2, a[r, k2 // 8], -1))
        second = np.where(use2, b[r, k2 // 8, k2 % 8], -1)
        ok = use1 | use2
        # two CMs of different cracks bridging through one cell: the first (CM order) has it
        who = np.concatenate([r, r])
        cells = np.concatenate([first, second])
        has = cells >= 0
        key = cells[has] * L + li[who[has]]
        uk, inv = np.unique(key, return_inverse=True)
        owner = np.full(len(uk), m, np.int64)
        np.minimum.at(owner, inv, who[has])
        ok[who[has][own[owner[inv]] != own[who[has]]]] = False
        sel = ok[who] & has
        w, c = who[sel], cells[sel]
        self.cracked[c, li[w]] = True
        self.crack_of[c, li[w]] = own[w]
        np.maximum.at(self.width, (c, li[w]), self._width(cm["R"][idx[w]]))
        return idx[~ok]

    def _side_stress(self, idx: np.ndarray, lay: np.ndarray, face: np.ndarray, xy: np.ndarray,
                     hvec: np.ndarray, side: float) -> np.ndarray:
        """Strongest axis of the spectrum ahead and to one side (+1 left) of CMs ``idx``."""
        r = self.rule
        nrm = np.column_stack([-hvec[idx, 1], hvec[idx, 0]]) * side
        val, found = self._sample_ahead(lay[idx], face[idx], xy[idx], r.lookahead * self.size * (hvec[idx] + nrm))
        return np.where(found, val.max(axis=1), np.inf)

    def _cross(self, face: np.ndarray, xy: np.ndarray, q: np.ndarray, ang: np.ndarray):
        """Unfold steps that leave their facet into the neighbour's frame (up to 3 edges)."""
        cm, ed = self.cm, self.edges
        face, q, ang = face.copy(), q.copy(), ang.copy()
        p = xy.copy()
        lost = np.zeros(len(face), bool)
        crossed = np.zeros(len(face), bool)
        for _ in range(3):                                     # a step crosses at most a corner
            dq = ed.outside(face, q)
            out = np.nonzero((dq < -1e-12 * self.size).any(axis=1) & ~lost)[0]
            if len(out) == 0:
                break
            f, pp, qq = face[out], p[out], q[out]
            dp = np.maximum(ed.outside(f, pp), 0.0)
            d2 = dq[out]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.where(d2 < 0, np.clip(dp / (dp - d2), 0.0, 1.0), np.inf)
            k = np.argmin(t, axis=1)
            tk = t[np.arange(len(out)), k]
            e = pp + tk[:, None] * (qq - pp)
            g = ed.nb[f, k]
            # close the old facet's line at the edge point, then open a new line over the edge
            cm["xy"][out] = e
            self._emit(out, e, f)
            gone = g < 0
            lost[out[gone]] = True
            q[out[gone]] = e[gone]
            ok = out[~gone]
            if len(ok) == 0:
                continue
            fo, ko = f[~gone], k[~gone]
            mat = ed.mat[fo, ko]
            eg = ed.u_g[fo, ko] + np.einsum("mij,mj->mi", mat, e[~gone] - ed.u_f[fo, ko])
            rest = np.einsum("mij,mj->mi", mat, (qq - e)[~gone])
            hv = np.einsum("mij,mj->mi", mat, np.column_stack([np.cos(ang[ok]), np.sin(ang[ok])]))
            face[ok] = g[~gone]
            p[ok] = eg
            q[ok] = eg + rest
            ang[ok] = np.arctan2(hv[:, 1], hv[:, 0])
            crossed[ok] = True
            cm["face"][ok] = face[ok]
            cm["xy"][ok] = eg
            self._new_lines(ok)
            self._emit(ok, eg, face[ok])
            cm["anchor"][ok] = eg
            cm["seg"][ok] = ang[ok]                  # the new line runs along the heading
            cm["turn"][ok] = 0.0
        still = np.nonzero((ed.outside(face, q) < -1e-9 * self.size).any(axis=1) & ~lost)[0]
        lost[still] = True
        q[still] = p[still]
        return face, q, ang, lost, crossed

    def _segments(self, old_xy: np.ndarray, dturn: np.ndarray) -> None:
        """Store a vertex at the previous position where the path has turned by more than CSa."""
        cm, r = self.cm, self.rule
        cm["turn"] = cm["turn"] + np.abs(dturn)
        chord = cm["xy"] - cm["anchor"]
        cang = np.arctan2(chord[:, 1], chord[:, 0])
        fresh = np.isnan(cm["seg"]) & (np.hypot(chord[:, 0], chord[:, 1]) > 0)
        cm["seg"] = np.where(fresh, cang, cm["seg"])
        csa = np.radians(r.segment_angle)
        with np.errstate(invalid="ignore"):
            bend = (np.abs(wrap_angle(cang - cm["seg"])) > csa) | (cm["turn"] > csa + np.radians(r.segment_tolerance))
        vert = np.nonzero(bend & ~fresh)[0]
        if len(vert) == 0:
            return
        self._emit(vert, old_xy[vert], cm["face"][vert])
        cm["anchor"][vert] = old_xy[vert]
        d = cm["xy"][vert] - old_xy[vert]
        cm["seg"][vert] = np.arctan2(d[:, 1], d[:, 0])
        cm["turn"][vert] = 0.0

    def _release(self, sel: np.ndarray) -> np.ndarray:
        """Release stress across the last step of CMs ``sel`` (thesis 5.2.4.c, Figure 5.13).

        Cells whose centre projects onto the step and lies within d cells of it lose, on each
        axis, ``release * S * (1 - x/d) * |sin(axis - path)|`` (clipped at what the cell holds):
        the stress across the path, the most on the path, falling linearly to 0 at distance d;
        stress along the path stays.  S is the stress driving the CM (its strongest axis ahead;
        ``release_of = "drive"``), or the cell's own value on that axis (``"cell"``; then the
        share ``release * (1 - x/d)`` is capped at 1, so that a cell far above mR near the path
        loses its across stress too, instead of staying unstable and seeding a stub).  The
        thesis makes the "release intensity" depend on the material and the crack thickness
        and fall linearly (5.2.4.c); with ``release`` > 1 the across-path stress is gone in a
        band along the crack, so that what remains there runs along it and an approaching
        crack turns to meet it at about 90 degrees (plate 5.5).  (A cell whose centre projects
        outside every step, at a sharp turn, gets none: the thesis's Figure 5.13 flaw.)  The band
        is walked over facet edges (:meth:`FacetEdges.walk`), the step carried into each facet's
        frame, and cells cut by a facet edge are placed at their centroids and found through
        their neighbours: on meshes of facets a few cells wide most cells are such slivers, and
        a band stopped at the first edge or missing the slivers left stress across the crack
        there, from which stubs were born running along it.  Returns the stress released by
        each CM (0 for the others).
        """
        out = np.zeros(self.n_live)
        if len(sel) == 0:
            return out
        r, cm, s = self.rule, self.cm, self.size
        face, lay = cm["face"][sel], cm["layer"][sel]
        h = np.column_stack([np.cos(cm["ang"][sel]), np.sin(cm["ang"][sel])])
        seg_len = r.step_length * s
        start = cm["xy"][sel] - seg_len * h
        dist = r.release_distance
        # every whole cell whose centre projects onto the step is crossed by the perpendicular
        # through the step's middle over a chord of at least sqrt 2 - step cells (a unit square
        # cut at step/2 from its centre, at 45 degrees): samples spaced by less find them all.
        # A cell cut by a facet edge can be a sliver the samples step over: the Moore
        # neighbours of the cells found are tested too (below)
        mid = start + 0.5 * seg_len * h
        nrm = np.column_stack([-h[:, 1], h[:, 0]])
        gap = min(0.5, np.sqrt(2.0) - r.step_length - 0.01)
        half = int(np.ceil(dist / gap))
        off = np.arange(-half, half + 1) * (gap * s)
        pts = (mid[:, None, :] + off[None, :, None] * nrm[:, None, :]).reshape(-1, 2)
        mi = np.repeat(np.arange(len(sel)), len(off))
        # each sample walked from the head over the facet edges between, carrying the step
        # (start point and direction) into the frame of the facet the sample lands on
        head = cm["xy"][sel][mi]
        pf, pxy, (p0,), (hv,) = self.edges.walk(face[mi], head, pts - head, (start[mi],), (h[mi],))
        c = np.full(len(mi), -1, np.int64)
        ok = pf >= 0
        c[ok] = self.sampler.cell_of(pf[ok], pxy[ok])
        ok = c >= 0
        ok[ok] = self.active[c[ok], lay[mi[ok]]]
        mi, c, hv, p0 = mi[ok], c[ok], hv[ok], p0[ok]
        _, first = np.unique(mi * self.n + c, return_index=True)
        mi, c, hv, p0 = mi[first], c[first], hv[first], p0[first]
        mi, c, hv, p0, cen = self._with_neighbours(mi, c, hv, p0)
        ok = self.active[c, lay[mi]]
        mi, c, hv, p0, cen = mi[ok], c[ok], hv[ok], p0[ok], cen[ok]
        key = c * self.n_layers + lay[mi]
        _, first = np.unique(mi * (self.n * self.n_layers) + key, return_index=True)
        mi, c, hv, p0, key, cen = mi[first], c[first], hv[first], p0[first], key[first], cen[first]
        rel = cen - p0                                    # in the frame the step was carried to
        t = np.einsum("md,md->m", rel, hv) / seg_len
        perp = np.abs(rel[:, 0] * hv[:, 1] - rel[:, 1] * hv[:, 0]) / s
        # each centroid on one step; a cell cut by a facet edge within half a step beyond
        # either end too: its centroid (in a frame unfolded from the step's) can fall in the gap
        # between two steps' spans, and a sliver left unreleased by a crack seeds a stub that
        # runs along it (a small over-release instead: two steps may both release a sliver)
        slack = np.where(self.cut[c], 0.5, 0.0)
        band = (t >= -1e-9 - slack) & (t < 1.0 - 1e-9 + slack) & (perp < dist)
        mi, hv, key, perp = mi[band], hv[band], key[band], perp[band]
        share = (r.release * (1.0 - perp / dist))[:, None] * across_share(np.arctan2(hv[:, 1], hv[:, 0]))
        if r.release_of == "cell":
            amount = np.minimum(share, 1.0) * self.flat[key]
        else:
            amount = share * self._drive[sel][mi][:, None]
        uk, inv = np.unique(key, return_inverse=True)
        tot = np.zeros((len(uk), 4))
        np.add.at(tot, inv, amount)
        before = self.flat[uk]
        after = np.maximum(before - tot, 0.0)
        self.flat[uk] = after
        # what each CM took: its share of the cell's drop
        drop = before - after
        self.released += float(drop.sum())                    # only active cells are released
        with np.errstate(invalid="ignore", divide="ignore"):
            part = np.where(tot[inv] > 0, amount / tot[inv], 0.0) * drop[inv]
        out[sel] = np.bincount(mi, weights=part.sum(axis=1), minlength=len(sel))
        return out

    def _with_neighbours(self, mi: np.ndarray, c: np.ndarray, hv: np.ndarray,
                         p0: np.ndarray) -> tuple[np.ndarray, ...]:
        """The cells found by the release samples and their Moore neighbours that a facet edge
        cuts, each with its centroid in the frame of the sample that found it (a neighbour on
        the next facet unfolded across their common edge): slivers the samples step over."""
        nb = self.slots[c]                                              # (m, 8)
        m = len(c)
        f = self.cell_face[c]
        cand = np.concatenate([c, nb.ravel()])
        src = np.concatenate([np.arange(m), np.repeat(np.arange(m), 8)])
        keep = cand >= 0
        keep[m:] &= self.cut[np.maximum(cand[m:], 0)]      # whole cells: the samples find them
        cand, src = cand[keep], src[keep]
        g, fs = self.cell_face[cand], f[src]
        cen = self.centroid2d[cand].copy()
        other = np.nonzero(g != fs)[0]
        if len(other):
            ed = self.edges
            # the edge k' of facet g whose neighbour is the finding cell's facet
            hit = ed.nb[g[other]] == fs[other][:, None]
            has = hit.any(axis=1)
            k = np.argmax(hit, axis=1)
            go, ko = g[other], k
            cen[other] = ed.u_g[go, ko] + np.einsum("mij,mj->mi", ed.mat[go, ko], cen[other] - ed.u_f[go, ko])
            drop = np.ones(len(cand), bool)
            drop[other[~has]] = False
            cand, src, cen = cand[drop], src[drop], cen[drop]
        return mi[src], cand, hv[src], p0[src], cen

    # -- results ------------------------------------------------------------------------------
    def polylines(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]:
        """(points (N, 3), offsets, point fields, line fields) of the merged crack paths."""
        if not self._pts:
            empty = np.zeros(0)
            return np.zeros((0, 3)), np.zeros(1, np.int64), \
                {"crack__width": empty, "crack__face": empty.astype(np.int64)}, \
                {"crack__layer": empty.astype(np.int64), "crack__type": empty.astype(np.int64)}
        line, seq, p3, w, face = (np.concatenate(x) for x in zip(*self._pts))
        order = np.lexsort((seq, line))
        line, p3, w, face = line[order], p3[order], w[order], face[order]
        # a point repeating the previous one of its line (an edge point closing a lost CM)
        dup = np.zeros(len(line), bool)
        dup[1:] = (line[1:] == line[:-1]) & np.all(p3[1:] == p3[:-1], axis=1)
        line, p3, w, face = line[~dup], p3[~dup], w[~dup], face[~dup]
        ids, lay, typ, _ = (np.concatenate(x) for x in zip(*self._line_meta))
        meta_order = np.argsort(ids)
        lay, typ = lay[meta_order], typ[meta_order]
        counts = np.bincount(line, minlength=self.n_lines)
        keep_line = counts >= 2                                  # a line needs two points
        keep_pt = keep_line[line]
        line, p3, w, face = line[keep_pt], p3[keep_pt], w[keep_pt], face[keep_pt]
        counts = counts[keep_line]
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        return p3, offsets, {"crack__width": w, "crack__face": face}, \
            {"crack__layer": lay[keep_line], "crack__type": typ[keep_line]}


def meeting_angles(points: np.ndarray, offsets: np.ndarray, size: float) -> np.ndarray:
    """Angles (degrees, 0-90) at which crack ends meet another crack (thesis plate 5.5).

    Lines sharing an end point (a facet crossing, a fork, the heads of one birth) form one
    chain; a line's last point that no other line shares is a crack end, and where it lies
    within 1.5 cells of another chain's path the end met that crack: the angle is the one
    between the end's last segment and the nearest segment of the other chain.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    offsets = np.asarray(offsets, np.int64)
    n_lines = len(offsets) - 1
    if n_lines == 0 or len(points) < 2:
        return np.zeros(0)
    line_of = np.repeat(np.arange(n_lines), np.diff(offsets))
    tips = np.concatenate([offsets[:-1], offsets[1:] - 1])
    _, inv, cnt = np.unique(np.round(points[tips] / size, 6), axis=0, return_inverse=True,
                            return_counts=True)
    inv = inv.ravel()
    link = coo_matrix((np.ones(len(tips)), (line_of[tips], n_lines + inv)),
                      shape=(n_lines + len(cnt),) * 2)
    chain = connected_components(link, directed=False)[1][:n_lines]
    # the path sampled every half cell, each sample knowing its segment
    seg = np.nonzero(line_of[:-1] == line_of[1:])[0]
    a, b = points[seg], points[seg + 1]
    reps = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / (0.5 * size)).astype(np.int64), 1)
    sid = np.repeat(np.arange(len(seg)), reps)
    t = (np.arange(len(sid)) - np.repeat(np.cumsum(reps) - reps, reps)) / np.repeat(reps, reps)
    samples = a[sid] + t[:, None] * (b - a)[sid]
    ends = offsets[1:] - 1
    free = (cnt[inv[n_lines:]] == 1) & (np.diff(offsets) >= 2)
    ends, own = ends[free], chain[free]
    if len(ends) == 0:
        return np.zeros(0)
    dist, near = cKDTree(samples).query(points[ends], k=min(32, len(samples)),
                                        distance_upper_bound=1.5 * size)
    dist, near = dist.reshape(len(ends), -1), near.reshape(len(ends), -1)
    hit = np.isfinite(dist)
    other = np.where(hit, chain[line_of[seg[sid[np.minimum(near, len(sid) - 1)]]]], -1)
    ok = hit & (other != own[:, None])
    met = ok.any(axis=1)
    first = np.argmax(ok, axis=1)[met]
    s_other = sid[near[met, first]]
    u = points[ends[met]] - points[ends[met] - 1]
    v = (b - a)[s_other]
    cos = np.abs(np.einsum("md,md->m", u, v)) / np.maximum(
        np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-300)
    return np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))
