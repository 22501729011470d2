// One file written by every rank at once, each rank its own pieces at their offsets, so that no
// rank ever holds what the others wrote (the row-ordered matrix files of `mpirun ... viewfactors`).
//
// The file is `head`, then pieces 0 .. count-1 in that order, then `tail`. Every piece is on
// exactly one rank (a piece no rank has is empty). The offsets follow from every piece's length:
// the lengths are summed over the ranks (each rank knows only its own), then each rank writes its
// pieces with MPI-IO (MPI_File_write_at, MPI-3.1 standard §13.4.2) and the file is synced
// (MPI_File_sync) before it is closed. Rank 0 writes the head and the tail. Without MPI (one rank)
// the same is done with pwrite(2) and fsync(2).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace photometria {

// Called by every rank with the same path (an existing file: rank 0's AtomicOutput temporary),
// name (the target, for messages), count, head and tail. `mine`: (piece index, bytes) of this
// rank, pointers valid during the call. Throws Error(Io) "cannot write '<name>': ..." on every
// rank when any rank's write fails (ranks::agree).
void write_pieces(const std::string& path, const std::string& name, const std::string& head,
                  const std::vector<std::pair<int, const std::string*>>& mine, int count, const std::string& tail);

}  // namespace photometria
