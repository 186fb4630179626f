/* bkflow LAMMPS plugin: what the plugin says to the outside, named once: the slots of fix
   bk/substrate's global vector, the code of the path that ran, and the tokens that start the
   plugin's error messages that a program has to tell apart. bkflow mirrors each by name
   (bkflow.lammps.deck.SLOTS, bkflow.lammps.plugin.PATH_CODES and ERROR_TOKENS), and tests/plugins/test_interface.py
   reads this file to check that the two agree. */

#ifndef BKFLOW_BK_INTERFACE_H
#define BKFLOW_BK_INTERFACE_H

/* the slots of fix bk/substrate's global vector, 0-based (f_ID[slot + 1] in a deck) */
enum bk_slot {
  BK_SLOT_SIGMA,           /* sigma_x = sum_i k_d^i (anchor_x,i(t) - x_i) / (Lx Ly) */
  BK_SLOT_BREAKS_STEP,     /* contact breaks in the last step */
  BK_SLOT_BREAKS_TOTAL,    /* contact breaks since the fix was defined */
  BK_SLOT_PLATE,           /* the plate's displacement V_d (t - t0) */
  BK_SLOT_BOND_MAX,        /* the longest bond in the last step */
  BK_SLOT_PATH,            /* the path that ran, a bk_path_code */
  /* the energy ledger (docs/model.md "Energy"): the energies of the current step, computed
     when asked, and, with the keyword `energy`, the running sums since the fix was defined
     (NaN without it) */
  BK_SLOT_E_BOND,          /* bonds, sum k_b/2 (r - r0)^2 */
  BK_SLOT_E_DRIVE,         /* drive springs, sum k_d^i/2 |r_i - anchor_i(t)|^2 */
  BK_SLOT_E_CONTACT,       /* contacts, sum k_e/2 |dr_i|^2 */
  BK_SLOT_E_KINETIC,       /* kinetic, sum m/2 |v_i|^2 (the full-step velocities) */
  BK_SLOT_WORK,            /* the plate's work on the drive springs */
  BK_SLOT_DISS_BREAK,      /* dissipated by contact breaks (the sliding work under coulomb) */
  BK_SLOT_DISS_DAMP,       /* dissipated by damping */
  BK_SLOT_IMAGE_BASE,      /* box lengths the fix took out of LAMMPS's x image flags */
  BK_SLOT_OVERSHOOT,       /* contacts the rule left past the threshold, since the fix was
                              defined: a step moved them past their whole range, too long a
                              time step for the friction law (0 at any sensible step) */
  BK_NSLOTS
};

/* the path that integrates (slot BK_SLOT_PATH) */
enum bk_path_code {
  BK_PATH_GENERAL,           /* fix bk/substrate's general path (or fix nve + ... ) */
  BK_PATH_FUSED_BASELINE,    /* the fused path, its kernel built for baseline x86-64 */
  BK_PATH_FUSED_AVX2,        /* ... for AVX2 */
  BK_PATH_FUSED_AVX512       /* ... for AVX-512 */
};

/* tokens that start the plugin's error messages that bkflow's engine tells apart */
#define BK_ERR_WRITE_FAILED "[bk:write-failed]"     /* an output file could not be written */
#define BK_ERR_CANNOT_OPEN "[bk:cannot-open]"       /* an output file could not be opened */
#define BK_ERR_PARTNER_MISSING "[bk:partner-missing]" /* a bond partner is not on the rank */
#define BK_ERR_ATOM_LOST "[bk:atom-lost]"           /* the fused path lost one of its atoms */

#endif
