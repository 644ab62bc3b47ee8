"""grayscott.react: U + 2V -> 3V with feed F and kill k, both chemicals diffusing on a Grid."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, Grid, RuleBase, State, param


def laplacian(a: np.ndarray) -> np.ndarray:
    """5-point Laplacian with periodic borders (unit cell spacing)."""
    return np.roll(a, 1, 0) + np.roll(a, -1, 0) + np.roll(a, 1, 1) + np.roll(a, -1, 1) - 4 * a


@dataclass(kw_only=True)
class GrayScott(RuleBase):
    """Gray-Scott reaction-diffusion: two chemicals whose feed/kill rates choose the pattern.

    du/dt = Du lap(u) - u v^2 + F (1 - u);  dv/dt = Dv lap(v) + u v^2 - (F + k) v.
    Explicit Euler; stable for dt * max(Du, Dv) <= 0.25.
    """

    name: ClassVar[str] = "grayscott.react"
    creates: ClassVar[dict[str, str]] = {"{grid}": "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("chemical__u", "{grid}", "cell", "out", doc="substrate concentration"),
        FieldSpec("chemical__v", "{grid}", "cell", "out", doc="activator concentration"),
    )
    default_iterations: ClassVar[int] = 2000
    example: ClassVar[tuple[dict, ...]] = ({"rule": "grayscott.react", "params": {"size": 32}, "iterations": 20},)

    grid: str = param("chemicals", doc="name of the Grid to create")
    size: int = param(128, ge=8, le=4096, units="cells", doc="grid cells per side")
    feed: float = param(0.055, ge=0.0, le=0.1, units="1/step", doc="feed rate F")
    kill: float = param(0.062, ge=0.0, le=0.1, units="1/step", doc="kill rate k")
    du: float = param(0.16, gt=0.0, le=1.0, units="cell^2/step", doc="diffusion of u")
    dv: float = param(0.08, gt=0.0, le=1.0, units="cell^2/step", doc="diffusion of v")
    dt: float = param(1.0, gt=0.0, le=1.0, units="step", doc="time step")
    seeds: int = param(12, ge=1, le=1000, doc="square patches of v seeded at random")

    def validate(self) -> None:
        if self.dt * max(self.du, self.dv) > 0.25 + 1e-12:
            raise ValueError(f"dt*max(du, dv) = {self.dt * max(self.du, self.dv):g} > 0.25 is unstable")

    def memory_estimate(self) -> int:
        return self.size * self.size * 8 * 10

    def setup(self, state: State) -> None:
        rng = state.rng()
        n = self.size
        u, v = np.ones((n, n)), np.zeros((n, n))
        r = max(2, n // 24)
        for cy, cx in rng.integers(r, n - r, size=(self.seeds, 2)):
            u[cy - r:cy + r, cx - r:cx + r] = 0.5
            v[cy - r:cy + r, cx - r:cx + r] = 0.25
        v += 0.01 * rng.random((n, n))
        g = Grid((n, n))
        g.add_field("chemical__u", u, at="cell", doc="substrate")
        g.add_field("chemical__v", v, at="cell", doc="activator")
        state.add_domain(self.grid, g)

    def step(self, state: State) -> bool:
        g = state.get(self.grid, Grid)
        u, v = g["chemical__u"], g["chemical__v"]
        uvv = u * v * v
        du = self.du * laplacian(u) - uvv + self.feed * (1 - u)
        dv = self.dv * laplacian(v) + uvv - (self.feed + self.kill) * v
        u += self.dt * du
        v += self.dt * dv
        return bool(np.abs(dv).max() > 1e-9)
