"""The time per step of the fused path on P ranks: a model, fitted to this machine, and what it
predicts past it (benchmarks/RESULTS.md's blocks scaling and scaling-model are generated from
MEASURED and this model).

Each of P ranks holds a block of n = N / P atoms in whole rows of an Lx x Ly lattice and,
every step, trades its first and last rows with its two neighbours (32 Lx bytes leave each
rank, in two messages). The model of one step:

    t_P = c(n) n (1 + kappa [P > 1]) + [P > 1] (2 lam + 32 Lx / bw)

  c(n)      the compute per atom-step of one rank holding n atoms: measured on one rank at
            each lattice and interpolated in log n (it is not a constant: it grows once a
            rank's arrays, about 240 bytes an atom, leave the caches; held at the end values
            outside the measured range);
  kappa     what the ranks lose meeting every step, in proportion to their compute (each waits
            for the slower one: the jitter of a step scales with the step);
  lam, bw   the latency of one exchange and the bandwidth.

kappa, lam and 1/bw are fitted (non-negative least squares, scipy.optimize.nnls, in relative
terms) to the time of two fused ranks beside one. Past this machine the exchanges crossing a
node boundary have NETWORK's latency and bandwidth (an assumption, stated where it is used);
the slowest rank sets the step, so on several nodes every step pays one inter-node exchange.
What this machine cannot tell: c(n) on a 64-core node, whose ranks share the memory bandwidth
(here two ranks did not slow each other: benchmarks/RESULTS.md).

    python -m benchmarks.report.scaling_model     # the fit of MEASURED and the predictions

MEASURED is the last line of ``python -m benchmarks.measure.throughput --scaling``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from benchmarks.harness import parser

#: (Lx, N, t_1 s/step, t_2 s/step, halo s/step) of `measure/throughput.py --scaling`, this
#: machine (2026-11-24, bkflow 0.3.0)
MEASURED = [(60.0, 900.0, 5.37206e-06, 6.35276e-06, 3.13e-06),
            (120.0, 3600.0, 2.38575e-05, 1.60747e-05, 3.76e-06),
            (240.0, 14400.0, 9.53438e-05, 5.25592e-05, 4.89e-06),
            (480.0, 57600.0, 0.000460776, 0.000240901, 1.38e-05),
            (960.0, 230400.0, 0.00370687, 0.00215652, 0.000139)]

#: the inter-node link assumed past one node: latency (s) and bandwidth (bytes/s) of one
#: exchange, a 100 Gb/s InfiniBand link as MPI sees it
NETWORK = (2.0e-6, 10.0e9)
#: cores of one node in the predictions
NODE = 64


@dataclass(frozen=True)
class Model:
    n: tuple        # atoms of one rank at which c was measured
    c: tuple        # s per atom-step there
    kappa: float    # the ranks' meeting, a fraction of the compute
    lam: float      # s per exchange
    bw: float       # bytes/s

    def compute(self, n):
        """c(n) n: one rank's compute per step, holding n atoms"""
        c = np.interp(np.log(n), np.log(self.n), self.c)
        return c * n

    def halo(self, Lx, lam=None, bw=None):
        """the two exchanges of one step"""
        lam = self.lam if lam is None else lam
        bw = self.bw if bw is None else bw
        return 2.0 * lam + 32.0 * Lx / bw

    def step(self, N, Lx, P, lam=None, bw=None):
        """seconds per step of an N-atom lattice Lx wide on P ranks"""
        t = self.compute(N / P)
        if P > 1:
            t = t * (1.0 + self.kappa) + self.halo(Lx, lam, bw)
        return t


def fit(measured) -> Model:
    m = np.asarray(sorted(measured, key=lambda r: r[1]), dtype=float)
    Lx, N, t1, t2, _ = m.T
    base = Model(n=tuple(N), c=tuple(t1 / N), kappa=0.0, lam=0.0, bw=np.inf)
    comp = np.array([base.compute(n / 2) for n in N])
    # relative residuals: each lattice counts alike
    A = np.column_stack([comp, 2.0 * np.ones_like(N), 32.0 * Lx]) / t2[:, None]
    (kappa, lam, inv_bw), _ = nnls(A, (t2 - comp) / t2)
    return Model(n=base.n, c=base.c, kappa=kappa, lam=lam,
                 bw=1.0 / inv_bw if inv_bw > 0 else np.inf)


def _net(P):
    return NETWORK if P > NODE else (None, None)


def strong(model: Model, N: int, Lx: int, ranks) -> list[tuple[int, float, float, float]]:
    """(P, s/step, speed-up over one rank, efficiency) for each P; P beyond NODE pays one
    inter-node exchange per step (NETWORK)"""
    t1 = model.step(N, Lx, 1)
    out = []
    for P in ranks:
        t = model.step(N, Lx, P, *_net(P))
        out.append((P, t, t1 / t, t1 / t / P))
    return out


