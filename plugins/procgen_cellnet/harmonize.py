"""Harmonizing a network: attraction/repulsion along links, release, best-link pruning (sec. 4.4).

Equation (1) is garbled in the source: "F = (k/(cs ri)) d^2 - ((k + a cs^2)/cs) d + k" with an
undefined a.  Taking a = k/(cs ri) (the d^2 coefficient) makes it factor exactly into

    F(d) = k / (cs ri) * (d - cs) * (d - ri)        for d < dmax; the link is released otherwise

F(0) = k (the maximum repulsion), F = 0 at the rest length cs and at ri, attraction in between
(Figure 7's parabola), repulsion again beyond ri.  F > 0 pushes the pair apart.  The summed
pair forces move each cell by dt * F (explicit Euler, the step the paper leaves open), kept in
the cell's tangent plane; sleeping cells stay fixed.  With ``surface`` set, every moved cell
is put back at its closest point on the source polygons after each step (the paper is silent:
tangent moves alone lift cells off a curved surface) and takes the surface's normal there, face
or interpolated as the network was seeded (section 3.3), so the next step's tangent plane and
the splats follow the surface under the cell's new position.  Afterwards each cell keeps its lg best
links (smallest |d - cs|; lg = 4/8, 6, 3 for square, triangle, hexagon, 6 for random),
``mutual`` keeping a link only if both ends keep it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, State, TriMesh, param

from .cellrule import CellRule
from .projection import closest_on_mesh

from .seeding import DEGREE, surface_normals


def force(d: np.ndarray, cs: float, ri: float, k: float) -> np.ndarray:
    """Equation (1) as reconstructed: k/(cs ri) (d - cs)(d - ri)."""
    return k / (cs * ri) * (d - cs) * (d - ri)


def force_literal(d: np.ndarray, cs: float, ri: float, k: float) -> np.ndarray:
    """The extracted polynomial with a = k/(cs ri): equal to :func:`force` (tested)."""
    a = k / (cs * ri)
    return k / (cs * ri) * d ** 2 - (k + a * cs ** 2) / cs * d + k


def harmonize_step(positions: np.ndarray, normals: np.ndarray, links: np.ndarray, movable: np.ndarray,
                   cs: float, ri: float, k: float, dmax: float, dt: float, tangent: bool):
    """(new positions, surviving links, displacement) after one Euler step of Equation (1)."""
    i, j = links[:, 0], links[:, 1]
    v = positions[j] - positions[i]
    d = np.sqrt(np.einsum("ij,ij->i", v, v))
    keep = d < dmax
    i, j, v, d = i[keep], j[keep], v[keep], d[keep]
    f = (force(d, cs, ri, k) / np.maximum(d, 1e-12))[:, None] * v   # along i -> j
    n = len(positions)
    ends = np.concatenate([i, j])
    disp = np.column_stack([np.bincount(ends, np.concatenate([-f[:, c], f[:, c]]), minlength=n)
                            for c in range(3)])
    if tangent:
        disp -= np.einsum("ij,ij->i", disp, normals)[:, None] * normals
    disp[~movable] = 0.0
    disp *= dt
    return positions + disp, links[keep], disp


@dataclass(kw_only=True)
class NetworkHarmonization(CellRule):
    """Harmonize cell spacing with Equation (1)'s attraction/repulsion; release links >= dmax."""

    name: ClassVar[str] = "cellnet.harmonize"
    default_iterations: ClassVar[int] = 300
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "plane", "size": 10.0, "subdivisions": 1}},
        {"rule": "cellnet.seed", "params": {"cs": 1.0, "grid": "random"}},
        {"rule": "cellnet.link"},
        {"rule": "cellnet.harmonize", "iterations": 5},)

    k: float = param(1.0, gt=0.0, doc="maximum repulsion F(0)")
    dmax: float = param(2.0, gt=0.0, units="cs", doc="links at least this long are released")
    dt: float = param(0.2, gt=0.0, le=1.0, units="cs/k", doc="Euler step")
    tol: float = param(1e-3, ge=0.0, units="cs", doc="stable when no cell moves more than this")
    tangent: bool = param(True, doc="move cells in their tangent planes only")
    surface: str | None = param(None, doc="TriMesh domain (the source polygons): put every moved "
                                "cell back at its closest point on it after each step, with the "
                                "surface's normal there")

    def field_specs(self) -> list[FieldSpec]:
        """Re-projection also re-normals the moved cells."""
        if self.surface is None:
            return []
        return [FieldSpec("cell__normal", domain=self.cells, at="cell", intent="out", doc="unit normal")]

    def domains_used(self) -> dict[str, str]:
        used = super().domains_used()
        if self.surface is not None:
            used[self.surface] = "TriMesh"
        return used

    def step(self, state: State) -> bool:
        net = self.network(state)
        send, update = self.gates(net)
        cs = net.cs
        pos, links, disp = harmonize_step(net.positions, net.normals(), net.links, update, cs,
                                          net.radius, self.k, self.dmax * cs, self.dt * cs / self.k,
                                          self.tangent)
        nrm = None
        if self.surface is not None:
            mesh = state.get(self.surface, TriMesh)
            moved = np.any(disp != 0, axis=1)
            q, face, _ = closest_on_mesh(pos[moved], mesh.vertices, mesh.faces)
            pos[moved] = q
            disp = pos - net.positions
            nrm = net.normals().copy()
            nrm[moved] = surface_normals(mesh.vertices, mesh.faces, face, q, net.normal_mode,
                                         mesh.vertex_normals if net.normal_mode == "vertex" else None)
        out = net.with_positions(pos)
        if nrm is not None:
            out.add_field("cell__normal", nrm, at="cell", doc="unit normal")
        if len(links) != net.n_links:
            out = out.with_links(links)
        state.add_domain(self.cells, out)
        dev = np.abs(out.link_lengths - cs)
        state.report(f"{self.cells}.mean_link_error", float(dev.mean()) / cs if len(dev) else 0.0)
        return float(np.abs(disp).max(initial=0)) > self.tol * cs or len(links) != net.n_links


