// A render session: one device, one scene, progressive passes accumulated in double
// precision, the error estimate and the image. What the commands and the C API drive.
//
// Use: open on a device, set_scene(), change settings(), then render() as often as wanted;
// a settings or scene change takes effect (and restarts accumulation) at the next render().
// Thread safety: none inside; one thread at a time, except cancel() from any thread.
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/render/backend.h"
#include "common/render/checkpoint.h"
#include "common/render/coordinator.h"
#include "common/render/gpu_scene.h"
#include "common/render/render_loop.h"
#include "common/scene/scene.h"

namespace mcpt {

constexpr uint32_t kReproducibleGroupSpp = 16;

struct SessionSettings {
    int width = 256, height = 256;
    int max_depth = -1;         // bounces; -1: the scene's default (default_max_depth)
    std::string tree = "auto";  // auto | sah | median | none
    int tree_depth = -1;        // tree depth limit; -1: the kind's default
    uint32_t seed = 0;
    bool specialize = true;  // compile only the features the scene uses
    // "sobol": Owen-scrambled Sobol points (the default); "independent": independent uniforms
    // (the sampler before Sobol, for A/B measurements).
    std::string sampler = "sobol";
    // Samples reach the double sums in fixed groups (kReproducibleGroupSpp, by sample index),
    // so the image depends only on the seed, the sample count and the device, not on how
    // passes were timed: checkpoints resume bit for bit (render_loop.h, group_spp).
    bool reproducible = false;
    // Adaptive sampling (render_loop.h): samples where the estimated noise is; spp is then
    // the mean over pixels. Not with `reproducible`, nor in checkpoints.
    bool adaptive = false;
    double dispatch_ms = 0;  // target duration of one dispatch; 0: the device's own
    float light_scale = 1.f;  // negative controls only
    // Several devices (coordinator.h): a chunk's target duration on the device that takes it.
    double chunk_seconds = 0.5;
};

// A part of a job split over runs that share nothing (job arrays): samples [first, end) of
// job_spp. Its checkpoint says so; mcpt merge adds the parts (parts.h).
struct SamplePart {
    uint64_t first = 0, end = 0;
    uint64_t job_spp = 0;  // 0: not a part, the whole render
};

// What one render() call did.
struct PassStats {
    uint64_t samples = 0;         // samples per pixel this call added
    uint64_t spp = 0;             // samples per pixel in the image
    double seconds = 0;           // wall time of this call
    double relative_error = 0;    // RenderResult::relative_error() after it
    bool cancelled = false;       // stopped by cancel()
    bool target_reached = false;  // relative_error <= the target asked for
};

class Session {
  public:
    // Opens the device of `spec` ("opencl", "vulkan:1", see device_registry.h).
    explicit Session(const std::string& device_spec, BackendOptions options = {});
    // Several devices on one image (coordinator.h): the first holds the image, every one
    // renders chunks of its samples. One spec is the same as the constructor above.
    Session(const std::vector<std::string>& device_specs, BackendOptions options);
    explicit Session(std::unique_ptr<Backend> backend);
    ~Session();

    Backend& backend() { return *backend_; }
    const DeviceInfo& device() const { return backend_->device(); }
    // Renders chunks of this session's image too (an MPI rank, coordinator.h); the session
    // takes it. Commits again at the next render().
    void add_worker(std::unique_ptr<Worker> worker);
    // Lets every worker added so go (an MPI rank's job ends); commits again at the next render().
    void remove_workers();
    // The devices rendering this image: this session's first, then the others.
    size_t device_count() const { return 1 + helpers_.size() + remote_.size(); }
    std::vector<std::string> device_names() const;
    // The shortest render() budget that keeps the work of its end (reading the sums back,
    // the error estimate; on several devices collecting a round's sums, coordinator.h) at
    // 4% or less: as measured on the last call. Callers that render in steps (a progress bar)
    // step by at least this.
    double step_seconds() const;
    // Several devices: rounds since the accumulation began, and the seconds spent collecting
    // their sums (every device waits meanwhile).
    uint64_t rounds() const { return rounds_; }
    double collect_seconds() const { return collect_total_s_; }
    // One device: the read-backs render() made (the sums to the host, with the error
    // estimate), and the seconds they took, since the session began.
    uint64_t readbacks() const { return readbacks_; }
    double readback_seconds() const { return readback_total_s_; }
    // Per device, what it rendered since the accumulation began; empty on one device.
    const std::vector<WorkerStats>& device_stats() const { return device_stats_; }

