"""Analysis functions on inputs whose answers are known exactly (docs/model.md, "Observables")."""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import j0, j1

from bkflow.model.lattice import box_extent, square_lattice
from bkflow.observables import clusters, order, stress
from bkflow.observables.stationarity import mean_error
from tests.support import fresh_python


def _rotate(v, angle):
    c, s = math.cos(angle), math.sin(angle)
    return v @ np.array([[c, s], [-s, c]])


# --- order -------------------------------------------------------------------------------

def test_perfect_lattice_has_psi_one():
    lat = square_lattice(20, 5)
    shifts = order.lattice_shifts(lat.positions, lat.bonds, lat.box)
    v = order.bond_vectors(lat.positions, lat.bonds, shifts=shifts)
    assert order.psi(v, lat.bonds, 100) == pytest.approx(1.0, abs=1e-14)
    # the same with the minimum image, and after a rigid shift of the whole layer
    vm = order.bond_vectors(lat.positions, lat.bonds, box=lat.box)
    np.testing.assert_allclose(vm, v, atol=1e-14)
    moved = lat.positions + np.array([83.25, -7.5])
    np.testing.assert_allclose(order.bond_vectors(moved, lat.bonds, shifts=shifts), v, atol=1e-12)


@pytest.mark.parametrize("angle", [0.1, math.pi / 7, 1.0, 2.5, -0.4])
def test_rotated_lattice_has_psi_one(angle):
    lat = square_lattice(8, 6)
    v = order.bond_vectors(lat.positions, lat.bonds, box=lat.box)
    assert order.psi(_rotate(v, angle), lat.bonds, 48) == pytest.approx(1.0, abs=1e-13)
    # rotating the positions themselves (a crystal in a large open region) gives the same
    r = _rotate(lat.positions, angle)
    rot_shifts = _rotate(order.lattice_shifts(lat.positions, lat.bonds, lat.box), angle)
    assert order.psi(order.bond_vectors(r, lat.bonds, shifts=rot_shifts), lat.bonds, 48) == \
        pytest.approx(1.0, abs=1e-13)


def _expected_abs_sum_of_unit_phasors(n):
    """W_n = E|sum of n unit vectors with independent uniform angles|.

    With phi_n(t) = J0(t)^n the characteristic function of the sum, E|S| = n * integral_0^inf
    J1(t) J0(t)^(n-1) dt / t (Borwein, Straub, Wan, Zudilin, Canad. J. Math. 64, 961 (2012),
    Eq. 2.1); W_2 = 4/pi, W_4 = 1.7990924...
    """
    f = lambda t: n * j1(t) * j0(t) ** (n - 1) / t  # noqa: E731
    total, a = 0.0, 0.0
    for _ in range(2000):  # integrate period by period: the integrand oscillates
        total += quad(f, a, a + math.pi, limit=200)[0]
        a += math.pi
    return total


def test_random_bond_angles_give_the_exact_expectation():
    """Each particle has 4 bonds with independent uniform angles theta, so 4*theta is uniform too
    and E Psi = W_4 / 4 = 0.44977 (docs/model.md's "about 0.45")."""
    w2 = _expected_abs_sum_of_unit_phasors(2)
    assert w2 == pytest.approx(4 / math.pi, rel=1e-6)  # the integral checks itself
    expected = _expected_abs_sum_of_unit_phasors(4) / 4
    assert expected == pytest.approx(1.7990924 / 4, abs=1e-6)
    lat = square_lattice(100, 100)
    rng = np.random.default_rng(11)
    theta = rng.uniform(0, 2 * math.pi, len(lat.bonds))
    length = rng.uniform(0.5, 1.5, len(lat.bonds))  # Psi ignores lengths
    v = np.column_stack([length * np.cos(theta), length * np.sin(theta)])
    assert order.psi(v, lat.bonds, lat.Lx * lat.Ly) == pytest.approx(expected, abs=0.01)


