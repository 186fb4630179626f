/* bkflow LAMMPS plugin: registers fix bk/substrate, fix bk/slips and fix bk/stress. LAMMPS only warns when a plugin was
   built for another version; a C++ plugin is tied to the exact build it was compiled
   against, so this one says so loudly at load time and fix bk/substrate refuses to run. */

#include "error.h"
#include "fix_bk_slips.h"
#include "fix_bk_stress.h"
#include "fix_bk_substrate.h"
#include "lammps.h"
#include "utils.h"

#include <cstring>

using namespace LAMMPS_NS;

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

static Fix *bk_substrate_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBKSubstrate(lmp, argc, argv);
}

static Fix *bk_slips_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBKSlips(lmp, argc, argv);
}

static Fix *bk_stress_creator(LAMMPS *lmp, int argc, char **argv)
{
  return new FixBKStress(lmp, argc, argv);
}

extern "C" void lammpsplugin_init(void *ptr, void *handle, void *regfunc)
{
  auto *lmp = static_cast<LAMMPS *>(ptr);
  auto register_plugin = reinterpret_cast<lammpsplugin_regfunc>(regfunc);

  if (strcmp(lmp->version, BK_LAMMPS_VERSION) != 0 ||
      strcmp(LAMMPS::git_descriptor(), BK_LAMMPS_GIT) != 0) {
    utils::logmesg(lmp,
                   "\n*** bkflow plugin MISMATCH: built for LAMMPS {} ({}), loaded into LAMMPS {} "
                   "({}).\n*** fix bk/substrate will refuse to run. Reinstall bkflow "
                   "(pip install -e .) against this LAMMPS.\n\n",
                   BK_LAMMPS_VERSION, BK_LAMMPS_GIT, lmp->version, LAMMPS::git_descriptor());
  }

  lammpsplugin_t plugin;
  // the running version, so that LAMMPS's own (warning-only) check stays quiet: ours is above
  plugin.version = lmp->version;
  plugin.style = "fix";
  plugin.name = "bk/substrate";
  plugin.info = "bkflow Burridge-Knopoff substrate: drive + shear-history friction + damping";
  plugin.author = "bkflow developers";
  plugin.creator.v2 = reinterpret_cast<lammpsplugin_factory2 *>(&bk_substrate_creator);
  plugin.handle = handle;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "bk/slips";
  plugin.info = "bkflow: positions at the maximum and minimum of every slip event";
  plugin.creator.v2 = reinterpret_cast<lammpsplugin_factory2 *>(&bk_slips_creator);
  (*register_plugin)(&plugin, lmp);

  plugin.name = "bk/stress";
  plugin.info = "bkflow: the shear stress series t,sigma_x, buffered";
  plugin.creator.v2 = reinterpret_cast<lammpsplugin_factory2 *>(&bk_stress_creator);
  (*register_plugin)(&plugin, lmp);
}
