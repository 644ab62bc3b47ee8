"""The snaxel cloud simulation: curves, speeds, Euler motion, events and clusters.

One ``step()`` is one Euler step of every snaxel (vectorised over the chain), followed by the
topology events in order of arrival time (per event), curve maintenance (length-limits table
and c_min; Python only for the few curves that split or merge) and cluster control.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from shapely.geometry import Polygon

from procgen import portable
from procgen.accel import MIN_SNAXELS, kernels
from procgen.geometry import signed_area

from .bumps import bump_statistics
from .fractal import raster_area_perimeter
from .params import GrowthParams
from .snake import CURVE, DX, DY, ELEN, OX, OY, POS, T, U, UNVISITED, V, Snake
from .speeds import base_speed, blend, circular_profile, effect_coefficient, linear_profile
from .topology import Topology


def label_starts(c: np.ndarray) -> np.ndarray:
    """True where a (cyclic) run of equal labels begins; slicing instead of np.roll (hot path)."""
    out = np.empty(len(c), bool)
    out[1:] = c[1:] != c[:-1]
    out[0] = c[0] != c[-1]
    return out


@dataclass
class Snapshot:
    step: int
    xy: np.ndarray
    curve: np.ndarray
    cluster: np.ndarray


@dataclass
class Runs:
    """The curve partition of the chain plus per-curve geometry (all flat arrays)."""

    starts: np.ndarray     # first chain index of each run
    rid: np.ndarray        # run index of each snaxel
    count: np.ndarray      # snaxels per run
    curve: np.ndarray      # curve id of each run
    length: np.ndarray     # curve length (own segments only, A6)
    arc: np.ndarray        # arc position of each snaxel inside its curve
    s: np.ndarray          # arc position of each snaxel along the closed chain
    perimeter: float


@dataclass
class Stats:
    steps: int = 0
    splits: int = 0
    curve_merges: int = 0
    clusters_grown: int = 0
    clusters_stalled: int = 0
    cluster_log: list = field(default_factory=list)
    sketch_steps: int = 0


class CloudGrowth:
    """A single snake growing one cloud on a fixed tessellation."""

    def __init__(self, topo: Topology, cfg: GrowthParams, rng: np.random.Generator,
                 bounds: tuple[float, float, float, float] | None = None,
                 marked: np.ndarray | None = None, guide: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        self.cfg = cfg
        self.limits = cfg.check_growth()
        self.topo = topo
        if bounds is None and not topo.unbounded:
            pts = topo.points
            bounds = (float(pts[:, 0].min()), float(pts[:, 1].min()), float(pts[:, 0].max()), float(pts[:, 1].max()))
        self.bounds = bounds
        self.snake = Snake(topo, self.blocks)
        self.snake.head_on = cfg.merge == "head_on"
        # independent streams: curve speeds, split points, cluster choices (digest property 22)
        self.rng_speed, self.rng_split, self.rng_cluster = rng.spawn(3)
        self.rng_jitter = rng.spawn(1)[0]    # limit_jitter's draws (none at 0: thesis streams unchanged)
        self.vb = np.zeros(0)
        self.vs = np.zeros(0)
        self.cluster_of = np.zeros(0, np.int64)
        self.jitter = np.ones(0)           # per curve: the factor on its table limit (limit_jitter)
        self.t_curve = np.zeros(0)         # per curve: travelled distance inherited from the curve it broke from
        self.n_curves = 0
        self.marked = marked
        self.guide = guide     # points (k, 2) -> attraction (higher = preferred) for seed_policy field / sketch
        self.phase = "sketch" if marked is not None else "grow"
        if marked is not None:
            cand = np.flatnonzero(marked & ~self.snake.blocked)
            if len(cand) == 0:
                raise ValueError("the sketch marks no vertex inside the margin")
            target = np.asarray(cfg.source if cfg.source is not None else topo.points[cand].mean(0))
            source = int(cand[np.argmin(np.hypot(*(topo.points[cand] - target).T))])
        else:
            source = self._source_vertex()
        self.source = source
        first = self._new_curve(cluster=0)
        self.snake.start(source, cfg.init_offset, first)
        self.active = 0
        self.g = float(self.rng_cluster.uniform(cfg.g_min, cfg.g_max))
        self.cluster_start = 0
        self.best_t = 0.0
        self.best_step = 0
        self.done = False
        self.stats = Stats()
        self.snapshots: list[Snapshot] = []
        self.snapshot_every = cfg.snapshot_every
        self.last_speed = np.zeros(len(self.snake))

    def blocks(self, p: np.ndarray) -> np.ndarray:
        """Vertices a snaxel must not enter: the domain margin (Figure 3.22) and, with a
        condensation level, everything below it (the flat base of a cumulus)."""
        out = np.zeros(len(p), bool)
        if self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
            m = self.cfg.margin
            out |= (p[:, 0] < x0 + m) | (p[:, 0] > x1 - m) | (p[:, 1] < y0 + m) | (p[:, 1] > y1 - m)
        if self.cfg.condensation_level is not None:
            out |= p[:, 1] < self.cfg.condensation_level
        return out

    def stop_lines(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where each snaxel ``idx`` (heading into a blocked vertex) meets the boundary: the distance
        along its edge to the first line it would cross (the domain margin's four sides, the
        condensation level) and which line (-1: none, a mesh's hull vertex blocks it)."""
        f = self.snake.flts[idx]
        o = (f[:, OX], f[:, OY])
        d = (f[:, DX], f[:, DY])
        lines: list[tuple[int, float, float]] = []        # (axis, bound, +1: coord >= bound / -1: <=)
        if self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
            m = self.cfg.margin
            lines += [(0, x0 + m, 1.0), (0, x1 - m, -1.0), (1, y0 + m, 1.0), (1, y1 - m, -1.0)]
        if self.cfg.condensation_level is not None:
            lines.append((1, float(self.cfg.condensation_level), 1.0))
        cap = np.full(len(idx), np.inf)
        which = np.full(len(idx), -1, np.int64)
        for k, (axis, bound, sign) in enumerate(lines):
            out = sign * d[axis] < 0.0                       # moving towards this line
            room = np.divide(sign * (o[axis] - bound), -sign * d[axis], out=np.full(len(idx), np.inf), where=out)
            room = np.maximum(room, 0.0)
            nearer = room < cap
            cap = np.where(nearer, room, cap)
            which = np.where(nearer, k, which)
        return cap, which

    def stop_distance(self, idx: np.ndarray) -> np.ndarray:
        """How far along its edge each snaxel ``idx`` (heading into a blocked vertex) may go: to where
        the edge meets the domain margin or the condensation level. Figure 3.22's caption: "the
        snaxels are stopped when they reach the boundaries of the screen", so the front stops on
        the boundary line itself and leaves a straight cut (the "horizontal line at the bottom").
        A destination blocked for another reason (a mesh's hull vertex) meets no line: the snaxel
        stays where it is."""
        cap, which = self.stop_lines(idx)
        return np.where(which >= 0, cap, self.snake.flts[idx, POS])

    def _heading_out(self) -> tuple[np.ndarray, np.ndarray]:
        """Snaxels heading into a blocked vertex and their stop distances (:meth:`stop_distance`)."""
        idx = np.flatnonzero(self.snake.blocked[self.snake.ints[:, V]])
        return idx, self.stop_distance(idx)

    def _clamp_to_boundary(self, moved: bool) -> None:
        """Stop snaxels on the boundary line. After the Euler motion (``moved``) the overshoot is
        taken off their travelled distance too; children just placed past it are placed on it."""
        idx, cap = self._heading_out()
        if len(idx) == 0:
            return
        f = self.snake.flts
        over = f[idx, POS] - cap
        hit = over > 0.0
        if hit.any():
            f[idx[hit], POS] = cap[hit]
            if moved and self.phase == "grow":
                f[idx[hit], T] -= over[hit]

    def _source_vertex(self) -> int:
        """The free vertex nearest to ``source`` (default: the domain centre, or the origin)."""
        cfg, topo = self.cfg, self.topo
        if cfg.source is not None:
            target = np.asarray(cfg.source, float)
        elif self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
            target = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        else:
            target = np.zeros(2)
        if self.blocks(target[None])[0]:
            raise ValueError(f"source {list(target)} lies in the blocked margin or below the condensation level")
        if topo.ensure_box(target[0], target[1], target[0], target[1]):
            self.sync()
        free = np.flatnonzero(~self.snake.blocked & topo.ready)
        return int(free[np.argmin(np.hypot(*(topo.points[free] - target).T))])

    def sync(self) -> None:
        """Per-vertex arrays follow a tiled tessellation that has added vertices."""
        self.snake.sync()
        if self.marked is not None and len(self.marked) < self.topo.n_vertices:
            self.marked = np.concatenate([self.marked, np.zeros(self.topo.n_vertices - len(self.marked), bool)])

    # -- curve table ------------------------------------------------------------------------
    def _new_curve(self, cluster: int, copy_of: int | None = None, inherit: float = 0.0) -> int:
        cid = self.n_curves
        if cid >= len(self.vb):
            cap = max(64, 2 * len(self.vb))
            self.vb = np.resize(self.vb, cap)
            self.vs = np.resize(self.vs, cap)
            self.cluster_of = np.resize(self.cluster_of, cap)
            self.jitter = np.resize(self.jitter, cap)
            self.t_curve = np.resize(self.t_curve, cap)
        self.t_curve[cid] = inherit
        if copy_of is None:   # A8: independent draws for the base value and the shape speed
            self.vb[cid], self.vs[cid] = self.rng_speed.uniform(self.cfg.v_min, self.cfg.v_max, 2)
            j = self.cfg.limit_jitter
            self.jitter[cid] = float(portable.exp(self.rng_jitter.uniform(-j, j))) if j > 0 else 1.0
        else:
            self.vb[cid], self.vs[cid] = self.vb[copy_of], self.vs[copy_of]
            self.jitter[cid] = self.jitter[copy_of]
            self.t_curve[cid] = self.t_curve[copy_of]
        self.cluster_of[cid] = cluster
        self.n_curves += 1
        return cid

    # -- chain geometry ---------------------------------------------------------------------
    def runs(self, xy: np.ndarray | None = None) -> Runs:
        snake = self.snake
        c = snake.ints[:, CURVE]
        n = len(c)
        if xy is None:
            xy = snake.xy()
        d = np.empty_like(xy)
        np.subtract(xy[1:], xy[:-1], out=d[:-1])
        np.subtract(xy[0], xy[-1], out=d[-1])
        seg = np.hypot(d[:, 0], d[:, 1])               # segment i joins snaxel i to i+1
        start_mask = label_starts(c)
        if not start_mask.any():
            start_mask[0] = True
        if not start_mask[0]:
            raise AssertionError("chain must start at a curve boundary")
        starts = np.flatnonzero(start_mask)
        rid = np.cumsum(start_mask) - 1
        bound = np.empty(len(starts) + 1, np.int64)
        bound[:-1], bound[-1] = starts, n
        inner = seg.copy()
        inner[bound[1:] - 1] = 0.0                     # gap segments belong to no curve
        length = np.bincount(rid, inner, minlength=len(starts))
        cs = np.empty(n + 1)                           # cs[i]: curve length before snaxel i
        cs[0] = 0.0
        np.cumsum(inner, out=cs[1:])
        arc = cs[:-1] - cs[starts][rid]
        np.cumsum(seg, out=cs[1:])                     # now along the whole chain, gaps included
        return Runs(starts, rid, np.diff(bound), c[starts], length, arc, cs[:-1], float(cs[-1]))

    def normalise(self) -> None:
        """Keep curves contiguous (fragments left by hole discards become curves of their own)
        and start the chain at a curve boundary."""
        snake = self.snake
        c = snake.ints[:, CURVE]
        start_mask = label_starts(c)
        if not start_mask.any():
            return
        starts = np.flatnonzero(start_mask)
        if starts[0] != 0:
            snake.roll(int(starts[0]))
            c = snake.ints[:, CURVE]
            starts = starts - starts[0]
        labels = c[starts]
        if np.bincount(labels).max() > 1:   # rare: a curve cut in two by a discarded hole
            seen: set[int] = set()
            ends = np.append(starts[1:], len(c))
            for s0, e0, lab in zip(starts, ends, labels):
                lab = int(lab)
                if lab in seen:
                    snake.ints[s0:e0, CURVE] = self._new_curve(int(self.cluster_of[lab]), copy_of=lab)
                seen.add(lab)

    # -- curve maintenance (active cluster only, A13) ------------------------------------------
    def maintain(self, runs: Runs, t: np.ndarray) -> bool:
        """Split active curves longer than their table limit, then merge active curves shorter
        than c_min into a random same-cluster neighbour, until no short curve can merge."""
        changed = self._split_long(runs, t)
        merged_any = True
        while merged_any and len(runs.starts) > 1:
            if changed:
                self.normalise()
                runs = self.runs()
            merged_any = self._merge_short(runs)
            changed |= merged_any
        if changed:      # a merge can push a curve over its limit: split once more (no new shorts)
            self.normalise()
            self._split_long(self.runs(), self.snake.flts[:, T])
        return changed

    def _split_long(self, runs: Runs, t: np.ndarray) -> bool:
        active = self.cluster_of[runs.curve] == self.active
        limit = self.limits.limit(self.curve_distance(runs, t))
        if self.cfg.limit_jitter > 0:
            limit = limit * self.jitter[runs.curve]
        changed = False
        for r in np.flatnonzero(active & (runs.length > limit) & (runs.count >= 4)):   # per split event
            s0 = int(runs.starts[r])
            changed |= self._split(s0, s0 + int(runs.count[r]), runs.arc)
        return changed

    def curve_distance(self, runs: Runs, t: np.ndarray) -> np.ndarray:
        """Each curve's travelled distance (section 3.5.1): the biggest distance travelled by any of
        its snaxels; with ``curve_distance = "inherit"`` at least the distance of the curve it broke
        from (a piece of a curve that has travelled into a table row is in that row)."""
        own = np.maximum.reduceat(t, runs.starts)
        if self.cfg.curve_distance == "inherit":
            own = np.maximum(own, self.t_curve[runs.curve])
        return own

    def _merge_short(self, runs: Runs) -> bool:
        """One pass of curve merges (A12: random neighbour of the same, active cluster)."""
        active = self.cluster_of[runs.curve] == self.active
        short = np.flatnonzero(active & (runs.length < self.cfg.c_min))
        c = self.snake.ints[:, CURVE]
        n = len(c)
        merged = False
        for r in short:     # per merge event (rare)
            s0 = int(runs.starts[r])
            e0 = s0 + int(runs.count[r])
            own = int(c[s0])
            nbrs = [int(c[(s0 - 1) % n]), int(c[e0 % n])]
            nbrs = [x for x in nbrs if x != own and self.cluster_of[x] == self.active]
            if nbrs:
                pick = nbrs[int(self.rng_split.integers(len(nbrs)))]
                c[s0:e0] = pick
                self.stats.curve_merges += 1
                merged = True
        return merged

    def _split(self, s0: int, e0: int, arc: np.ndarray) -> bool:
        """Split the curve on chain[s0:e0] at random snaxels until every piece fits its limit."""
        cfg = self.cfg
        snake = self.snake
        t = snake.flts[:, T]
        work = [(s0, e0)]
        did = False
        base = arc[s0:e0] - arc[s0]
        inherit = cfg.curve_distance == "inherit"
        while work:
            a, b = work.pop()
            loc = base[a - s0:b - s0] - base[a - s0]
            length = float(loc[-1])
            dist = max(float(t[a:b].max()), float(self.t_curve[snake.ints[a, CURVE]]) if inherit else 0.0)
            if length <= float(self.limits.limit(dist)) * self.jitter[snake.ints[a, CURVE]] or b - a < 4:
                continue
            # piece 1 = a..i, piece 2 = i+1..b-1, >= 2 snaxels and >= c_min long each (A7)
            i = np.arange(1, b - a - 2)
            ok = (loc[i] >= cfg.c_min) & (length - loc[i + 1] >= cfg.c_min)
            cand = i[ok]
            if len(cand) == 0:
                continue
            cut = a + int(cand[int(self.rng_split.integers(len(cand)))])
            cl = int(self.cluster_of[snake.ints[a, CURVE]])
            carry = dist if inherit else 0.0
            snake.ints[a:cut + 1, CURVE] = self._new_curve(cl, inherit=carry)
            snake.ints[cut + 1:b, CURVE] = self._new_curve(cl, inherit=carry)
            self.stats.splits += 1
            did = True
            work.append((a, cut + 1))
            work.append((cut + 1, b))
        return did

    # -- speeds -----------------------------------------------------------------------------
    def speeds(self, runs: Runs) -> np.ndarray:
        cfg = self.cfg
        snake = self.snake
        curve = snake.ints[:, CURVE]
        t = snake.flts[:, T]
        L = runs.length[runs.rid]
        if self.phase == "sketch":
            dest = snake.ints[:, V]
            go = self.marked[dest] & ~snake.blocked[dest]
            return np.where(go, cfg.sketch_speed or cfg.v_max, 0.0)
        if cfg.details == "circular":
            x = np.divide(cfg.G_max * runs.arc, L, out=np.zeros_like(L), where=L > 0)
            lv = np.where(L > 0, circular_profile(x, cfg.G_max, self.vs[curve]), 0.0)
        else:
            u = np.divide(runs.arc, L, out=np.zeros_like(L), where=L > 0)
            lv = np.where(L > 0, linear_profile(u, self.vs[curve]), 0.0)
        if cfg.base == "off":
            v = lv
        else:
            bv = base_speed(runs.s, runs.s[runs.starts], runs.length, self.vb[runs.curve], runs.perimeter)
            v = bv + lv if cfg.base == "sum" else blend(bv, lv, effect_coefficient(t, cfg.r), cfg.w_s)
        moving = (self.cluster_of[curve] == self.active) & ~snake.blocked[snake.ints[:, V]]
        idx, cap = self._heading_out()
        if len(idx):      # heading out of the domain: move until the boundary line, then stop
            moving[idx] = (self.cluster_of[curve[idx]] == self.active) & (snake.flts[idx, POS] < cap)
        return np.where(moving, v, 0.0)

    # -- one Euler step ---------------------------------------------------------------------
    def step(self) -> bool:
        """Advance one time step; False once the run has finished."""
        if self.done:
            return False
        cfg = self.cfg
        snake = self.snake
        if self.topo.ensure(snake.ints[:, V]):      # lazy tiles: ready every vertex a snaxel heads to
            self.sync()
        if self.snapshot_every and self.stats.steps % self.snapshot_every == 0:
            self.snapshot()
        xy = snake.xy()
        runs = self.runs(xy)
        if self.phase == "grow" and self.maintain(runs, snake.flts[:, T]):
            self.normalise()
            runs = self.runs()
        v = self.speeds(runs)
        self.last_speed = v
        f = snake.flts
        adv = v * cfg.dt
        pos_old = f[:, POS].copy()
        f[:, POS] += adv
        if self.phase == "grow":
            f[:, T] += adv
        self._clamp_to_boundary(moved=True)
        dead = snake.collide() if snake.head_on else None
        if dead is not None:
            f, v, pos_old = snake.flts, v[~dead], pos_old[~dead]
        arrived = np.flatnonzero(f[:, POS] >= f[:, ELEN])
        if len(arrived):
            when = (f[arrived, ELEN] - pos_old[arrived]) / v[arrived]
            order = arrived[np.lexsort((arrived, when))]
            kern = None if snake.head_on else kernels("procgen_snaxel.events_numba", snake.accelerate,
                                                      len(snake), MIN_SNAXELS)
            if kern is not None:           # all of them in one compiled call (the same chain)
                kern.step_events(snake, snake.ints[order, U], snake.ints[order, V], f[order, POS] - f[order, ELEN])
                order = order[:0]
            events = [(int(snake.ints[i, U]), int(snake.ints[i, V]), float(f[i, POS] - f[i, ELEN]))
                      for i in order]
            for u, w, carry in events:     # per topology event (~2 per step)
                if snake.state[w] != UNVISITED:
                    continue              # already entered this step: this snaxel merged there
                p = snake.find(u, w)
                if p >= 0:
                    snake.birth(p, carry)
            self.normalise()
            self._clamp_to_boundary(moved=False)
        self.stats.steps += 1
        if self.phase == "sketch":
            self._sketch_control()
        else:
            self._cluster_control()
        if self.stats.steps >= cfg.max_steps:
            self.done = True
        if self.done:
            self.snapshot()
        return True

    # -- control ----------------------------------------------------------------------------
    def _sketch_control(self) -> None:
        """Phase 1 ends when no snaxel heads into an unvisited marked vertex (A21)."""
        self.stats.sketch_steps += 1
        dest = self.snake.ints[:, V]
        if np.any(self.marked[dest] & ~self.snake.blocked[dest]):
            return
        self.phase = "grow"
        whole = self._new_curve(cluster=0)
        self.snake.ints[:, CURVE] = whole
        self.snake.flts[:, T] = 0.0
        self.cluster_start = self.stats.steps
        self.best_step = self.stats.steps

    def _cluster_control(self) -> None:
        cfg = self.cfg
        steps = self.stats.steps
        curve = self.snake.ints[:, CURVE]
        act = self.cluster_of[curve] == self.active
        reason = None
        if not act.any():
            reason = "vanished"
        else:
            tmax = float(self.snake.flts[act, T].max())
            if tmax >= self.g:
                reason = "reached"
            elif tmax >= self.best_t + cfg.guard_delta:
                self.best_t, self.best_step = tmax, steps
            elif steps - self.best_step > cfg.guard_steps:
                reason = "no progress"
            if reason is None and steps - self.cluster_start > cfg.cluster_max_steps:
                reason = "step cap"
        if reason is None:
            return
        self.stats.clusters_grown += 1
        if reason != "reached":
            self.stats.clusters_stalled += 1
        self.stats.cluster_log.append({"cluster": self.active, "end": reason, "steps": steps - self.cluster_start,
                                       "g": round(self.g, 3)})
        if self.stats.clusters_grown >= cfg.n_c:
            self.done = True
            return
        self._next_cluster()

    def _next_cluster(self) -> None:
        """A15/A17: seed from a random curve of the cluster just stopped with >= 3 snaxels,
        length >= c_min and not parked at the margin; else any such curve; else finish."""
        cfg = self.cfg
        snake = self.snake
        runs = self.runs()
        dest_free = ~snake.blocked[snake.ints[:, V]]
        free_count = np.bincount(runs.rid, dest_free, minlength=len(runs.starts))
        ok = (runs.count >= 3) & (runs.length >= cfg.c_min) & (free_count >= 3)
        cand = np.flatnonzero(ok & (self.cluster_of[runs.curve] == self.active)) if cfg.seed_from == "cluster" else []
        if len(cand) == 0:
            cand = np.flatnonzero(ok)
        if len(cand) == 0:
            self.stats.cluster_log.append({"cluster": self.active + 1, "end": "no seed curve left"})
            self.done = True
            return
        w = self.seed_weights(runs, cand)
        r = int(cand[int(self.rng_cluster.choice(len(cand), p=w))]) if w is not None else \
            int(cand[int(self.rng_cluster.integers(len(cand)))])
        self.active += 1
        cid = int(runs.curve[r])
        self.cluster_of[cid] = self.active
        t0 = float(self.rng_cluster.uniform(cfg.t_min, cfg.t_max))
        s0 = int(runs.starts[r])
        snake.flts[s0:s0 + int(runs.count[r]), T] = t0
        self.t_curve[cid] = t0
        self.g = float(self.rng_cluster.uniform(cfg.g_min, cfg.g_max))
        self.cluster_start = self.stats.steps
        self.best_t, self.best_step = t0, self.stats.steps

    def seed_weights(self, runs: Runs, cand: np.ndarray) -> np.ndarray | None:
        """Probabilities of the candidate seed curves under ``seed_policy`` (None: uniform, the
        thesis's rule). The thesis names the choice of the next cluster's seed curve as what decides
        the silhouette and leaves its control to future work (Chapter 5); here a curve's weight is
        exp(seed_bias * score), the score in [0, 1] measured on the curve's mid-point against the
        cloud's box: height above the base (towers), closeness to the centroid (compact heaps) or
        horizontal distance from the centroid (spreading sheets); or the user's ``guide`` (a field
        sampled at the mid-point, or closeness to guide strokes), ranged over the candidates."""
        policy, bias = self.cfg.seed_policy, self.cfg.seed_bias
        if policy == "uniform" or bias == 0.0 or len(cand) < 2:
            return None
        xy = self.snake.xy()
        mid = np.column_stack([np.bincount(runs.rid, xy[:, k], minlength=len(runs.starts)) for k in (0, 1)])
        mid = mid[cand] / runs.count[cand, None]
        lo, hi = xy.min(0), xy.max(0)
        size = np.maximum(hi - lo, 1e-9)
        centre = np.asarray(Polygon(xy).centroid.coords[0])
        if policy == "height":
            score = (mid[:, 1] - lo[1]) / size[1]
        elif policy == "centroid":
            score = 1.0 - np.hypot(*((mid - centre) / size).T) / np.sqrt(0.5)
        elif policy == "spread":
            score = np.abs(mid[:, 0] - centre[0]) / (0.5 * size[0])
        else:   # field / sketch: the user's guide, ranged over the candidates
            a = np.asarray(self.guide(mid), np.float64)
            span = float(a.max() - a.min())
            score = (a - a.min()) / span if span > 0 else np.ones(len(a))
        w = portable.exp(bias * (np.clip(score, 0.0, 1.0) - 1.0))
        return w / w.sum()

    # -- outputs ----------------------------------------------------------------------------
    def snapshot(self) -> None:
        if self.snapshots and self.snapshots[-1].step == self.stats.steps:
            return
        c = self.snake.ints[:, CURVE].copy()
        self.snapshots.append(Snapshot(self.stats.steps, self.snake.xy(), c, self.cluster_of[c].copy()))

    def run(self) -> "CloudGrowth":
        while self.step():
            pass
        return self

    def report(self) -> dict:
        xy = self.snake.xy()
        runs = self.runs(xy)
        s = self.snake
        return {
            "N_s": len(s), "N_v": int(self.topo.n_vertices), "steps": self.stats.steps,
            "births": s.births, "merges": s.merges, "holes": s.holes, "filled_vertices": s.filled,
            "hole_rule_disagreements": s.hole_rule_disagreements,
            "splits": self.stats.splits, "curve_merges": self.stats.curve_merges,
            "curves": int(len(runs.starts)), "clusters_grown": self.stats.clusters_grown,
            "clusters_stalled": self.stats.clusters_stalled, "sketch_steps": self.stats.sketch_steps,
            "area": signed_area(xy), "perimeter": runs.perimeter,
            "bbox": [float(xy[:, 0].min()), float(xy[:, 1].min()), float(xy[:, 0].max()), float(xy[:, 1].max())],
            **shape_statistics(xy),
            **self.boundary_cut(runs.perimeter),
            **bump_statistics(xy, float(self.topo.min_edge), 4.0 * float(self.limits.limits[-1])),
            **self.raster_history(),
        }

    def boundary_cut(self, perimeter: float) -> dict:
        """The straight cut where the growth met the domain margin or the condensation level
        (Figure 3.22): ``cut_length`` is the outline length of the longest run of consecutive
        snaxels stopped on one boundary line (0: the growth never reached one), ``cut_snaxels``
        how many snaxels sit on a boundary line."""
        snake = self.snake
        n = len(snake)
        idx = np.flatnonzero(snake.blocked[snake.ints[:, V]])
        cap, which = self.stop_lines(idx)
        line = np.full(n, -1, np.int64)
        on = (which >= 0) & (snake.flts[idx, POS] >= cap)
        line[idx[on]] = which[on]
        xy = snake.xy()
        nxt = np.roll(np.arange(n), -1)
        seg = np.hypot(*(xy[nxt] - xy).T)
        along = (line >= 0) & (line == line[nxt])        # segment i -> i+1 lies on one boundary line
        best = 0.0
        if along.all():
            best = perimeter
        elif along.any():
            k = int(np.flatnonzero(~along)[0])           # walk from a segment off the line: no run wraps
            a = np.roll(along, -k)
            w = np.roll(seg, -k)
            cum = np.concatenate([[0.0], np.cumsum(np.where(a, w, 0.0))])
            starts = np.flatnonzero(a & ~np.roll(a, 1))
            ends = np.flatnonzero(a & ~np.roll(a, -1)) + 1
            best = float((cum[ends] - cum[starts]).max())
        return {"cut_length": round(best, 3), "cut_snaxels": int(on.sum())}

    def raster_history(self) -> dict:
        """Area and perimeter of every recorded contour at a fixed pixel, the Poisson radius
        (:func:`.fractal.raster_area_perimeter`, for Lovejoy's D over an ensemble)."""
        eps = float(self.topo.min_edge)
        ap = np.array([raster_area_perimeter(s.xy, eps) for s in self.snapshots]).reshape(-1, 2)
        return {"area_history": np.round(ap[:, 0], 3).tolist(), "perimeter_history": np.round(ap[:, 1], 3).tolist(),
                "raster_pixel": eps}


def shape_statistics(xy: np.ndarray) -> dict[str, float]:
    """Aspect ratio (box width / height) and solidity (area / convex-hull area) of an outline:
    the two numbers the cloud-type presets are held to."""
    poly = Polygon(xy)
    w, h = np.ptp(xy, axis=0)
    return {"aspect": round(float(w / h), 4), "solidity": round(float(poly.area / poly.convex_hull.area), 4)}
