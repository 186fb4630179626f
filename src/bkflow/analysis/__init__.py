"""A run's records turned into its summary: the observables' registry (every summary key with
its unit and meaning, declared once) and summarize, which fills it."""
