"""Cellular-automaton machinery shared by the plugins: neighbour graphs and model kernels.

The cell-domain protocol (:mod:`.cells`: any domain that hands out a CellGraph), generic
stepping (:mod:`.graph`) and the attack/defence corrosion kernel (:mod:`.corrosion`)
that both the 2.5-D surface plugin and the mesh-surface plugin run, each on its own graph.
"""
