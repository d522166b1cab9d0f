// Files. Outputs are written to a temporary beside the target and renamed into place, so a
// failed or interrupted run never leaves a partial output file; an OutputTransaction places all
// of a command's outputs together, at the end, or none of them.
#pragma once

#include "penumbra/core/expected.h"
#include "penumbra/core/interrupt.h"

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace penumbra {

// Calls write(tmp_path) with a temporary beside `path` (same extension); on success renames it to
// `path` (or, while an OutputTransaction is open, leaves that to its commit()), otherwise removes
// it. SIGINT or SIGTERM arriving meanwhile removes the temporary too.
Status writeAtomically(const std::string& path,
                       const std::function<Status(const std::string&)>& write);

// As writeAtomically, but placed at once even inside a transaction (a checkpoint is kept when the
// other outputs fail).
Status writeAtomicallyNow(const std::string& path,
                          const std::function<Status(const std::string&)>& write);

// Before the work: that `path` can be written. Its directory exists and takes a new file (a probe
// is created and removed: access() says yes to root on read-only file systems), `path` is not a
// directory, nor anything else that is not a regular file (outputs are renamed into place, which
// would replace a device node such as /dev/null with a file), and its name is not longer than the
// file system allows. Temporaries left in the directory by processes that no longer exist (SIGKILL)
// are removed. In a run over several processes only rank 0 writes outputs (cluster/communicator.h):
// on the others this returns ok without looking (their file systems may differ, and their probes
// would race rank 0's temporaries).
Status checkOutputPath(const std::string& path);

// Whether this process writes the run's outputs: true unless it is a rank > 0 of a distributed run
// (the CLI sets it for each command).
void setThisProcessWritesOutputs(bool writes);
bool thisProcessWritesOutputs();

// All outputs of one command. While it is open (one at a time), writeAtomically writes into
// temporaries and commit() renames them into place in the order written; a transaction closed
// without commit() (an error, an exception) removes its temporaries and the directories it
// created, and SIGINT / SIGTERM ending the process does the same (core/interrupt.h).
class OutputTransaction {
 public:
  OutputTransaction();
  ~OutputTransaction();
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;

  // Creates `dir` and its missing parents now; those this run made are removed again unless the
  // transaction commits (or `keep` is called, as when a checkpoint was written into them).
  Status createDirectories(const std::string& dir);
  void keepCreatedDirectories();
  // A file removed once the outputs are placed (a checkpoint the run made stale).
  void removeOnCommit(const std::string& path) { remove_on_commit_.push_back(path); }
  // Renames every temporary into place. If one fails, the temporaries left are removed and the
  // outputs this commit placed are removed again.
  Status commit();
  // Renames the temporaries written so far into place (a preview to look at while the run goes
  // on) and stays open for the rest. Directories it created stay while they hold what it placed.
  Status placeSoFar();

  // The temporary that holds `path` until commit, or "" when `path` is not pending.
  std::string pendingTemporary(const std::string& path) const;

  // The open transaction, or null.
  static OutputTransaction* current();

 private:
  friend Status writeAtomically(const std::string&,
                                const std::function<Status(const std::string&)>&);
  struct Pending {
    std::string tmp, path;
    CleanupOnSignal guard;
  };
  std::vector<Pending> pending_;
  std::vector<std::pair<std::string, CleanupOnSignal>> created_;  // in creation order
  std::vector<std::string> remove_on_commit_;
  bool committed_ = false;
};

// Reads a whole file into a string (binary). Only a regular file is read: a directory, a device,
// a FIFO or a socket is refused as input (exit 2) before anything is read (a FIFO is opened
// without blocking), and a file larger than the memory the process may still allocate is refused
// with both sizes. With `limit`, at most its first `limit` bytes are read.
Expected<std::string> readFile(const std::string& path);
Expected<std::string> readFile(const std::string& path, uint64_t limit);

// Before handing `path` to a library that opens it itself: it exists and is a regular file (after
// following links), else an input error naming what it is ("is a FIFO, not a regular file").
Status checkInputFile(const std::string& path);

// Writes `bytes` to `tmp` (a temporary that writeAtomically gave) with every write checked and
// the data flushed to the device, so "No space left on device" or a file-size limit is reported
// as a failed write of `path`, never found later as a truncated file.
Status writeBytesTo(const std::string& path, const std::string& tmp, std::string_view bytes);

// Lower-case extension with the dot (".exr"), empty when none.
std::string extensionOf(const std::string& path);

// `path` resolved against the directory of `base_file` unless it is absolute.
std::string resolveRelativeTo(const std::string& base_file, const std::string& path);

}  // namespace penumbra