    // A validated scene (scene_load.h); replaces the previous one.
    void set_scene(Scene scene);
    bool has_scene() const { return has_scene_; }
    // Lights this scene, and every scene set after, with `env` (an environment map or a
    // constant background; Environment{} removes it). A scene whose lamps were picked by
    // contribution (Scene::light_by_contribution) and now has an environment takes the tree
    // or power, as --light-sampling auto would.
    void set_environment(Environment env);
    const Scene& scene() const { return scene_; }

    // Changes take effect at the next render().
    SessionSettings& settings() { return settings_; }
    const SessionSettings& settings() const { return settings_; }
    // The bounce limit in effect: settings().max_depth or the scene's default.
    int max_depth() const;

    // Prepares the scene for the device (tree, layout, limits) and compiles: done by
    // render() when needed; call it to pay the cost up front. Throws mcpt::Error.
    void commit();

    // Renders passes for about budget_ms (at least one pass; a pass is never split), stopping
    // early at max_spp samples per pixel in the image (0: no cap), when the relative error
    // reaches target_error (0: none), or on cancel(). The image is current afterwards.
    // Samples reach the host at least once a second (for an image whose read-back takes
    // longer than 0.1 s: every ten read-backs' time); if the device fails meanwhile, render()
    // throws (mcpt::DeviceLost when it stopped) and the image keeps every sample read back
    // before: it can still be read and written. After DeviceLost the session renders no more.
    PassStats render(double budget_ms, double target_error = 0, uint64_t max_spp = 0);

    // Ends a running render() after its current pass; any thread. A render() that starts
    // later is not affected.
    void cancel() { cancel_.store(true); }

    // A device of a job on several (coordinator.h): renders samples [first, end) of every
    // pixel on this session's device alone, into the round's sums (not the image). `first`
    // must be a multiple of kReproducibleGroupSpp when reproducible.
    void render_chunk(uint64_t first, uint64_t end);
    // The round's chunks are done: reads its sums back (Worker::finish_round).
    void finish_round();
    // Adds the round's sums to `total` (coordinator.h, Worker::add_round_to) and starts a new
    // round.
    void add_round_to(RenderResult& total);
    // The round's sums, read back (nullptr: no chunk since the last round), for the
    // coordinator to add; start_round() then starts a new round (Worker::round_sums).
    const RenderResult* round_sums();
    void start_round();

    // Drops the samples taken (the next render() starts from zero).
    void reset();
    // Renders only `part` from now on (takes effect, and restarts accumulation, at the next
    // render()): its sums begin at part.first, render()'s max_spp counts from there.
    void set_part(const SamplePart& part);
    const SamplePart& part() const { return part_; }

    // The prepared scene (tree kind and why, features); valid after commit().
    const GpuScene& prepared() const { return prepared_; }
    bool committed() const { return !dirty_; }
    // Whether the next render() commits first (the scene or a setting changed): result()
    // is then replaced, and references to it dangle.
    bool needs_commit() const;
    // The accumulated result (sums, spp, rays, seconds of render() calls); empty before. On
    // several devices: the samples every device rendered, added.
    const RenderResult& result() const;
    // The render loop of the current accumulation (dispatch timings); null before render().
    const ProgressiveRender* loop() const { return progressive_.get(); }
    uint64_t spp() const { return result().spp; }