def test_psi_agrees_with_freud_hexatic():
    freud = pytest.importorskip("freud")
    lat = square_lattice(12, 8)
    rng = np.random.default_rng(3)
    r = lat.positions + rng.normal(0, 0.25, lat.positions.shape)
    v = order.bond_vectors(r, lat.bonds, box=lat.box)
    ours = order.particle_order(v, lat.bonds, 96)

    # freud's neighbour list: both directions of every bond, sorted by query point
    qi = np.concatenate([lat.bonds[:, 0], lat.bonds[:, 1]])
    pj = np.concatenate([lat.bonds[:, 1], lat.bonds[:, 0]])
    vec = np.concatenate([v, -v])
    srt = np.lexsort((pj, qi))
    vec3 = np.column_stack([vec[srt], np.zeros(len(srt))])
    nlist = freud.locality.NeighborList.from_arrays(96, 96, qi[srt], pj[srt], vec3)
    box = freud.box.Box(Lx=lat.Lx, Ly=lat.Ly, is2D=True)
    pts = np.column_stack([r - np.array(lat.box) / 2, np.zeros(96)])
    hex4 = freud.order.Hexatic(k=4).compute(system=(box, box.wrap(pts)), neighbors=nlist)
    theirs = np.asarray(hex4.particle_order)
    assert np.mean(np.abs(ours)) < 0.95  # disordered enough to mean something
    np.testing.assert_allclose(np.abs(ours), np.abs(theirs), atol=1e-5)
    assert order.psi(v, lat.bonds, 96) == pytest.approx(np.mean(np.abs(theirs)), abs=1e-5)


def test_psi_is_vectorised_over_frames():
    lat = square_lattice(6, 4)
    rng = np.random.default_rng(0)
    frames = lat.positions + rng.normal(0, 0.2, (5, 24, 2))
    shifts = order.lattice_shifts(lat.positions, lat.bonds, lat.box)
    many = order.psi(order.bond_vectors(frames, lat.bonds, shifts=shifts), lat.bonds, 24)
    one = [order.psi(order.bond_vectors(f, lat.bonds, shifts=shifts), lat.bonds, 24)
           for f in frames]
    np.testing.assert_allclose(many, one, rtol=1e-14)


def test_psi_inf_is_the_mean_of_the_last_fifth():
    t = np.arange(101.0)
    p = np.where(t >= 80, 0.5, 1.0)
    assert order.psi_inf(t, p) == 0.5
    assert order.psi_inf(t, np.where(t >= 90, 0.0, 1.0)) == pytest.approx(10 / 21)


def test_bond_vectors_needs_exactly_one_image_rule():
    lat = square_lattice(4, 4)
    with pytest.raises(ValueError, match="exactly one"):
        order.bond_vectors(lat.positions, lat.bonds)


# --- clusters ----------------------------------------------------------------------------

@pytest.mark.parametrize("Lx, Ly", [(20, 5), (40, 10), (7, 4)])
def test_full_system_cluster_spans_box(Lx, Ly):
    """The discreteness of docs/model.md's formula: on a ring of L sites the distances to the others
    sum to S(L) = L^2/4 (L even) or (L^2 - 1)/4 (L odd), so a cluster of the whole box has
    l_x = 4 Ly S(Lx) / (N - 1): Lx N/(N-1) for even Lx, times (1 - 1/Lx^2) for odd Lx."""
    lat = square_lattice(Lx, Ly)
    n = Lx * Ly
    labels = clusters.slip_clusters(np.ones(n, bool), lat.bonds)
    assert set(labels) == {0}
    ext = clusters.cluster_extents(lat.positions, labels, lat.box)
    ring = lambda L: (L * L - L % 2) / 4  # noqa: E731
    assert ext.l_x[0] == pytest.approx(4 * Ly * ring(Lx) / (n - 1), rel=1e-13)
    assert ext.l_y[0] == pytest.approx(4 * Lx * ring(Ly) / (n - 1), rel=1e-13)
    for ell, L in ((ext.l_x[0], Lx), (ext.l_y[0], Ly)):
        assert abs(ell / L - 1) <= 1 / (n - 1) + 1 / L ** 2


