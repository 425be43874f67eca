// mcpt under mpirun: rank 0 holds the image and coordinates (coordinator.h); every rank, rank
// 0 included, renders chunks of samples on its own device. Without MPI in the build, or when
// not started by mpirun, a job of one rank.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "common/analysis/compare.h"
#include "common/render/checkpoint.h"
#include "common/render/coordinator.h"
#include "common/render/session.h"

namespace mcpt {

struct MpiJob {
    int rank = 0, size = 1;
    int local_rank = 0;  // the rank among those on this host (picks its GPU)
};

// Starts MPI when mpirun started this process (its environment says so); the job, also
// without. Call once, first thing; mpi_finish() at exit.
const MpiJob& mpi_start(int& argc, char**& argv);
const MpiJob& mpi_job();
void mpi_finish();

// Ends every rank of the job with `code` (a rank failed).
[[noreturn]] void mpi_abort(int code);

// The device a rank takes when --device names none: the backend's GPU at its local rank
// (modulo the GPUs there), else its first device.
std::string rank_device(const std::string& backend, const MpiJob& job);

// What rank 0 checks every other rank's messages against.
struct RankJob {
    int width = 0, height = 0;
    bool exact = false;           // reproducible: exact sums
    double timeout_floor_s = 30;  // the least time a rank is given to answer (--rank-timeout)
    bool flat_reduction = false;  // --reduction flat: rank 0 adds every rank's sums in turn
};

// Rank 0: a worker for each other rank, once each said which device it has and that it was
// started for this job (`job_fingerprint`, the device aside; a mismatch is an error naming
// the rank and what differs). Each worker validates what its rank sends against `job` and
// gives each chunk a deadline: the larger of the floor and ten times its expected time at
// the rank's measured speed (its first chunk: ten times the floor); a rank that misses it
// (hung, stopped) ends the job, named. A
// round's sums come up a binomial tree (mpi_wire.h): rank 0 receives log2(N) messages, each
// checked against what the ranks it holds were handed, by the floor plus a transfer time.
std::vector<std::unique_ptr<Worker>> mpi_remote_workers(const Fingerprint& job_fingerprint,
                                                        const RankJob& job);

// Rank 0 of `compare`: a batch renderer for each other rank, after the same greeting as
// mpi_remote_workers(). Each batch gets the deadline a chunk gets; a renderer's end tells its
// rank to stop.
std::vector<std::unique_ptr<BatchRenderer>> mpi_batch_renderers(
    const Fingerprint& job_fingerprint, const RankJob& job);

// Ranks above 0 of `compare`: renders the batches rank 0 asks for on `session` until it says
// stop; a failure goes to rank 0 with its message.
void mpi_serve_batches(Session& session);

// Ranks above 0: renders the chunks rank 0 hands out on `session` until it says stop; a
// failure goes to rank 0 with its message. `flat_reduction` as rank 0's (checked).
void mpi_serve(Session& session, bool flat_reduction);

}  // namespace mcpt
