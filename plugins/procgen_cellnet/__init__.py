"""procgen_cellnet: cellular networks (seed 002, "Generating Surface Textures based on Cellular
Networks", GMAI 2006): free cells seeded on any polygons, a boundless sparse box index, distance
links, general states, and the paper's behaviours (colour, cracks, corrosion, watercolour,
melting, activator/inhibitor) on one network at once.
"""