def prune_links(positions: np.ndarray, links: np.ndarray, cs: float, lg: int, mode: str) -> np.ndarray:
    """Keep each cell's lg best links (smallest |d - cs|): both ends (mutual) or either (union)."""
    if len(links) == 0:
        return links
    v = positions[links[:, 1]] - positions[links[:, 0]]
    err = np.abs(np.sqrt(np.einsum("ij,ij->i", v, v)) - cs)
    m = len(links)
    ends = np.concatenate([links[:, 0], links[:, 1]])
    lid = np.tile(np.arange(m), 2)
    order = np.lexsort((lid, np.tile(err, 2), ends))
    e = ends[order]
    first = np.ones(len(e), bool)
    first[1:] = e[1:] != e[:-1]
    rank = np.arange(len(e)) - np.maximum.accumulate(np.where(first, np.arange(len(e)), 0))
    ok = np.zeros(2 * m, bool)
    ok[order] = rank < lg
    a, b = ok[:m], ok[m:]
    return links[(a & b) if mode == "mutual" else (a | b)]


@dataclass(kw_only=True)
class LinkPruning(CellRule):
    """Keep only the best lg links of every cell (section 4.4 step 3)."""

    name: ClassVar[str] = "cellnet.prune"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "plane", "size": 10.0, "subdivisions": 1}},
        {"rule": "cellnet.seed", "params": {"cs": 1.0, "grid": "random"}},
        {"rule": "cellnet.link"},
        {"rule": "cellnet.prune"},)

    lg: int | None = param(None, ge=1, le=64, doc="links kept per cell (default from the grid)")
    mode: str = param("mutual", choices=("mutual", "union"),
                      doc="a link survives if both ends keep it (mutual) or either (union)")

    def step(self, state: State) -> bool:
        net = self.network(state)
        lg = self.lg if self.lg is not None else DEGREE[net.grid]
        links = prune_links(net.positions, net.links, net.cs, lg, self.mode)
        state.add_domain(self.cells, net.with_links(links))
        state.report(f"{self.cells}.n_links", len(links))
        return False



