"""procgen_cracks: cracks and peeling of layered surfaces (built-in procgen rule plugin).

Hybrid 3DSCA, chapter 5 of the surface-cellular-automata thesis (seed 000): a directional
stress spectrum per cell and layer, crack modules that walk across the cells and release the
stress around their path, crack rendering with the crack-mirror effect, and peeling of the
groups of cells that the cracks cut out. The layers are the ``procgen_layers`` stack on the
surface cells of ``procgen_surface``; the cell-to-cell stepping is the core's CA layer.
Recipes live with the other surface-cell plates (``rules/meshes``); this plugin ships its
gallery list.
"""
