"""procgen_wood: wood weathering on surface cells (built-in procgen rule plugin).

Chidtavong, "Wood weathering simulation with 3 dimensional surface cellular automata" (KMITL,
2007): a procedural wood grain (thesis 3.1), a Life-like CA on 3DSCA cells whose per-cell value
picks a colour by range (thesis 3.2, 4.3.3), the two combined by modulation (thesis 4.3.4), and,
beyond the thesis, exposure-driven ageing from sun and rain.
"""
