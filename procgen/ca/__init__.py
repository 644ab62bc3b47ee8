"""Cellular-automaton machinery shared by the plugins: mechanisms only, no phenomenon.

The cell-domain protocol (:mod:`.cells`: any domain that hands out a CellGraph), the one
neighbour graph (:mod:`.graph`), connected regions and hop distances over it
(:mod:`.components`), the rule bases (:mod:`.automaton`), coverage curves
(:mod:`.coverage`) and the generic rules that run on every cell domain: outer-totalistic binary
rules (:mod:`.lifelike`, ``ca.life``), seeded multi-label propagation (:mod:`.propagation`,
``ca.voronoi``) and majority votes (:mod:`.majority`, ``ca.majority``).  Models written on them
(corrosion, weathering, ...) live in their family plugins.
"""
