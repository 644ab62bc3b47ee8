"""Melting: every cell moves to the mean of itself and its sending neighbours (Table 1, Figure 12).

Table 1 "Melting-like": v <- (v + sum v_n) / (k + 1) for positions and normals (normals then
renormalised).  This is umbrella Laplacian smoothing (step k/(k+1)), so small details vanish
first and the shape shrinks (Figure 12; section 5.2: the last frame after a "nightlong" melt).
Links stay fixed; the network's box indexes follow the moved cells incrementally.  Sleeping
cells stay where they are (anchored, partial melting); with all cells active and symmetric
links, sum (k_i + 1) x_i is conserved (tested).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, State, param

from .cellrule import EXAMPLE_NET, CellRule, Next


def melt_step(net, send: np.ndarray, update: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(positions, normals) at t + 1: two products with the precomputed sending matrix."""
    g, k = net.sending(send)
    n = net.normals()
    pos = g @ net.positions
    pos += net.positions
    pos *= (1 / (k + 1))[:, None]
    nn = g @ n
    nn += n
    ln = np.sqrt(np.einsum("ij,ij->i", nn, nn))
    nn *= (1 / np.maximum(ln, 1e-300))[:, None]
    keep = ~update[:, None] | (ln <= 1e-12)[:, None]      # a cancelled normal keeps its own
    np.copyto(nn, n, where=keep)
    if not update.all():
        np.copyto(pos, net.positions, where=~update[:, None])
    return pos, nn


@dataclass(kw_only=True)
class MeltingAverage(CellRule):
    """Melting: positions and normals averaged over the cell and its sending neighbours."""

    name: ClassVar[str] = "cellnet.melt"
    default_iterations: ClassVar[int] = 10
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("cell__normal", domain="{cells}", at="cell", intent="out", doc="unit normal"),)
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 2}},
        {"rule": "cellnet.seed", "params": {"target_cells": 400}},
        {"rule": "cellnet.link"},
        {"rule": "cellnet.melt", "iterations": 3},)

    tol: float = param(1e-9, ge=0.0, units="cs", doc="stable when no cell moves more than this")

    def advance(self, net, send: np.ndarray, update: np.ndarray) -> Next:
        pos, nrm = melt_step(net, send, update)
        return Next(update, {"cell__normal": nrm}, pos)

    def step(self, state: State) -> bool:
        net = self.network(state)
        nxt = self.advance(net, *self.gates(net))
        self.commit(state, net, nxt)
        return float(np.abs(nxt.positions - net.positions).max(initial=0)) > self.tol * net.cs
