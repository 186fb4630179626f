"""Figures of a sweep directory (the paper's, one module per family) and of one run's fronts.

``catalogue`` lists the figures ``bkflow plot`` draws and ``writer`` writes them
(``registry``: the documented path of both); ``data`` reads a sweep's tables and runs for
them, ``style`` and ``legends`` hold what every figure shares (its look, its markers, its
legends); ``friction``, ``order``, ``clusters``, ``drops`` and ``contacts`` draw the
figure families; ``fronts`` draws one run's rupture fronts.
"""
