"""Cellular-automaton machinery shared by the plugins: neighbour graphs, generic rules, kernels.

The cell-domain protocol (:mod:`.cells`: any domain that hands out a CellGraph), the one
neighbour graph (:mod:`.graph`), the rule bases (:mod:`.automaton`) and the generic rules that
run on every cell domain: outer-totalistic binary rules (:mod:`.lifelike`, ``ca.life``), seeded
multi-label propagation (:mod:`.propagation`, ``ca.voronoi``) and majority votes
(:mod:`.majority`, ``ca.majority``); plus the attack/defence corrosion kernel (:mod:`.corrosion`)
that both layered plugins run, each on its own graph.
"""
