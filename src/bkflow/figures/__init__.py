"""Figures of a sweep directory (the paper's, one module per family) and of one run's fronts.

``registry`` lists the figures ``bkflow plot`` draws and writes them; ``data`` reads a sweep's
tables and runs for them, ``style`` and ``keys`` hold what every figure shares (its look, its
markers and keys); ``friction``, ``order``, ``clusters``, ``drops`` and ``contacts`` draw the
figure families; ``fronts`` draws one run's rupture fronts.
"""
