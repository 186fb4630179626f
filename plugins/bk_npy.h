/* bkflow LAMMPS plugin: BKNpy, a NumPy .npy file of fixed-size records written as a run goes
   (fix bk/reduce, fix bk/psi): a 512-byte header that says how many records, rewritten after
   the records at every write, then the records; the last `pending` record (the state of the
   run so far, not yet final) is rewritten at every write until it is final. numpy.load reads
   the file at any time between writes. Records are doubles; a field declared '<i8' holds
   int64 bits (as_double). */

#ifndef BKFLOW_BK_NPY_H
#define BKFLOW_BK_NPY_H

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace LAMMPS_NS {

struct BKNpy {
  static constexpr long HEADER = 512;

  std::string name;
  std::string descr;              // "('a', '<i8'), ('b', '<f8'), " (NumPy's spelling)
  int nfields = 0;                // doubles per record
  FILE *fp = nullptr;             // rank 0 only
  int64_t nfinal = 0;             // final records on disk
  int64_t nrecords = 0;           // final records (every rank)
  std::vector<double> staged;     // final records not yet written
  std::vector<double> pending;    // the record under way (empty: none)

  static double as_double(int64_t v)
  {
    double d;
    std::memcpy(&d, &v, sizeof d);
    return d;
  }
  static int64_t as_int(double d)
  {
    int64_t v;
    std::memcpy(&v, &d, sizeof v);
    return v;
  }

  void field(const char *fname, const char *type)
  {
    descr += std::string("('") + fname + "', '" + type + "'), ";
    nfields++;
  }

  // opens the file (a run continued from a restart file: read and written in place); false
  // when it cannot be opened
  bool open(const char *fname, bool appending)
  {
    name = fname;
    fp = fopen(fname, appending ? "r+b" : "w+b");
    if (!fp) return false;
    if (!appending) return write();    // a new file is a valid .npy of no records from the start
    // appended to: the records so far, from the file's size (a restart's state may say more
    // exactly which are final: it sets nfinal then)
    if (fseek(fp, 0, SEEK_END) != 0) return false;
    const long size = ftell(fp);
    const long rec = static_cast<long>(sizeof(double)) * nfields;
    nfinal = size > HEADER && rec > 0 ? (size - HEADER) / rec : 0;
    return true;
  }

  void close()
  {
    if (fp) fclose(fp);
    fp = nullptr;
  }

  // one final record (`values`, nfields of them); on rank 0 (`root`) staged for the next write
  void stage(const double *values, bool root)
  {
    nrecords++;
    if (root) staged.insert(staged.end(), values, values + nfields);
  }

  // the file's size is at least what `nfinal` final records take
  bool holds_final() const
  {
    if (!fp || fseek(fp, 0, SEEK_END) != 0) return false;
    return ftell(fp) >= HEADER + static_cast<long>(sizeof(double) * nfields * nfinal);
  }

  // writes the staged records, the pending one and the header; false when a write failed
  bool write()
  {
    if (!fp) return true;
    const std::size_t rec = sizeof(double) * nfields;
    const int64_t nstaged = static_cast<int64_t>(staged.size()) / nfields;
    const int64_t total = nfinal + nstaged + (pending.empty() ? 0 : 1);
    if (fseek(fp, HEADER + static_cast<long>(rec * nfinal), SEEK_SET) != 0) return false;
    if (nstaged && fwrite(staged.data(), rec, nstaged, fp) != static_cast<size_t>(nstaged))
      return false;
    if (!pending.empty() && fwrite(pending.data(), rec, 1, fp) != 1) return false;
    nfinal += nstaged;
    staged.clear();
    // the header last: a reader never counts a record not yet on disk
    const std::string dict = "{'descr': [" + descr.substr(0, descr.size() - 2) +
        "], 'fortran_order': False, 'shape': (" + std::to_string(total) + ",), }";
    char head[HEADER];
    std::memset(head, ' ', HEADER);
    std::memcpy(head, "\x93NUMPY\x01\x00", 8);
    const unsigned len = HEADER - 10;
    head[8] = static_cast<char>(len & 0xff);
    head[9] = static_cast<char>(len >> 8);
    std::memcpy(head + 10, dict.data(), dict.size());
    head[HEADER - 1] = '\n';
    return fflush(fp) == 0 && fseek(fp, 0, SEEK_SET) == 0 &&
        fwrite(head, 1, HEADER, fp) == static_cast<size_t>(HEADER) && fflush(fp) == 0;
  }
};

}    // namespace LAMMPS_NS

#endif