def stops(model: Model, N: int, Lx: int, limit: int) -> int:
    """the largest P (a power of 2, <= limit) past which one more doubling gains less than 10%
    (beyond NODE ranks with the inter-node exchange)"""
    def t(P):
        return model.step(N, Lx, P, *_net(P))
    P = 1
    while 2 * P <= limit and t(P) / t(2 * P) > 1.1:
        P *= 2
    return P


def main(argv=None) -> None:
    parser(__doc__).parse_args(argv)
    if not MEASURED:
        raise SystemExit("MEASURED is empty: paste the last line of "
                         "`python -m benchmarks.measure.throughput --scaling`")
    mdl = fit(MEASURED)
    print("c(n), ns per atom-step on one rank: " + ", ".join(
        f"{c * 1e9:.2f} at n = {n:.0f}" for n, c in zip(mdl.n, mdl.c)))
    print(f"kappa = {mdl.kappa:.3f}, lam = {mdl.lam * 1e6:.2f} us/exchange, "
          f"bw = {mdl.bw / 1e9:.2f} GB/s\n")
    print("| lattice | N | t_2 measured | model | halo measured (waits included) | model |")
    print("|---|---|---|---|---|---|")
    for Lx, N, _t1, t2, h in sorted(MEASURED, key=lambda r: r[1]):
        print(f"| {Lx:.0f}x{N / Lx:.0f} | {N:.0f} | {t2 * 1e6:.1f} us | "
              f"{mdl.step(N, Lx, 2) * 1e6:.1f} | {h * 1e6:.2f} us | "
              f"{(mdl.halo(Lx) + mdl.kappa * mdl.compute(N / 2)) * 1e6:.2f} |")
    N, Lx = 2000 * 500, 2000    # 10^6 atoms, the paper's 4:1 aspect
    print(f"\nstrong scaling, N = {N} ({Lx}x{N // Lx}); past {NODE} ranks, {NODE} a node with "
          f"one inter-node exchange a step (lam = {NETWORK[0] * 1e6:g} us, "
          f"bw = {NETWORK[1] / 1e9:g} GB/s, assumed)\n")
    print("| P | atoms a rank | us/step | speed-up | efficiency |")
    print("|---|---|---|---|---|")
    for P, t, s, e in strong(mdl, N, Lx, [1, 2, 4, 8, 16, 32, 64, 128, 256]):
        print(f"| {P} | {N // P} | {t * 1e6:.1f} | {s:.1f} | {e:.2f} |")
    print("\nweak scaling, 14400 atoms a rank: Lx fixed at 240 (blocks of 60 rows), and the "
          "4:1 aspect kept (Lx grows as sqrt(P))\n")
    print("| P | us/step, Lx = 240 | efficiency | Lx at 4:1 | us/step | efficiency |")
    print("|---|---|---|---|---|---|")
    base = mdl.step(14400, 240, 1)
    for P in [1, 2, 4, 16, 64, 256]:
        t_fixed = mdl.step(14400 * P, 240, P, *_net(P))
        lx = int(round(2 * np.sqrt(14400 * P)))
        t_aspect = mdl.step(14400 * P, lx, P, *_net(P))
        print(f"| {P} | {t_fixed * 1e6:.1f} | {base / t_fixed:.2f} | {lx} | "
              f"{t_aspect * 1e6:.1f} | {base / t_aspect:.2f} |")
    # the same without the caches' gain: c held at its in-cache value (n = 14400), the
    # pessimistic reading for a node whose ranks share memory bandwidth
    flat = Model(n=(1.0,), c=(float(np.interp(np.log(14400), np.log(mdl.n), mdl.c)),),
                 kappa=mdl.kappa, lam=mdl.lam, bw=mdl.bw)
    print("\nwhere doubling P stops paying 10% (P a power of 2, at most one lattice row a rank): "
          "P, atoms a rank, and the share of the step that is not compute there (the exchanges "
          "and the ranks' meeting); in brackets, P with c held at its in-cache value (n = "
          "14400), the reading for a node whose ranks share the memory bandwidth\n")
    print("| N | lattice | one node | four nodes |")
    print("|---|---|---|---|")
    for n_, lx in ((14400, 240), (57600, 480), (230400, 960), (N, Lx)):
        ly = n_ // lx
        cells = []
        for limit in (NODE, 4 * NODE):
            P = stops(mdl, n_, lx, min(limit, ly))
            Pf = stops(flat, n_, lx, min(limit, ly))
            t = mdl.step(n_, lx, P, *_net(P))
            share = 1.0 - mdl.compute(n_ / P) / t
            why = " (rows)" if 2 * P > ly else ""
            cells.append(f"P = {P}{why}, {n_ // P} atoms, {100 * share:.0f}% [{Pf}]")
        print(f"| {n_} | {lx}x{ly} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
