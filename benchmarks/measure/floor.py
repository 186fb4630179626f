"""The floor: a tight single-thread C kernel of the model (benchmarks/measure/floor_kernel.c),
the fastest this model can run on one core, against LAMMPS running the same deck.

1. builds floor_kernel.c with ``gcc -O3 -march=native -fno-math-errno`` (a shared library
   called through ctypes);
2. checks it against the plugin (``fix bk/substrate``, contact rule reset, implicit damping) on
   a short run from a lively start (tests/support.py, the plugin tests' own): 2000 steps on 8x3
   and 20x5 lattices, every position to 1e-9 and the contact breaks exactly;
3. times it in ns per atom-step at N = 100 and 900 (phi = 100, C = 0.1, t_end = 1000, the
   friction scene) against LAMMPS's ``Loop time`` of the same deck run as
   ``lmp -in in.bk -var comm_cutoff 1.0``: the codes alternate, ``--rounds`` times, and the
   medians are printed side by side with their ratios to the floor.

Codes (``--codes``):
  floor    the C kernel
  engine   the installed plugin (``bkflow_plugin``) running the deck of bkflow.lammps.deck
  dev      the same deck with the plugin of BKFLOW_PLUGIN_DIR (a development build)
  fused    the development build's fused path, ``fix bk/substrate ... fused``: the deck of
           ``bkflow.lammps.deck.setup_text(..., path="fused")``
and any of them with LAMMPS settings appended as ``+NAME`` (SETTINGS: timer, neigh50,
newtonoff, nosort; ``+fast`` = FAST: timer, neigh50, newtonoff), e.g. ``fused+fast``,
``engine+timer+neigh50``.

    python -m benchmarks.measure.floor [--check-only] [--sizes 20x5 60x15] [--rounds 5]
        [--t-end 1000] [--codes floor engine dev fused]
"""

from __future__ import annotations

import os

# NumPy's OpenBLAS threads spin while idle: on a 2-core machine they steal the timed core
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import ctypes  # noqa: E402
import re  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks.harness import ROOT, medians, parser, tool  # noqa: E402
from bkflow.cli.assignments import parse_size  # noqa: E402
from bkflow.lammps.deck import FAST_SETTINGS, DeckOptions, data_text, setup_text  # noqa: E402
from bkflow.model.lattice import lattice_for  # noqa: E402
from bkflow.model.params import RunSpec  # noqa: E402
from bkflow.store.layout import DATA, STRESS  # noqa: E402

KERNEL = Path(__file__).with_name("floor_kernel.c")
#: the model's one header (plugins/bk_model.h), which the kernel includes
MODEL_HEADER_DIR = ROOT / "plugins"
CFLAGS = ["-O3", "-march=native", "-fno-math-errno"]


class Params(ctypes.Structure):
    _fields_ = [("Lx", ctypes.c_int), ("Ly", ctypes.c_int)] + [
        (k, ctypes.c_double) for k in
        ("dt", "mass", "kb", "r0", "vd", "ke", "fmax", "gamma", "xprd", "yprd")]


_P = ctypes.POINTER(ctypes.c_double)


class Arrays(ctypes.Structure):
    _fields_ = [(k, _P) for k in ("x", "y", "vx", "vy", "fx", "fy", "drx", "dry", "ax", "ay",
                                  "kd", "srx", "sry", "sux", "suy")]


def build(out_dir: Path) -> ctypes.CDLL:
    lib = out_dir / "libbkfloor.so"
    subprocess.run(["gcc", *CFLAGS, "-shared", "-fPIC", "-Wall", "-Wextra",
                    f"-I{MODEL_HEADER_DIR}", str(KERNEL), "-o", str(lib), "-lm"], check=True)
    dll = ctypes.CDLL(str(lib))
    dll.bk_floor_run.restype = ctypes.c_long
    dll.bk_floor_run.argtypes = [ctypes.POINTER(Params), ctypes.POINTER(Arrays), ctypes.c_long,
                                 ctypes.c_long, ctypes.c_int, ctypes.c_int, _P, _P]
    return dll


