"""A run's records turned into its summary: the summary's keys, each declared once with the
observable that computes it (``summary_keys``), and summarize, which computes them."""