def test_full_row_has_no_transverse_extent():
    lat = square_lattice(20, 5)
    mask = np.zeros(100, bool)
    mask[40:60] = True  # row iy = 2
    ext = clusters.cluster_extents(lat.positions, clusters.slip_clusters(mask, lat.bonds), lat.box)
    assert len(ext) == 1 and ext.n_c[0] == 20
    assert ext.l_y[0] == 0.0
    assert ext.l_x[0] == pytest.approx(20 * 20 / 19, rel=1e-13)


def _block(lat, x0, y0, nx, ny):
    mask = np.zeros(lat.Lx * lat.Ly, bool)
    for dx in range(nx):
        for dy in range(ny):
            mask[(x0 + dx) % lat.Lx + lat.Lx * ((y0 + dy) % lat.Ly)] = True
    return mask


def test_wrapped_cluster_equals_the_same_cluster_inside_the_box():
    lat = square_lattice(20, 8)
    inside = _block(lat, 5, 2, 4, 3)
    across = _block(lat, 18, 6, 4, 3)  # wraps across both periodic boundaries
    li = clusters.slip_clusters(inside, lat.bonds)
    la = clusters.slip_clusters(across, lat.bonds)
    assert li.max() == 0 and la.max() == 0  # one connected cluster each, through the bonds
    ei = clusters.cluster_extents(lat.positions, li, lat.box)
    ea = clusters.cluster_extents(lat.positions, la, lat.box)
    assert ea.n_c[0] == ei.n_c[0] == 12
    assert ea.l_x[0] == pytest.approx(ei.l_x[0], rel=1e-13)
    assert ea.l_y[0] == pytest.approx(ei.l_y[0], rel=1e-13)
    # unwrapped positions (atoms carried around the box) give the same extents
    unwrapped = lat.positions + np.array([[20.0, 8.0]]) * (np.arange(160) % 3)[:, None]
    eu = clusters.cluster_extents(unwrapped, la, lat.box)
    assert eu.l_x[0] == pytest.approx(ei.l_x[0], rel=1e-12)


def test_pair_sum_matches_the_direct_double_sum():
    rng = np.random.default_rng(5)
    for n, L in [(2, 5.0), (3, 7.0), (57, 20.0), (400, 13.0)]:
        x = rng.uniform(-30, 30, n)
        d = np.abs(x[:, None] - x[None, :])
        d = np.minimum(d % L, L - d % L)
        assert clusters.periodic_pair_sum(x, L) == pytest.approx(d.sum() / 2, rel=1e-12)
    # points exactly half a box apart count L/2 once
    assert clusters.periodic_pair_sum([0.0, 5.0], 10.0) == 5.0


def test_slipping_is_signed_and_clusters_follow_the_bonds():
    lat = square_lattice(10, 4)
    x0 = lat.positions
    x1 = x0.copy()
    x1[[0, 1, 2], 0] += 0.05      # a row fragment moving forward: one cluster of 3
    x1[[25, 35], 0] += 0.5        # two particles bonded in y: one cluster of 2
    x1[[17], 0] += 0.5            # alone: dropped (one particle)
    x1[[5, 6], 0] -= 0.5          # backward: not slipping
    x1[[8], 0] += 0.005           # below S_x: not slipping
    ext = clusters.event_clusters(x0, x1, lat.bonds, lat.box)
    assert sorted(ext.n_c.tolist()) == [2, 3]
    by_size = dict(zip(ext.n_c.tolist(), zip(ext.l_x.tolist(), ext.l_y.tolist())))
    assert by_size[2] == pytest.approx((0.0, 4.0 * 2 * 1 / 2))  # l_y = 4 * (2 * 1) / (2 * 1)
    assert by_size[3][1] == 0.0


