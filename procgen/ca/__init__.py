"""Cellular-automaton machinery shared by the plugins: mechanisms only, no phenomenon.

The cell-domain protocol (:mod:`.cells`: any domain that hands out a CellGraph), generic
stepping (:mod:`.graph`) and coverage curves (:mod:`.coverage`).  Models written on them
(corrosion, Voronoi growth, ...) live in their family plugins.
"""
