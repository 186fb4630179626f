"""Running LAMMPS: the deck's text, loading the plugin, the engine that runs a deck in chunks
with its stop rule, and the limits a run is checked against before it starts."""