@pytest.mark.parametrize("fx, fy, psi, expected", [
    (1.01, 0.98, 0.99, "C"),
    (1.01, 0.98, 0.6, "W"),      # spans both axes but is not crystalline: never DP or DT
    (0.98, 1.01, 0.6, "W"),
    (1.02, 0.35, 0.95, "LC"),
    (0.6, 0.3, 0.7, "DP"),
    (0.3, 0.6, 0.5, "DT"),
    (math.nan, math.nan, 0.9, None),
])
def test_regime_rule(fx, fy, psi, expected):
    assert clusters.regime(fx, fy, psi) == expected


def test_run_regime_is_the_most_frequent_cluster_regime():
    box = (20.0, 5.0)
    # 3 whole-system clusters, 2 rows, 1 small transverse one
    l_x = np.array([20.2, 20.2, 20.2, 21.05, 21.05, 1.0])
    l_y = np.array([5.05, 5.05, 5.05, 0.0, 0.0, 4.0])
    shape = clusters.cluster_shape(l_x, l_y, box, psi_inf=0.99)
    assert shape.regime == "C"
    assert shape.regime_fractions == pytest.approx({"C": 0.5, "W": 0, "LC": 1 / 3, "DP": 0,
                                                    "DT": 1 / 6})
    assert shape.lx_mean_over_Lx == pytest.approx(l_x.mean() / 20)
    assert shape.lx_over_ly == pytest.approx(l_x.mean() / l_y.mean())
    assert clusters.cluster_shape(l_x, l_y, box, psi_inf=0.5).regime == "W"
    assert clusters.cluster_shape([], [], box).regime is None


@pytest.mark.parametrize("lx, ly", [(20, 5), (5, 20), (10, 10), (21, 6), (6, 21), (9, 7),
                                    (40, 10), (10, 40), (3, 3)])
@pytest.mark.parametrize("psi, expected", [(0.99, "C"), (0.5, "W")])
def test_a_whole_box_slip_is_neither_dp_nor_dt_on_any_lattice(lx, ly, psi, expected):
    """The parity-free rule: every particle slipping, on odd and even sides, is C or W; its
    extents are exactly the whole box's (box_extent), and whole rows stay LC."""
    from bkflow.model.lattice import square_lattice

    lat = square_lattice(lx, ly)
    x0 = lat.positions[:, :2].copy()
    ext = clusters.event_clusters(x0, x0 + [0.5, 0.0], lat.bonds, lat.box)
    assert ext.n_c.tolist() == [lx * ly]
    assert ext.l_x[0] == pytest.approx(box_extent(lx, ly), rel=1e-12)
    assert ext.l_y[0] == pytest.approx(box_extent(ly, lx), rel=1e-12)
    shape = clusters.cluster_shape(ext.l_x, ext.l_y, lat.box, psi_inf=psi)
    assert shape.regime == expected and shape.regime_fractions[expected] == 1.0
    assert shape.regime_fractions["DP"] == shape.regime_fractions["DT"] == 0.0
    # the layer's rows one by one (a row of lx sites is bonded along x): LC
    row = np.zeros(lx * ly, bool)
    row[:lx] = True
    ext = clusters.event_clusters(x0, x0 + 0.5 * row[:, None] * [1.0, 0.0], lat.bonds, lat.box)
    if ly > 1 and lx > 1:
        assert clusters.cluster_shape(ext.l_x, ext.l_y, lat.box, psi_inf=psi).regime == "LC"


# --- stress ------------------------------------------------------------------------------

def _sawtooth(peaks, rate=0.02, dt=0.1, floor=0.0):
    """Linear loading from ``floor`` to each peak, then a drop to ``floor`` in one sample."""
    t, s, cur, idx = [0.0], [floor], 0.0, []
    for p in peaks:
        n = int(math.ceil((p - floor) / (rate * dt)))
        ramp = np.linspace(floor, p, n + 1)[1:]
        for v in ramp:
            cur += dt
            t.append(cur)
            s.append(v)
        idx.append(len(s) - 1)
        cur += dt
        t.append(cur)
        s.append(floor)
    for v in np.linspace(floor, floor + 0.05, 20)[1:]:  # the last drop is confirmed by a rise
        cur += dt
        t.append(cur)
        s.append(v)
    return np.array(t), np.array(s), np.array(idx)


