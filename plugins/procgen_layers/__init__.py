"""procgen_layers: the layered-materials family (material table, layer stack on any cell domain,
attack/defence corrosion, light through layers), registered through the 'procgen' entry point."""