class Floor:
    """The kernel's state for one lattice: x_unwrapped (N, 2) at the start, velocities,
    anchors (positions when the drive was attached, whose bond images are the fixed ones) and
    the contacts' initial displacement along x."""

    def __init__(self, dll, spec: RunSpec, k_d, x, v, anchor, dr0=None):
        self.dll, self.spec = dll, spec
        lx, ly, n = spec.Lx, spec.Ly, spec.N
        box = np.array([float(lx), float(ly)])
        anchor = np.asarray(anchor, float)
        k = np.arange(n)
        ix, iy = k % lx, k // lx
        right = (ix + 1) % lx + lx * iy
        up = ix + lx * ((iy + 1) % ly)
        sr = -box * np.round((anchor - anchor[right]) / box)
        su = -box * np.round((anchor - anchor[up]) / box)
        c = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
        self.a = {"x": c(x[:, 0]), "y": c(x[:, 1]), "vx": c(v[:, 0]), "vy": c(v[:, 1]),
                  "fx": np.zeros(n), "fy": np.zeros(n),
                  "drx": c(np.zeros(n) if dr0 is None else dr0), "dry": np.zeros(n),
                  "ax": c(anchor[:, 0]), "ay": c(anchor[:, 1]), "kd": c(k_d),
                  "srx": c(sr[:, 0]), "sry": c(sr[:, 1]), "sux": c(su[:, 0]), "suy": c(su[:, 1])}
        self.arrays = Arrays(**{k: v.ctypes.data_as(_P) for k, v in self.a.items()})
        self.params = Params(lx, ly, spec.dt, spec.mass, spec.k_b, 1.0, spec.V_d, spec.k_e,
                             spec.friction_threshold, spec.gamma, box[0], box[1])
        self.step, self.breaks = 0, 0

    def run(self, nsteps: int, nevery: int = 0) -> tuple[float, float, np.ndarray]:
        """Advance nsteps; (wall ns, CPU ns of the steps, sigma_x every nevery-th step)."""
        sigma = np.zeros(nsteps // nevery + 1 if nevery else 1)
        ns = (ctypes.c_double * 2)()
        b = self.dll.bk_floor_run(ctypes.byref(self.params), ctypes.byref(self.arrays),
                                  self.step, nsteps, int(self.step == 0), nevery,
                                  sigma.ctypes.data_as(_P), ns)
        if b < 0:
            raise MemoryError("floor kernel: allocation failed")
        self.step += nsteps
        self.breaks += b
        return ns[0], ns[1], sigma[:nsteps // nevery if nevery else 0]

    def time_per_atom_step(self, spec: RunSpec) -> tuple[float, float]:
        """(wall, CPU) ns per atom-step of the whole run of ``spec`` from here, sampling
        sigma_x as the friction scene does."""
        ns, cpu, _ = self.run(spec.n_steps, spec.stress_nevery)
        return ns / (spec.N * spec.n_steps), cpu / (spec.N * spec.n_steps)

    @property
    def x(self):
        return np.column_stack([self.a["x"], self.a["y"]])


# --------------------------------------------------------------------------------------------
def check(dll, sizes=((8, 3), (20, 5)), phis=(10.0, 1000.0), steps=2000) -> bool:
    """The kernel against fix bk/substrate (the plugin bkflow.lammps.plugin finds) from a lively
    start."""
    from tests.support import global_vector, lammps_with, lively_start, unwrapped_state

    ok = True
    for lx, ly in sizes:
        for phi in phis:
            spec = RunSpec(phi=phi, Lx=lx, Ly=ly, seed=3, contact_rule="reset",
                           damping="implicit")
            lattice, x0, v0 = lively_start(spec)
            with tempfile.TemporaryDirectory() as tmp:
                cwd = os.getcwd()
                os.chdir(tmp)
                try:
                    lmp = lammps_with(spec, lattice, v0, Path(tmp), preload=1.2)
                    lmp.command(f"run {steps}")
                    got = unwrapped_state(lmp)
                    breaks = int(global_vector(lmp, "breaks_total"))
                    lmp.close()
                finally:
                    os.chdir(cwd)
            fl = Floor(dll, spec, lattice.k_d, x0 - [1.2, 0.0], v0, anchor=x0)
            fl.run(steps)
            err = np.abs(fl.x - got["x"]).max()
            good = err <= 1e-9 and fl.breaks == breaks and breaks > 0
            ok &= good
            print(f"check {lx}x{ly} phi={phi:g}: max |x_floor - x_plugin| = {err:.2e}, breaks "
                  f"{fl.breaks} vs {breaks}: {'OK' if good else 'FAIL'}", flush=True)
    return ok


# --------------------------------------------------------------------------------------------
LOOP = re.compile(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms")

#: LAMMPS settings measured with the fused path, as `+NAME` suffixes of a code;
#: none of them changes the trajectory
SETTINGS = {
    "timer": ("add", FAST_SETTINGS[0]),
    "neigh50": ("replace", "neigh_modify", FAST_SETTINGS[1]),
    "newtonoff": ("replace", "newton", FAST_SETTINGS[2]),
    "nosort": ("after", "atom_modify", "atom_modify     sort 0 0.0"),
}
#: the settings of the fused path's recommended deck (not nosort: without a pair style LAMMPS
#: disables atom sorting by itself, "No pairwise cutoff or binsize set")
FAST = ("timer", "neigh50", "newtonoff")


def apply_settings(deck: str, names) -> str:
    """The deck with the SETTINGS ``names`` applied (``fast``: all of FAST)."""
    names = [n for m in names for n in (FAST if m == "fast" else (m,))]
    lines = deck.splitlines()
    for name in names:
        how = SETTINGS[name]
        if how[0] == "add":
            i = next(i for i, ln in enumerate(lines) if ln.startswith("run "))
            lines.insert(i, how[1])
        elif how[0] == "replace":
            i = next(i for i, ln in enumerate(lines) if ln.split()[:1] == [how[1]])
            lines[i] = how[2]
        else:
            i = next(i for i, ln in enumerate(lines) if ln.split()[:1] == [how[1]])
            lines.insert(i + 1, how[2])
    return "\n".join(lines) + "\n"


def code_deck(code: str, base: str, base_fused: str, dev_dir: str | None):
    """(deck, plugin dir) of a code: engine | dev | fused, each with +SETTING suffixes."""
    name, *opts = code.split("+")
    if any(o not in SETTINGS and o != "fast" for o in opts):
        raise SystemExit(f"unknown option in {code}: settings are {', '.join(SETTINGS)}, fast")
    settings = opts
    if name == "engine":
        deck, pdir = base, installed_plugin_dir()
    elif name == "dev":
        deck, pdir = base, dev_dir
    elif name == "fused":
        deck, pdir = base_fused, dev_dir
    else:
        raise SystemExit(f"unknown code {code}")
    return apply_settings(deck, settings), pdir


CPU_USE = re.compile(r"^([0-9.]+)% CPU use with", re.M)


def lammps_loop(deck: str, work: Path, plugin_dir: str | None) -> tuple[float, float, int, int]:
    """(Loop time in s, its CPU time in s, steps, atoms) of ``lmp -in deck -var comm_cutoff 1.0``
    (CPU time = Loop time x LAMMPS's "% CPU use")."""
    f = work / "in.bk"
    f.write_text(deck)
    env = os.environ.copy()
    env.pop("LAMMPS_PLUGIN_PATH", None)
    if plugin_dir:
        env["BKFLOW_PLUGIN_DIR"] = plugin_dir
    else:
        env.pop("BKFLOW_PLUGIN_DIR", None)
    log = work / "log.lammps"
    subprocess.run([tool("lmp"), "-in", str(f), "-var", "comm_cutoff", "1.0", "-log",
                    str(log), "-screen", "none"], check=True, cwd=work, env=env,
                   timeout=7200)
    text = log.read_text()
    wall, _, steps, atoms = LOOP.findall(text)[-1]
    cpu = float(wall) * float(CPU_USE.findall(text)[-1]) / 100.0
    return float(wall), cpu, int(steps), int(atoms)


def installed_plugin_dir() -> str:
    import importlib.util

    spec = importlib.util.find_spec("bkflow_plugin")
    return str(spec.submodule_search_locations[0])


def _table(title, codes, rows):
    """One row per code: ns per atom-step at each N, and its ratio to the floor."""
    sizes = list(rows)
    print(f"\n{title}\n")
    print("| code | " + " | ".join(f"N = {n} | / floor" for n in sizes) + " |")
    print("|---|" + "---|---|" * len(sizes))
    for c in codes:
        cells = []
        for n in sizes:
            med = rows[n]
            ratio = f"{med[c] / med['floor']:.2f}" if "floor" in med else ""
            cells.append(f"{med[c]:.2f} | {ratio}")
        print(f"| {c} | " + " | ".join(cells) + " |", flush=True)


def timing(dll, sizes, rounds, t_end, codes, dev_dir):
    """Median ns per atom-step of each code, wall and CPU time; the codes alternate."""
    work = Path(tempfile.mkdtemp(prefix="bkfloor"))
    rows, cpu_rows = {}, {}
    for size in sizes:
        lx, ly = parse_size(size)
        spec = RunSpec(phi=100.0, Lx=lx, Ly=ly, dt_factor=0.1, t_end=t_end, scene="friction",
                       seed=1)
        (work / DATA).write_text(data_text(spec))
        run_line = f"\nrun             {spec.n_steps}\n"
        base = setup_text(spec, DeckOptions(data=DATA, stress=STRESS, path="general")) + run_line
        base_fused = setup_text(spec, DeckOptions(data=DATA, stress=STRESS,
                                                  path="fused")) + run_line
        lat = lattice_for(spec)
        times = {c: [] for c in codes}
        cpus = {c: [] for c in codes}
        for _ in range(rounds):
            for c in codes:
                if c == "floor":
                    wall, cpu = Floor(dll, spec, lat.k_d, lat.positions, np.zeros((spec.N, 2)),
                                      anchor=lat.positions).time_per_atom_step(spec)
                    times[c].append(wall)
                    cpus[c].append(cpu)
                    continue
                deck, pdir = code_deck(c, base, base_fused, dev_dir)
                wall, cpu, steps, atoms = lammps_loop(deck, work, pdir)
                times[c].append(wall * 1e9 / (steps * atoms))
                cpus[c].append(cpu * 1e9 / (steps * atoms))
        rows[spec.N] = medians(times)
        cpu_rows[spec.N] = medians(cpus)
        print(f"N = {spec.N}: " + ", ".join(f"{c} {rows[spec.N][c]:.2f}" for c in codes),
              flush=True)
    what = (f"median of {rounds} alternated rounds (phi = 100, C = 0.1, t_end = {t_end:g}, "
            "scene friction, one rank)")
    _table(f"wall ns per atom-step (LAMMPS: Loop time), {what}", codes, rows)
    _table(f"CPU ns per atom-step (LAMMPS: Loop time x % CPU use), {what}", codes, cpu_rows)
    return rows, cpu_rows


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--check-only", action="store_true")
    ap.add_argument("--no-check", action="store_true")
    ap.add_argument("--sizes", nargs="+", default=["20x5", "60x15"])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--t-end", type=float, default=1000.0)
    ap.add_argument("--codes", nargs="+", default=["floor", "engine"])
    a = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="bkfloor"))
    dll = build(tmp)
    print(f"built {KERNEL.name} with gcc {' '.join(CFLAGS)}", flush=True)
    if not a.no_check:
        if not check(dll):
            raise SystemExit("floor kernel does not match the plugin")
        if a.check_only:
            return
    dev = os.environ.get("BKFLOW_PLUGIN_DIR")
    if any(c.startswith(("dev", "fused")) for c in a.codes) and not dev:
        raise SystemExit("codes dev/fused need BKFLOW_PLUGIN_DIR (the development build)")
    timing(dll, a.sizes, a.rounds, a.t_end, a.codes, dev)


if __name__ == "__main__":
    main()