def test_sawtooth_returns_exactly_its_peaks():
    rng = np.random.default_rng(2)
    peaks = rng.uniform(0.3, 1.0, 30)
    t, s, idx = _sawtooth(peaks, floor=0.1)
    ev = stress.slip_events(t, s, threshold=0.01)
    np.testing.assert_array_equal(ev.i_max, idx)
    np.testing.assert_array_equal(ev.sigma_fail, peaks)
    np.testing.assert_allclose(ev.drop, peaks - 0.1, rtol=1e-14)
    f = stress.macroscopic_friction(t, s, sigma_n=5.0, threshold=0.01, transient_fraction=0.0)
    assert f.n_slips == 30
    assert f.mu_bar == pytest.approx(peaks.mean() / 5.0, rel=1e-14)
    # the transient removes exactly the events whose maximum lies in it
    t0 = t[idx[10]]
    f2 = stress.macroscopic_friction(t, s, 5.0, 0.01, t_transient=t0)
    assert f2.n_slips == 20 and f2.mu_bar == pytest.approx(peaks[10:].mean() / 5, rel=1e-14)


def test_wiggles_below_the_threshold_are_not_events():
    rng = np.random.default_rng(4)
    peaks = rng.uniform(0.3, 1.0, 20)
    t, s, idx = _sawtooth(peaks, floor=0.1)
    thr = 0.01
    # a wiggle of amplitude 0.4 thr everywhere: on the ramps, in the troughs, at the peaks
    wig = 0.4 * thr * np.sin(2 * math.pi * t / 0.7)
    ev = stress.slip_events(t, s + wig, thr)
    assert len(ev) == 20
    np.testing.assert_allclose(ev.sigma_fail, peaks, atol=0.4 * thr + 0.02 * 0.1)
    # wiggles alone, however many, are no slip
    assert len(stress.slip_events(t, 0.5 + wig, thr)) == 0
    # a drop of exactly the threshold is not "larger than" it
    assert len(stress.slip_events([0, 1, 2, 3], [0, 1.0, 0.75, 1.5], 0.25)) == 0
    assert len(stress.slip_events([0, 1, 2, 3], [0, 1.0, 0.7, 1.5], 0.25)) == 1


def test_standard_error_shrinks_like_one_over_sqrt_n():
    rng = np.random.default_rng(8)
    ns = np.array([64, 256, 1024, 4096])
    errs = []
    for n in ns:
        e = [mean_error(rng.normal(0.6, 0.05, n)) for _ in range(40)]
        assert np.median([x.g for x in e]) < 1.1  # independent: mostly no inefficiency
        errs.append(np.mean([x.error for x in e]))
    slope = np.polyfit(np.log(ns), np.log(errs), 1)[0]
    assert slope == pytest.approx(-0.5, abs=0.03)
    np.testing.assert_allclose(np.array(errs) * np.sqrt(ns), 0.05, rtol=0.05)


def test_mean_error_accounts_for_correlation():
    """AR(1) slips with rho = 0.8: the error of the mean is sqrt((1+rho)/(1-rho)) = 3x the naive
    one; the statistical inefficiency finds it, the naive formula would not."""
    rng = np.random.default_rng(9)
    rho, n = 0.8, 2 ** 14
    found = []
    for _ in range(5):
        e = rng.normal(size=n)
        x = np.empty(n)
        x[0] = e[0] / math.sqrt(1 - rho ** 2)
        for i in range(1, n):
            x[i] = rho * x[i - 1] + e[i]
        found.append(mean_error(x).error)
    exact = math.sqrt(1 / (1 - rho ** 2) / n * (1 + rho) / (1 - rho))
    assert np.mean(found) == pytest.approx(exact, rel=0.15)


