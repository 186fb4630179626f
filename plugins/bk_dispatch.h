/* bkflow LAMMPS plugin: the one index of a step's specialised loops, on both paths of
   fix bk/substrate. Each combination of the parts of a deck that change a loop (the drive on or
   off, the contact rule, the damping scheme, the energy ledger on or off) is a specialisation
   of the loop's template, and the path picks it from a table of them by bk_dispatch(): the
   general path's eval() (fix_bk_substrate_forces.cpp, one table for a step and one for setup)
   and the fused kernel's run_t and setup_t (bk_fused_kernel.inc). Both build their tables from
   the decoders below. Compile-time constants with internal linkage and no LAMMPS header, as in
   bk_model.h, so that the kernel's builds for each instruction set include it too. */

#ifndef BKFLOW_BK_DISPATCH_H
#define BKFLOW_BK_DISPATCH_H

#include "bk_model.h"

// the number of combinations: drive (0, 1), contact rule, damping scheme, ledger (0, 1)
static constexpr int BK_NDISPATCH = 2 * BK_NCONTACT * BK_NDAMPING * 2;

// the index of a combination (drive and ledger 0 or 1, contact and damping of bk_model.h)
static constexpr int bk_dispatch(int drive, int contact, int damping, int ledger)
{
  return drive + 2 * (contact + BK_NCONTACT * (damping + BK_NDAMPING * ledger));
}

// the parts of index i, a table's template arguments
static constexpr int bk_dispatch_drive(int i)
{
  return i % 2;
}

static constexpr int bk_dispatch_contact(int i)
{
  return i / 2 % BK_NCONTACT;
}

static constexpr int bk_dispatch_damping(int i)
{
  return i / (2 * BK_NCONTACT) % BK_NDAMPING;
}

static constexpr int bk_dispatch_ledger(int i)
{
  return i / (2 * BK_NCONTACT * BK_NDAMPING);
}

// every index decodes to the combination it encodes
static constexpr bool bk_dispatch_round_trip()
{
  for (int i = 0; i < BK_NDISPATCH; i++)
    if (bk_dispatch(bk_dispatch_drive(i), bk_dispatch_contact(i), bk_dispatch_damping(i),
                    bk_dispatch_ledger(i)) != i)
      return false;
  return true;
}
static_assert(bk_dispatch_round_trip(), "bk_dispatch and its decoders disagree");

#endif
