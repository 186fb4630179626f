"""Figures of a sweep directory (the paper's, one module per family) and of one run's fronts."""