@pytest.mark.parametrize("alpha", [1.8, 2.5])
@pytest.mark.slow
def test_power_law_fit_recovers_the_exponent(alpha):
    rng = np.random.default_rng(int(alpha * 10))
    x_min = 0.01
    x = x_min * (1 - rng.random(20000)) ** (-1 / (alpha - 1))
    fixed = stress.power_law_fit(x, x_min=x_min)
    assert fixed.alpha == pytest.approx(alpha, abs=0.05)
    assert fixed.n_tail == 20000
    # below the cut, an excess of small drops (a threshold effect) that the KS rule must cut
    small = rng.uniform(0.002, x_min, 5000)
    auto = stress.power_law_fit(np.concatenate([x, small]))
    assert auto.alpha == pytest.approx(alpha, abs=0.05)
    assert auto.x_min >= 0.5 * x_min


def test_the_x_min_scan_is_a_fit_at_every_candidate_in_order():
    """power_law_fit's vectorised scan of x_min picks what fitting the tail above each
    sample value in turn (and keeping the first of the smallest KS distances) picks, ties
    and a tail of one value included, across chunk edges."""
    rng = np.random.default_rng(7)
    for trial in range(40):
        m = int(rng.integers(10, 400))
        x = np.round(0.01 * (1 - rng.random(m)) ** -0.8, int(rng.integers(2, 6)))
        if trial % 5 == 0:
            x[-(m // 3):] = x.max()   # a block of equal values at the top
        xs = np.sort(x)
        best = None
        for xm in np.unique(xs[: m - 10 + 1]):
            tail = xs[np.searchsorted(xs, xm):]
            if np.all(tail == xm):
                continue
            alpha, ks = stress._fit_tail(tail, xm)
            if best is None or ks < best[1]:
                best = (alpha, ks, xm, len(tail))
        fit = stress.power_law_fit(x)
        if best is None:
            assert math.isnan(fit.alpha)
            continue
        assert (fit.x_min, fit.n_tail) == (best[2], best[3])
        assert fit.alpha == pytest.approx(best[0], rel=1e-12)
        assert fit.ks == pytest.approx(best[1], rel=1e-9, abs=1e-15)
        cands = np.unique(xs[: m - 9])
        cands = cands[cands < xs[-1]]
        a1, k1 = stress._scan_tails(xs, cands)
        a2, k2 = stress._scan_tails(xs, cands, cells=3 * m)   # chunks of three
        a3, k3 = stress._scan_tails(xs, cands, loop_from=0)   # a call per candidate
        for a, k in ((a2, k2), (a3, k3)):
            assert np.allclose(a1, a, rtol=1e-12, atol=0) and np.allclose(k1, k, rtol=1e-9)


def test_power_law_fit_is_the_powerlaw_packages_at_a_fixed_x_min():
    """bkflow keeps its own closed-form fit (no optimiser, used inside the bootstrap); it
    is the same maximum-likelihood estimate as the field's library."""
    import powerlaw

    rng = np.random.default_rng(11)
    x = 0.01 * (1 - rng.random(3000)) ** (-1 / 0.75)
    ours = stress.power_law_fit(x, x_min=0.01)
    theirs = powerlaw.Fit(x, xmin=0.01, verbose=False).power_law.alpha
    assert ours.alpha == pytest.approx(theirs, rel=1e-9)


def test_the_goodness_of_fit_p_value_is_calibrated_on_true_power_laws():
    """Drawn from the law it tests, p is uniform on [0, 1]: about 10% of true power laws fall
    below P_REJECT (Clauset et al.'s false rejection rate), and the mean p is about 1/2."""
    rng = np.random.default_rng(12)
    ps = []
    for _ in range(200):
        x = 0.01 * (1 - rng.random(150)) ** (-1 / 0.9)
        ps.append(stress.power_law_p(stress.power_law_fit(x, x_min=0.01), n_boot=200,
                                     seed=int(rng.integers(1 << 30))))
    ps = np.array(ps)
    assert 0.04 <= np.mean(ps < stress.P_REJECT) <= 0.18
    assert np.mean(ps) == pytest.approx(0.5, abs=0.08)


@pytest.mark.parametrize("n", [300, 3000])
def test_a_lognormal_is_not_taken_for_a_power_law(n):
    """Lognormal 'drops' (the shape the stiff layers show): the bootstrap rejects the power
    law and the likelihood ratio favours the lognormal; a true power law passes both."""
    rng = np.random.default_rng(n)
    ln = stress.power_law_test(np.exp(rng.normal(-3.5, 0.8, n)), x_min=0.01)
    assert ln.verdict == "rejected" and ln.p == 0.0 and ln.preferred == "lognormal"
    assert ln.describe() == "power law rejected (p < 0.001, lognormal favoured)"
    pl = stress.power_law_test(0.01 * (1 - rng.random(n)) ** (-1 / 0.8), x_min=0.01)
    assert pl.verdict == "plausible" and pl.preferred != "lognormal"
    assert pl.describe().startswith("alpha = 1.")
    assert stress.power_law_test([0.02] * 5, x_min=0.01).verdict == "no fit"


def test_drop_distribution_is_a_normalised_density_in_log_bins():
    rng = np.random.default_rng(6)
    drops = 0.01 * (1 - rng.random(5000)) ** (-1 / 1.5)  # alpha = 2.5
    centres, density = stress.drop_distribution(drops, bins=15)
    edges = np.geomspace(drops.min(), drops.max(), 16)
    np.testing.assert_allclose(centres, np.sqrt(edges[:-1] * edges[1:]), rtol=1e-12)
    assert np.sum(density * np.diff(edges)) == pytest.approx(1.0, rel=1e-12)
    # the density of a power law falls with the power law's exponent
    full = density > 0
    slope = np.polyfit(np.log(centres[full][:8]), np.log(density[full][:8]), 1)[0]
    assert slope == pytest.approx(-2.5, abs=0.2)
    c0, d0 = stress.drop_distribution([])
    assert len(c0) == 0 and len(d0) == 0


def test_mean_stress_ratio_is_the_late_time_average():
    t = np.linspace(0, 100, 1001)
    s = np.where(t < 20, 0.0, 0.5)
    f = stress.macroscopic_friction(t, s, sigma_n=5.0, threshold=0.01)
    assert f.mean_stress_ratio == pytest.approx(0.1, rel=1e-14)
    assert f.n_slips == 0 and math.isnan(f.mu_bar)


def test_bad_stress_input_is_refused():
    with pytest.raises(ValueError, match="threshold"):
        stress.slip_events([0, 1], [0, 1], 0.0)
    with pytest.raises(ValueError, match="NaN"):
        stress.slip_events([0, 1, 2], [0, np.nan, 1], 0.01)
    with pytest.raises(ValueError, match="shape"):
        stress.slip_events([0, 1, 2], [0, 1], 0.01)


def test_powerlaw_is_imported_without_pyplot_and_pyplot_stays_real():
    """The analysis imports powerlaw without matplotlib.pyplot
    (bkflow.observables.stress.import_powerlaw); powerlaw's own plots still work, and a later
    ``import matplotlib.pyplot`` is the real one."""
    code = (
        "import sys\n"
        "from bkflow.observables.stress import import_powerlaw\n"
        "pl = import_powerlaw()\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
        "import matplotlib\n"
        "matplotlib.use('Agg')\n"
        "import matplotlib.pyplot as plt\n"
        "assert type(plt).__name__ == 'module' and hasattr(plt, 'subplots')\n"
        "assert pl.fitting.plt.gca() is plt.gca()\n"
        "import numpy as np\n"
        "fit = pl.Fit(np.arange(1.0, 200.0) ** 1.5, xmin=1.0, verbose=False)\n"
        "print(fit.plot_pdf() is plt.gca())\n")
    assert fresh_python(code).strip() == "True"
