// The messages of an MPI job (mpi_job.h), checked on receipt: tags, the lock that serializes
// rank 0's MPI calls, waits with deadlines, and a round's sums: sent as a header and arrays,
// received checked against the job before anything is allocated from them, and added over a
// binomial tree, so that rank 0 receives log2(N) messages a round instead of N - 1. Exact
// (reproducible) sums give the same bits in any order, so the tree's image is the serial one.
#pragma once
#ifdef MCPT_WITH_MPI
#include <mpi.h>

#include <chrono>
#include <cstdint>
#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "app/reduction_tree.h"
#include "common/analysis/compare.h"
#include "common/render/render_loop.h"

namespace mcpt::wire {

enum Tag : int {
    kHello = 1,   // rank -> 0: its device's name, a newline, its job's fingerprint
    kChunk = 2,   // 0 -> rank: first, end (end 0: stop)
    kDone = 3,    // rank -> 0: the chunk is rendered
    kRound = 4,   // 0 -> rank: the round ends; add the sums up the tree
    kResult = 5,  // rank -> its parent in the tree: the sums it holds (header, then arrays)
    kError = 6,   // rank -> 0: why it failed (first byte 1: its device was lost)
    kBatch = 7,   // 0 -> rank: a batch's seed and samples per pixel (0: stop)
    kBatchMean = 8,  // rank -> 0: the batch's mean per pixel (header, then the array)
};

// The longest hello or error message taken.
constexpr int kMaxText = 1 << 16;

using Clock = std::chrono::steady_clock;

// MPI calls from several threads of rank 0 (MPI_THREAD_SERIALIZED): one at a time.
std::mutex& lock();

std::string rank_name(int rank);
// Waits for the next message from `rank` without holding the lock (other ranks' threads go
// on), up to `deadline`; false when none came by then.
bool wait_for(int rank, Clock::time_point deadline, MPI_Status& st);
// The byte count of a probed message.
int count_of(const MPI_Status& st);
// Receives a probed text message of at most kMaxText bytes; throws mcpt::Error if longer.
std::string receive_text(int rank, const MPI_Status& st);
// A rank's probed failure message, thrown as the exception it stands for.
[[noreturn]] void throw_rank_error(int rank, const MPI_Status& st);
// This rank's failure, to rank 0.
void send_error(const std::exception& e, bool lost);

// What every rank's sums must be.
struct SumsShape {
    int width = 0, height = 0;
    bool exact = false;  // reproducible: exact sums (and no double sums) travel
};

// Sends sums (spp 0: the header alone) to `to` as kResult.
void send_sums(const RenderResult& r, int to, bool bad_size = false);
// Any count of samples per pixel (receive_sums' `spp` on ranks that do not know what their
// children were handed).
constexpr uint64_t kAnySpp = UINT64_MAX;
// Receives sums from `from` into `out` (its arrays reused), each message's tag and size
// checked, the header against `shape` and `spp` (exactly the samples handed out to the ranks
// they speak for, unless kAnySpp), up to `deadline` (false: none came in time, or not whole).
// A kError from `from` is thrown as its exception; anything else that does not fit throws
// mcpt::Error beginning with `who`.
bool receive_sums(int from, const SumsShape& shape, uint64_t spp, Clock::time_point deadline,
                  const std::string& who, RenderResult& out);

// A batch of `compare` (compare.h) to rank 0 (`bad_size`: a header of another width, for
// fault injection).
void send_batch_mean(const BatchMean& batch, bool bad_size = false);
// Receives the batch `from` renders, checked: tags and sizes, the image size, `spp` samples
// per pixel, counts in range, every mean finite; up to `deadline` (false: none came in time).
// A kError is thrown as its exception; anything else that does not fit throws mcpt::Error
// beginning with `who`.
bool receive_batch_mean(int from, int width, int height, uint64_t spp,
                        Clock::time_point deadline, const std::string& who, BatchMean& out);

}  // namespace mcpt::wire
#endif
