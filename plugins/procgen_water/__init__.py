"""procgen_water: built-in procgen rule plugin (registered through the 'procgen' entry point)."""
