"""The snake: one closed chain of snaxels on tessellation edges, with birth, merge and holes.

Representation (digest section 4.7, ambiguity A18): a vertex is *visited* once a snaxel has
passed it. Every edge from a visited to an unvisited vertex carries exactly one snaxel, moving
towards the unvisited end, and the chain order is the counter-clockwise walk with the visited
side on the left. A birth at vertex w replaces the snaxels arriving at w (the parent plus the
ones that merge head-on with the children the thesis would put on edges back to visited
vertices) by one child per edge to an unvisited neighbour, in CCW angular order, joined to the
rim snaxels that share a triangle with the end children. When w touched the chain in k > 1
places the chain falls into k loops (a non-connected merge): the loop with the largest
positive signed area is the snake, the others are holes; holes are discarded and the unvisited
vertices they enclose are marked *filled* so that nothing ever enters them.

Chain arrays are kept in chain order (struct of arrays): ``ints[:, 0:3] = (u, v, curve)`` and
``flts[:, 0:7] = (pos, t, edge_len, ox, oy, dx, dy)``. Topology events are handled one at a
time in Python (each costs a few O(N_s) numpy passes; the step itself is vectorised).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from procgen.accel import MIN_SNAXELS, kernels
from procgen.geometry import signed_area

from .topology import Topology

U, V, CURVE = 0, 1, 2
POS, T, ELEN, OX, OY, DX, DY = range(7)
UNVISITED, VISITED, FILLED = 0, 1, 2


class TopologyBug(RuntimeError):
    """An internal invariant of the snake broke (never expected; signals a bug, not bad input)."""


class Snake:
    """Chain state plus per-vertex visit state; see the module docstring."""

    def __init__(self, topo: Topology, blocks: Callable[[np.ndarray], np.ndarray], min_offset: float = 1e-3) -> None:
        self.topo = topo
        self.blocks = blocks      # points (k, 2) -> True where a snaxel heading there must stop
        self.blocked = np.zeros(0, bool)
        self.state = np.zeros(0, np.int8)
        self.sync()
        self.min_offset = float(min_offset)   # children start at >= this fraction of their edge
        self.ints = np.zeros((0, 3), np.int64)
        self.flts = np.zeros((0, 7), np.float64)
        self.births = 0
        self.merges = 0           # incoming snaxels removed at a newly visited vertex (besides the parent)
        self.holes = 0            # loops discarded
        self.filled = 0           # vertices sealed inside discarded holes
        self.hole_rule_disagreements = 0   # thesis "more snaxels = snake" rule vs signed area
        self.head_on = False      # thesis-literal merges: see birth() and collide()
        self.accelerate: bool | None = None  # events by procgen_snaxel.events_numba, see procgen.accel

    # -- construction -------------------------------------------------------------------
    def sync(self) -> None:
        """Extend the per-vertex arrays to vertices a tiled tessellation has added."""
        n0, n = len(self.state), self.topo.n_vertices
        if n > n0:
            self.state = np.concatenate([self.state, np.zeros(n - n0, np.int8)])
            new = np.asarray(self.blocks(self.topo.points[n0:]), bool) | self.topo.hull[n0:]
            self.blocked = np.concatenate([self.blocked, new])

    def start(self, source: int, offset: float, curve: int = 0) -> None:
        """Initial snake (A3): the source is visited, one snaxel per incident edge, CCW."""
        if self.blocked[source]:
            raise ValueError("source vertex is on the margin or hull")
        self.state[source] = VISITED
        ring = self.topo.neighbours(source)
        ints, flts = self._children(source, ring, np.full(len(ring), 0.0), 0.0, curve)
        flts[:, POS] = np.maximum(offset, self.min_offset) * flts[:, ELEN]
        self.ints, self.flts = ints, flts

    def _children(self, w: int, verts: np.ndarray, carry: np.ndarray, t: float, curve: int
                  ) -> tuple[np.ndarray, np.ndarray]:
        pts = self.topo.points
        d = pts[verts] - pts[w]
        elen = np.hypot(d[:, 0], d[:, 1])
        ints = np.empty((len(verts), 3), np.int64)
        ints[:, U] = w
        ints[:, V] = verts
        ints[:, CURVE] = curve
        flts = np.empty((len(verts), 7), np.float64)
        flts[:, POS] = np.clip(carry, self.min_offset * elen, 0.5 * elen)
        flts[:, T] = t
        flts[:, ELEN] = elen
        flts[:, OX] = pts[w, 0]
        flts[:, OY] = pts[w, 1]
        flts[:, DX] = d[:, 0] / elen
        flts[:, DY] = d[:, 1] / elen
        return ints, flts

    # -- geometry -------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.ints)

    def xy(self) -> np.ndarray:
        f = self.flts
        return np.column_stack([f[:, OX] + f[:, DX] * f[:, POS], f[:, OY] + f[:, DY] * f[:, POS]])

    def roll(self, k: int) -> None:
        """Rotate the chain (same loop, different first snaxel)."""
        if k:
            self.ints = np.roll(self.ints, -k, axis=0)
            self.flts = np.roll(self.flts, -k, axis=0)

    # -- events ---------------------------------------------------------------------------
    def find(self, u: int, v: int) -> int:
        """Chain index of the snaxel on edge u->v, or -1."""
        kern = kernels("procgen_snaxel.events_numba", self.accelerate, len(self.ints), MIN_SNAXELS)
        if kern is not None:
            return kern.find(self, u, v)
        hit = np.flatnonzero((self.ints[:, V] == v) & (self.ints[:, U] == u))
        return int(hit[0]) if len(hit) else -1

    def birth(self, p: int, carry: float) -> None:
        """Snaxel ``p`` reached its destination w: visit w, replace the w-snaxels by children."""
        kern = None if self.head_on else kernels("procgen_snaxel.events_numba", self.accelerate,
                                                 len(self.ints), MIN_SNAXELS)
        if kern is not None and kern.birth(self, p, carry):
            return                # a simple birth, done compiled (same chain; head-on pairs stay numpy)
        ints, flts = self.ints, self.flts
        w = int(ints[p, V])
        t_parent, curve = float(flts[p, T]), int(ints[p, CURVE])
        self.state[w] = VISITED
        self.births += 1
        ring = self.topo.neighbours(w)
        unv = self.state[ring] == UNVISITED
        rm = ints[:, V] == w
        idx = np.flatnonzero(rm)
        self.merges += len(idx) - 1
        if self._birth_simple(w, ring, unv, idx, carry, t_parent, curve, p):
            return
        if self.head_on and self.collide(force=True) is not None:   # the general path needs no pairs
            ints, flts = self.ints, self.flts
            rm = ints[:, V] == w
        if not unv.any():        # w was enclosed; cannot happen once holes are filled
            raise TopologyBug(f"vertex {w} entered with no unvisited neighbour")
        # rotate the ring to start at a visited vertex so that unvisited runs do not wrap
        j0 = int(np.argmin(unv))
        ring = np.roll(ring, -j0)
        unv = np.roll(unv, -j0)
        edge = np.diff(np.concatenate([[0], unv.astype(np.int8), [0]]))
        run_s = np.flatnonzero(edge == 1)
        run_e = np.flatnonzero(edge == -1) - 1
        # rotate the chain so that it starts at an arc start (a kept snaxel after a removed one)
        keep = ~rm
        starts = np.flatnonzero(keep & np.roll(rm, 1))
        if len(starts) == 0:
            raise TopologyBug(f"no rim snaxel around vertex {w}")
        k0 = int(starts[0])
        ints = np.roll(ints, -k0, axis=0)
        flts = np.roll(flts, -k0, axis=0)
        keep = np.roll(keep, -k0)
        b = np.diff(np.concatenate([[0], keep.astype(np.int8), [0]]))
        arc_s = np.flatnonzero(b == 1)
        arc_e = np.flatnonzero(b == -1) - 1
        nv = self.topo.n_vertices
        key = ints[:, U] * nv + ints[:, V]
        start_key = {int(key[i]): a for a, i in enumerate(arc_s)}
        end_key = {int(key[i]): a for a, i in enumerate(arc_e)}
        n_arcs = len(arc_s)
        succ: list[tuple[int, int]] = [(-1, -1)] * n_arcs     # arc -> (run, next arc)
        d = len(ring)
        for r in range(len(run_s)):
            first, last = int(ring[run_s[r]]), int(ring[run_e[r]])
            prev_v, next_v = int(ring[run_s[r] - 1]), int(ring[(run_e[r] + 1) % d])
            a_before = end_key.get(prev_v * nv + first)
            a_after = start_key.get(next_v * nv + last)
            if a_before is None or a_after is None:
                raise TopologyBug(f"rim snaxels around vertex {w} not found")
            succ[a_before] = (r, a_after)
        loops: list[list[tuple[str, int]]] = []
        seen = np.zeros(n_arcs, bool)
        for a0 in range(n_arcs):
            if seen[a0]:
                continue
            loop, a = [], a0
            while not seen[a]:
                seen[a] = True
                r, nxt = succ[a]
                if r < 0:
                    raise TopologyBug(f"arc without successor at vertex {w}")
                loop.append(("arc", a))
                loop.append(("run", r))
                a = nxt
            loops.append(loop)
        run_parts = [self._children(w, ring[run_s[r]:run_e[r] + 1],
                                    np.full(run_e[r] - run_s[r] + 1, carry), t_parent, curve)
                     for r in range(len(run_s))]

        # The chain's first snaxel is its head (the joint of a single curve): keep it in place,
        # or hand it to the first child that replaces it (the children follow the same arc).
        h = (len(keep) - k0) % len(keep)
        if keep[h]:
            head_piece = ("arc", int(np.searchsorted(arc_s, h, side="right")) - 1)
            head_off = h - int(arc_s[head_piece[1]])
        else:
            a_prev = int(np.searchsorted(arc_e, h)) - 1
            head_piece, head_off = ("run", succ[a_prev][0]), 0

        def assemble(loop: list[tuple[str, int]]) -> tuple[np.ndarray, np.ndarray]:
            pi, pf = [], []
            head = 0
            at = 0
            for kind, j in loop:
                if kind == "arc":
                    pi.append(ints[arc_s[j]:arc_e[j] + 1])
                    pf.append(flts[arc_s[j]:arc_e[j] + 1])
                else:
                    pi.append(run_parts[j][0])
                    pf.append(run_parts[j][1])
                if (kind, j) == head_piece:
                    head = at + head_off
                at += len(pi[-1])
            out_i, out_f = np.concatenate(pi), np.concatenate(pf)
            if head:
                out_i, out_f = np.roll(out_i, -head, axis=0), np.roll(out_f, -head, axis=0)
            return out_i, out_f

        if len(loops) == 1:
            self.ints, self.flts = assemble(loops[0])
            return
        built = [assemble(lp) for lp in loops]
        areas = []
        for bi, bf in built:
            xy = np.column_stack([bf[:, OX] + bf[:, DX] * bf[:, POS], bf[:, OY] + bf[:, DY] * bf[:, POS]])
            areas.append(signed_area(xy))
        best = int(np.argmax(areas))
        if int(np.argmax([len(bi) for bi, _ in built])) != best:
            self.hole_rule_disagreements += 1
        self.ints, self.flts = built[best]
        for j, (bi, _) in enumerate(built):
            if j != best:
                self.holes += 1
                self._fill(bi[:, V])

    def _birth_simple(self, w: int, ring: np.ndarray, unv: np.ndarray, idx: np.ndarray, carry: float,
                      t_parent: float, curve: int, parent: int = -1) -> bool:
        """Fast path for the common birth (~95%): the w-snaxels are one contiguous, non-wrapping
        stretch of the chain and w's unvisited neighbours form one angular run. Then the children
        simply replace that stretch (connected merge); the general path below handles the rest.
        With ``head_on`` (thesis section 3.2.2, taken literally) the two end snaxels of the
        stretch, when they are not the parent, live on and each gets a child on its own edge
        heading back at it: the pair dies when they collide (:meth:`collide`)."""
        i, j = int(idx[0]), int(idx[-1])
        if j - i + 1 != len(idx):
            return False
        flags = unv.tolist()
        d = len(flags)
        if all(flags):
            return False
        j0 = flags.index(False)
        order = [(j0 + q) % d for q in range(d)]
        seq = [flags[q] for q in order]
        # exactly one run of unvisited neighbours, in CCW order after a visited one
        first = seq.index(True)
        last = d - 1 - seq[::-1].index(True)
        if not all(seq[first:last + 1]):
            return False
        verts = ring[[order[q] for q in range(first, last + 1)]]
        ci, cf = self._children(w, verts, np.full(len(verts), carry), t_parent, curve)
        if self.head_on:
            ci, cf = self._head_on(w, i, j, parent, ci, cf, t_parent, curve)
        if i == 0:     # the head was replaced: its first child becomes the head
            self.ints = np.concatenate([ci, self.ints[j + 1:]])
            self.flts = np.concatenate([cf, self.flts[j + 1:]])
        else:
            self.ints = np.concatenate([self.ints[:i], ci, self.ints[j + 1:]])
            self.flts = np.concatenate([self.flts[:i], cf, self.flts[j + 1:]])
        return True

    def _head_on(self, w: int, i: int, j: int, parent: int, ci: np.ndarray, cf: np.ndarray, t: float, curve: int
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Children framed by the end partners [i, j] kept and their head-on back-children."""
        pre_i, pre_f, post_i, post_f = [], [], [], []
        f = self.flts
        apart = f[:, POS] < (1.0 - self.min_offset) * f[:, ELEN]      # else they meet at once
        if i != parent and j > i and apart[i]:
            bi, bf = self._children(w, self.ints[i:i + 1, U], np.zeros(1), t, curve)
            pre_i, pre_f = [self.ints[i:i + 1], bi], [f[i:i + 1], bf]
        if j != parent and j > i and apart[j]:
            bi, bf = self._children(w, self.ints[j:j + 1, U], np.zeros(1), t, curve)
            post_i, post_f = [bi, self.ints[j:j + 1]], [bf, f[j:j + 1]]
        self.merges -= len(pre_i) // 2 + len(post_i) // 2      # counted when they collide instead
        return np.concatenate([*pre_i, ci, *post_i]), np.concatenate([*pre_f, cf, *post_f])

    def collide(self, force: bool = False) -> np.ndarray | None:
        """Thesis-literal merge (section 3.2.2): neighbours on one edge heading at each other die
        once they meet (their travelled parts cover the edge; ``force``: now, before a birth the
        general path handles); returns the mask of the dead (old chain indices) or None."""
        ints, f = self.ints, self.flts
        nxt = np.roll(np.arange(len(ints)), -1)
        hit = np.flatnonzero((ints[:, U] == ints[nxt, V]) & (ints[:, V] == ints[nxt, U])
                             & (force | (f[:, POS] + f[nxt, POS] >= f[:, ELEN])))
        if not len(hit):
            return None
        dead = np.zeros(len(ints), bool)
        dead[hit] = True
        dead[nxt[hit]] = True
        self.ints, self.flts = ints[~dead], f[~dead]
        self.merges += len(hit)
        return dead

    def _fill(self, seeds: np.ndarray) -> None:
        """Seal the unvisited vertices enclosed by a discarded hole loop (breadth-first, one
        whole frontier at a time; a tiled tessellation readies the frontier's rings first)."""
        topo = self.topo
        front = np.unique(seeds)
        front = front[self.state[front] == UNVISITED]
        while len(front):
            if topo.ensure(front):
                self.sync()
            self.state[front] = FILLED
            self.filled += len(front)
            nb = np.unique(topo.rings_of(front)[1])
            nb = nb[self.state[nb] == UNVISITED]
            if np.any(topo.hull[nb]):
                raise TopologyBug("a discarded hole loop leaks to the mesh boundary")
            front = nb
