// The error curve as a library call: progressive renders on one device list after another,
// their error against a reference (exact, or a cached high-sample render) at checkpoints, the
// log-log fits, the bias flag and the time to each target error. `mcpt converge`, the C API
// (mcpt_converge_*) and the Java Converge class are its clients.
#pragma once
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/analysis/convergence.h"
#include "common/render/session.h"
#include "common/scene/scene.h"

namespace mcpt {

// The devices of one run (of each sampler and sampling): one image on all of them.
struct ConvergeDevices {
    std::vector<std::string> specs;
    bool with_ranks = false;  // the other ranks of an MPI job render it too
    // A run on the first device alone beside its twin on all of them: it takes its twin's
    // seeds, so the two curves differ in time only, not in one seed's luck.
    bool beside = false;
};

// Each backend's runs: on its devices (`devices` empty: the backend's best), and with
// `beside_one` on the first of several alone too.
std::vector<ConvergeDevices> converge_devices(const std::vector<std::string>& backends,
                                              const std::vector<std::string>& devices,
                                              bool beside_one);

struct ConvergeSpec {
    std::shared_ptr<const Scene> scene;  // lit, its lights chosen
    std::string label;                   // the scene's name in messages and reports
    std::vector<ConvergeDevices> runs{{{"opencl"}}};
    int width = 256, height = 256;
    double seconds = 10;   // render time per run
    uint64_t max_spp = 0;  // also stop at this many samples per pixel (0: no limit)
    Schedule schedule = Schedule::SppDoubling;
    std::string reference = "auto";  // auto (exact when known, else cached), exact, cached
    uint64_t reference_spp = 1024;
    std::string reference_device;             // renders a new reference; "": the first run's first
    std::vector<double> targets{0.10, 0.05};  // relative RMSE for time-to-error
    int max_depth = -1;
    std::string tree = "auto";
    uint32_t seed = 1;                             // of the first run; each further run adds 100000
    std::vector<std::string> samplers{"sobol"};    // sobol | independent: a run each
    std::vector<std::string> sampling{"uniform"};  // uniform | adaptive: a run each
    bool keep_images = false;                      // ConvergeRun::image
    // What the job tells as it goes (each optional).
    std::function<void(const std::string& message)> on_reference;  // a new one is rendered
    std::function<void(double fraction, double seconds)> reference_progress;
    std::function<void(const struct ConvergeResult&)> on_ready;  // the reference is at hand
    std::function<void(const struct ConvergeRun&, const Checkpoint&)> on_checkpoint;
    std::function<void(const struct ConvergeRun&, const Session&)> on_run_end;
    // Devices elsewhere (MPI ranks) that join a run `with_ranks`.
    std::function<std::vector<std::unique_ptr<Worker>>(Session&)> remote;
};

struct ConvergeRun {
    std::string backend, device;  // "opencl x2/independent", "pthread-haswell + ..."
    size_t devices = 1;
    std::vector<Checkpoint> checkpoints;
    ConvergenceReport report;
    std::vector<TimeToError> time_to_target;  // one per ConvergeSpec::targets
    std::vector<float> image;                 // the final mean, 3 floats a pixel (keep_images)
};

struct ConvergeResult {
    std::string label;
    int width = 0, height = 0;
    uint32_t max_depth = 0;
    std::vector<double> targets;
    Reference reference;
    std::vector<ConvergeRun> runs;
    bool cancelled = false;
    bool biased() const;
    std::string settings;  // one line: scene, size, bounces, schedule, budget
};

// Runs the curves. Thread-safe cancel(): the run under way ends after its current step (its
// checkpoints so far kept, measured and fitted), no more start. Throws mcpt::Error.
class ConvergeJob {
  public:
    explicit ConvergeJob(ConvergeSpec spec);
    ConvergeResult run();
    // Ranks above 0 of an MPI job: each run with ranks, its session handed to `serve` (the
    // transport) once per sampler and sampling, as rank 0 runs them.
    void serve(const std::function<void(Session&)>& serve);
    void cancel();

  private:
    std::unique_ptr<Session> open_session(const ConvergeDevices& devices) const;
    Reference make_reference(const GpuScene& packed, uint32_t max_depth);
    ConvergeSpec spec_;
    std::atomic<bool> cancel_{false};
    std::mutex running_mutex_;
    Session* running_ = nullptr;  // the session rendering now, for cancel()
};

}  // namespace mcpt