    // The image: linear radiance RGBA (alpha 1), or 8-bit sRGB RGBA (exposure 1, clamped),
    // top row first. Writes .exr (linear) or .png (sRGB).
    std::vector<float> image_rgba32f() const;
    std::vector<uint8_t> image_rgba8() const;
    void write_image(const std::string& path) const;
    // Writes the accumulation (sums, squared sums, invalid counts, the sample index reached)
    // with the scene's and the settings' fingerprint to `path`, atomically (checkpoint.h). In
    // reproducible mode it holds the samples up to the last group end. Throws mcpt::Error.
    void save_checkpoint(const std::string& path);
    // Continues the accumulation a checkpoint holds (commits first if needed): the next
    // render() adds to it. Throws mcpt::Error naming what differs (version, scene, an option,
    // the device) or that the file is truncated or corrupted; the session is then unchanged.
    void resume_checkpoint(const std::string& path);
    // What a checkpoint of this session is written for (version, scene and its lighting,
    // every setting that changes the image, the devices, the part): what parts of one job
    // and the ranks of an MPI job must share.
    Fingerprint fingerprint() const;

  private:
    void keep_light_choice_possible();
    PassStats render_on_devices(double budget_s, double target_error, uint64_t max_spp);
    bool round_open_ = false;     // render_chunk() added samples since add_round_to()
    bool round_flushed_ = false;  // and finish_round() read them back
    double reduce_seconds_ = 0;   // collecting the last round's sums
    double collect_s_ = 0;        // one device: the last read-back and error estimate
    uint64_t readbacks_ = 0;
    double readback_total_s_ = 0;
    uint64_t rounds_ = 0;
    double collect_total_s_ = 0;
    double round_seconds() const;
    void add_stats(const std::vector<WorkerStats>& job);
    bool several() const { return !helpers_.empty() || !remote_.empty(); }
    std::unique_ptr<Backend> backend_;
    std::vector<std::unique_ptr<Session>> helpers_;  // the other devices of this process
    std::vector<std::unique_ptr<Worker>> remote_;    // devices elsewhere (MPI ranks)
    RenderResult total_;                             // several devices: the image's sums
    std::vector<double> rates_;                      // several devices: their speeds
    std::vector<WorkerStats> device_stats_;
    SamplePart part_;
    Scene scene_;
    bool has_scene_ = false;
    Environment environment_;
    SessionSettings settings_;
    SessionSettings committed_settings_;
    bool dirty_ = true;
    // The backend holds the scene as loaded_settings_ asked (commit() loads it again only
    // when what the device depends on changed).
    bool loaded_ = false;
    SessionSettings loaded_settings_;
    GpuScene prepared_;
    std::unique_ptr<ProgressiveRender> progressive_;
    RenderResult empty_;
    std::atomic<bool> cancel_{false};
    std::string lost_;  // why the device stopped; empty while it works
};

// Commits every session at once, on threads of their own (trees and kernels). Throws
// mcpt::Error naming the first that failed: "device K (its label): why", K counted from
// `first_number`.
void commit_all(const std::vector<Session*>& sessions, size_t first_number = 0);

// Where render_until() stops: samples per pixel, seconds of rendering (a resumed render's
// included), a relative error; 0: no limit of that kind (at least one is needed).
struct RenderGoal {
    uint64_t spp = 0;
    double seconds = 0;
    double target_error = 0;
    // Each step (a Session::render() call, which ends with a read-back) lasts at most this,
    // unless Session::step_seconds() asks for longer.
    double step_seconds = 1.0;
    // Set: no step starts once it is true (a job's cancel, between steps of a second or so).
    const std::atomic<bool>* cancel = nullptr;
};

// The loop of `mcpt render` and `mcpt bench --throughput`: Session::render() in steps until
// the goal is reached, calling after_step (if set) after each. Returns the last step's stats.
PassStats render_until(Session& session, const RenderGoal& goal,
                       const std::function<void(const PassStats&)>& after_step = {});

}  // namespace mcpt
