/* bkflow LAMMPS plugin: what the plugin's entry point (bkplugin.cpp) shares with its fixes,
   the check that the running LAMMPS is the build the plugin was compiled against. */

#ifndef BKFLOW_BKPLUGIN_H
#define BKFLOW_BKPLUGIN_H

#include <string>

namespace LAMMPS_NS {
class LAMMPS;

// "" when lmp is the LAMMPS version and git descriptor the plugin was built against (the
// compile definitions BK_LAMMPS_VERSION and BK_LAMMPS_GIT), else "built for LAMMPS <version>
// (<git>) but loaded into LAMMPS <version> (<git>)"
std::string bk_version_mismatch(LAMMPS *lmp);

}    // namespace LAMMPS_NS

#endif
