"""The time per step of the fused path on P ranks: a model, fitted to this machine, and what it
predicts past it (benchmarks/RESULTS.md, "The fused path on many ranks").

Each of P ranks holds a block of N / P atoms in whole rows of an Lx x Ly lattice and, every
step, trades its first and last rows with its two neighbours (two MPI_Sendrecv of 2 Lx
doubles each way). The model of one step:

    t_P = a N / P + o + [P > 1] (2 lam + 32 Lx / bw + g0 + g1 Lx)

  a         compute per atom-step (the kernel), o the loop's fixed cost per step (LAMMPS's
            Verlet, the fix's calls): both fitted to one rank, t_1 = a N + o;
  lam, bw   latency per exchange and bandwidth: fitted to the halo time the fix itself
            measures on two ranks (its log line; 32 Lx bytes leave each rank per step);
  g0, g1    what else two ranks cost per step (LAMMPS's own forward communication of the ghost
            atoms of the bond check, about one row each side, and the wait for the slower
            rank): fitted to the rest of t_2.

Past this machine the exchange's lam and bw are those of the network the boundary crosses:
inside a node, the fitted ones (shared memory); between nodes, NETWORK below (an assumption,
stated where it is used: a 100 Gb/s InfiniBand link). The slowest rank sets the step, so on
several nodes every step pays one inter-node exchange.

    python benchmarks/scaling_model.py     # the fit of MEASURED and the predictions

MEASURED is the last line of ``python benchmarks/throughput.py --scaling`` (benchmarks/
RESULTS.md has the run it comes from).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: (Lx, N, t_1 s/step, t_2 s/step, halo s/step) of `throughput.py --scaling`, this machine
MEASURED = []

#: the inter-node link assumed past one node: latency (s) and bandwidth (bytes/s) of one
#: exchange, a 100 Gb/s InfiniBand link as MPI sees it
NETWORK = (2.0e-6, 10.0e9)
#: cores of one node in the predictions
NODE = 64


@dataclass(frozen=True)
class Model:
    a: float      # s per atom-step
    o: float      # s per step, fixed
    lam: float    # s per exchange (latency)
    bw: float     # bytes/s
    g0: float     # s per step, other costs of several ranks
    g1: float     # s per step per row atom, other costs of several ranks

    def halo(self, Lx, lam=None, bw=None):
        """the two exchanges of one step"""
        lam = self.lam if lam is None else lam
        bw = self.bw if bw is None else bw
        return 2.0 * lam + 32.0 * Lx / bw

    def step(self, N, Lx, P, lam=None, bw=None):
        """seconds per step of an N-atom lattice Lx wide on P ranks"""
        t = self.a * N / P + self.o
        if P > 1:
            t = t + self.halo(Lx, lam, bw) + self.g0 + self.g1 * Lx
        return t


def fit(measured) -> Model:
    """least squares (numpy.linalg.lstsq) of each part on its own measurements"""
    m = np.asarray(measured, dtype=float)
    Lx, N, t1, t2, h = m.T
    (a, o), *_ = np.linalg.lstsq(np.column_stack([N, np.ones_like(N)]), t1, rcond=None)
    (c0, c1), *_ = np.linalg.lstsq(np.column_stack([np.ones_like(Lx), Lx]), h, rcond=None)
    rest = t2 - (a * N / 2 + o) - h
    (g0, g1), *_ = np.linalg.lstsq(np.column_stack([np.ones_like(Lx), Lx]), rest, rcond=None)
    return Model(a=a, o=o, lam=c0 / 2.0, bw=32.0 / c1 if c1 > 0 else np.inf, g0=g0, g1=g1)


def strong(model: Model, N: int, Lx: int, ranks) -> list[tuple[int, float, float, float]]:
    """(P, s/step, speed-up over one rank, efficiency) for each P; P beyond NODE pays one
    inter-node exchange per step (NETWORK)"""
    t1 = model.step(N, Lx, 1)
    out = []
    for P in ranks:
        net = NETWORK if P > NODE else (None, None)
        t = model.step(N, Lx, P, *net)
        out.append((P, t, t1 / t, t1 / t / P))
    return out


def stops(model: Model, N: int, Lx: int, limit: int) -> int:
    """the largest P (a power of 2, <= limit) past which one more doubling gains less than 10%
    (beyond NODE ranks with the inter-node exchange)"""
    def t(P):
        return model.step(N, Lx, P, *(NETWORK if P > NODE else (None, None)))
    P = 1
    while 2 * P <= limit and t(P) / t(2 * P) > 1.1:
        P *= 2
    return P


def main() -> None:
    if not MEASURED:
        raise SystemExit("MEASURED is empty: paste the last line of "
                         "`python benchmarks/throughput.py --scaling`")
    mdl = fit(MEASURED)
    print(f"a = {mdl.a * 1e9:.2f} ns/atom-step, o = {mdl.o * 1e6:.2f} us/step, "
          f"lam = {mdl.lam * 1e6:.2f} us/exchange, bw = {mdl.bw / 1e9:.2f} GB/s, "
          f"g0 = {mdl.g0 * 1e6:.2f} us/step, g1 = {mdl.g1 * 1e9:.2f} ns/step per row atom\n")
    print("| lattice | N | t_1 measured | model | t_2 measured | model | halo measured | model |")
    print("|---|---|---|---|---|---|---|---|")
    for Lx, N, t1, t2, h in MEASURED:
        print(f"| {Lx:.0f}x{N / Lx:.0f} | {N:.0f} | {t1 * 1e6:.1f} us | "
              f"{mdl.step(N, Lx, 1) * 1e6:.1f} | {t2 * 1e6:.1f} us | "
              f"{mdl.step(N, Lx, 2) * 1e6:.1f} | {h * 1e6:.2f} us | {mdl.halo(Lx) * 1e6:.2f} |")
    N, Lx = 2000 * 500, 2000    # 10^6 atoms, the paper's 4:1 aspect
    print(f"\nstrong scaling, N = {N} ({Lx}x{N // Lx}); past {NODE} ranks, {NODE} a node with "
          f"one inter-node exchange a step (lam = {NETWORK[0] * 1e6:g} us, "
          f"bw = {NETWORK[1] / 1e9:g} GB/s, assumed)\n")
    print("| P | us/step | speed-up | efficiency |")
    print("|---|---|---|---|")
    for P, t, s, e in strong(mdl, N, Lx, [1, 2, 4, 8, 16, 32, 64, 128, 256]):
        print(f"| {P} | {t * 1e6:.1f} | {s:.1f} | {e:.2f} |")
    print(f"\nweak scaling, 14400 atoms a rank: Lx fixed at 240 (blocks of 60 rows), and the "
          f"4:1 aspect kept (Lx grows as sqrt(P))\n")
    print("| P | us/step, Lx = 240 | efficiency | Lx at 4:1 | us/step | efficiency |")
    print("|---|---|---|---|---|---|")
    base = mdl.step(14400, 240, 1)
    for P in [1, 2, 4, 16, 64, 256]:
        net = NETWORK if P > NODE else (None, None)
        t_fixed = mdl.step(14400 * P, 240, P, *net)
        lx = int(round(2 * np.sqrt(14400 * P)))
        t_aspect = mdl.step(14400 * P, lx, P, *net)
        print(f"| {P} | {t_fixed * 1e6:.1f} | {base / t_fixed:.2f} | {lx} | "
              f"{t_aspect * 1e6:.1f} | {base / t_aspect:.2f} |")
    print(f"\nwhere doubling P stops paying 10% (N = {N}): one node, P = "
          f"{stops(mdl, N, Lx, NODE)}; four nodes, P = {stops(mdl, N, Lx, 4 * NODE)}")


if __name__ == "__main__":
    main()
