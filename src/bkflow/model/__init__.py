"""What a run is: its parameters (RunSpec, presets, the analysis settings) and the lattice,
checked on construction. Depends on nothing else of bkflow."""
