// One image on several devices (common/render/coordinator.h): chunks of sample ranges cover
// the job once, in order, shared by speed; in reproducible mode N devices of one kind give one
// device's image bit for bit; PoCL and lavapipe together agree with one device statistically
// and seed for seed; a worker that counts a chunk twice is caught by both tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <future>
#include <thread>

#include "common/analysis/compare.h"
#include "common/error.h"
#include "common/render/coordinator.h"
#include "common/render/session.h"
#include "common/scene/builtin_scenes.h"

namespace mcpt {
namespace {

// A device that renders nothing: sums of one sample value, at a set speed.
class FakeWorker : public Worker {
  public:
    FakeWorker(std::string name, double spp_per_second, int fail_at = -1)
        : name_(std::move(name)), rate_(spp_per_second), fail_at_(fail_at) {}
    std::string name() const override { return name_; }
    void render(const Chunk& c) override {
        if (chunks_++ == fail_at_) throw DeviceLost("lost (planted)");
        ranges_.push_back({c.first, c.end});
        std::this_thread::sleep_for(std::chrono::duration<double>(double(c.end - c.first) / rate_));
        spp_ += c.end - c.first;
    }
    void add_round_to(RenderResult& total) override {
        if (spp_ == 0) return;
        RenderResult r;
        r.width = 2, r.height = 1, r.spp = spp_;
        r.sum.assign(6, double(spp_)), r.sum_sq.assign(6, double(spp_));
        r.nonfinite.assign(2, 0.0);
        accumulate_sums(total, r);
        spp_ = 0;
    }

    // The sample ranges of its chunks, as handed out.
    const std::vector<std::pair<uint64_t, uint64_t>>& ranges() const { return ranges_; }

  private:
    std::vector<std::pair<uint64_t, uint64_t>> ranges_;
    std::string name_;
    double rate_;
    int fail_at_, chunks_ = 0;
    uint64_t spp_ = 0;
};

// Sorted ranges [first, end) that cover [begin, end) exactly once, each non-empty and on
// multiples of `granule` (the last may end at `end`).
::testing::AssertionResult tiles(const std::vector<std::pair<uint64_t, uint64_t>>& ranges,
                                 uint64_t begin, uint64_t end, uint64_t granule) {
    uint64_t at = begin;
    for (const auto& [first, last] : ranges) {
        if (first != at)
            return ::testing::AssertionFailure()
                   << "a chunk starts at " << first << ", the one before ended at " << at;
        if (last <= first || first % granule != 0 || (last % granule != 0 && last != end))
            return ::testing::AssertionFailure() << "chunk [" << first << ", " << last << ")";
        at = last;
    }
    if (at != end) return ::testing::AssertionFailure() << "the chunks end at " << at;
    return ::testing::AssertionSuccess();
}

// A job's limits: ending at sample `end` (0: none) after `seconds` (0: none), in chunks of
// `chunk_seconds` starting at multiples of `granule`.
JobLimits limits(uint64_t end, double seconds, uint32_t granule, double chunk_seconds) {
    JobLimits lim;
    lim.end = end, lim.seconds = seconds, lim.granule = granule;
    lim.chunk_seconds = chunk_seconds;
    return lim;
}

TEST(Coordinator, ChunksCoverTheJobOnceSharedBySpeed) {
    FakeWorker fast("fast", 4000), slow("slow", 1000);
    RenderResult total;
    // Chunks of 0.05 s: each one's time holds a thread's wake-up after its sleep, which a loaded
    // machine stretches; at 0.02 s the fast device's chunks shrink toward one granule (4 ms of
    // samples) and a mean wake-up of ~12 ms can take its share below 0.6 (at 0.05 s: ~30 ms).
    Coordinator job(total, limits(2000, 0, 16, 0.05), {&fast, &slow});
    job.run();
    // Every sample once, in one prefix; each value counted once.
    EXPECT_EQ(total.first, 0u);
    EXPECT_EQ(total.spp, 2000u);
    EXPECT_EQ(total.sum[0], 2000.0);
    // The fast device took about 4/5 (its chunks sized to its speed).
    const double fast_share = double(job.stats()[0].samples) / 2000.0;
    EXPECT_GT(fast_share, 0.6);
    EXPECT_LT(fast_share, 0.95);
    EXPECT_EQ(job.stats()[0].samples + job.stats()[1].samples, 2000u);
    // The chunks' ranges tile [0, 2000) exactly (totals alone pass overlaps and gaps that add
    // up), each on granule boundaries, and both devices took some.
    std::vector<std::pair<uint64_t, uint64_t>> all = fast.ranges();
    all.insert(all.end(), slow.ranges().begin(), slow.ranges().end());
    std::sort(all.begin(), all.end());
    EXPECT_TRUE(tiles(all, 0, 2000, 16));
    EXPECT_FALSE(fast.ranges().empty());
    EXPECT_FALSE(slow.ranges().empty());
    // Controls: a gap and an overlap of one granule, the totals unchanged, are caught.
    auto gap = all, overlap = all;
    gap[1].first += 16, gap.back().second += 16;
    overlap[1].first -= 16, overlap.back().second -= 16;
    EXPECT_FALSE(tiles(gap, 0, 2000, 16));
    EXPECT_FALSE(tiles(overlap, 0, 2000, 16));
}

// A round with an end on devices of one speed: each takes a quarter in one chunk, and they
// end together (a device that asks first must not take more than its part).
TEST(Coordinator, EqualDevicesShareARoundInOneChunkEach) {
    FakeWorker a("a", 2000), b("b", 2000), c("c", 2000), d("d", 2000);
    RenderResult total;
    // Parts of 1 s: a thread that starts up to ~0.6 s after the others (the threads' start as
    // a loaded machine schedules it; parts of 0.1 s allowed ~60 ms) leaves them slivers shorter
    // than min_share_seconds, which they sit out.
    JobLimits lim = limits(8000, 0, 1, 2.0);
    lim.min_share_seconds = 0.5;
    Coordinator job(total, lim, {&a, &b, &c, &d}, {2000, 2000, 2000, 2000});
    job.run();
    EXPECT_EQ(total.spp, 8000u);
    for (const WorkerStats& s : job.stats()) {
        EXPECT_EQ(s.chunks, 1u) << s.name;
        EXPECT_NEAR(double(s.samples), 2000.0, 4.0) << s.name;
    }
}

// A round too short to share: the measured device renders it; devices not measured yet count
// at its speed and sit it out (joining costs a collection), but join a round worth it.
TEST(Coordinator, DevicesSitOutARoundTooShortToShare) {
    FakeWorker a("a", 1000), b("b", 1000), c("c", 1000), d("d", 1000);
    RenderResult total;
    JobLimits lim = limits(32, 0, 1, 0.5);
    lim.min_share_seconds = 0.05;  // 50 samples at their speed
    Coordinator tiny(total, lim, {&a, &b, &c, &d}, {1000});
    tiny.run();
    EXPECT_EQ(total.spp, 32u);
    EXPECT_EQ(tiny.stats()[0].samples, 32u);
    lim.end = 32 + 1600;  // 0.4 s each
    Coordinator large(total, lim, {&a, &b, &c, &d}, tiny.rates());
    large.run();
    EXPECT_EQ(total.spp, 1632u);
    for (const WorkerStats& s : large.stats()) EXPECT_GT(s.samples, 0u) << s.name;
}

// A short chunk's time is mostly its fixed cost: it may raise a device's speed, not lower it;
// a long one sets it (a device that slowed down).
TEST(Coordinator, ShortChunksMeasureSpeedFromBelow) {
    FakeWorker a("a", 1000);
    RenderResult total;
    Coordinator job(total, limits(1000, 0, 1, 0.5), {&a});
    job.done(0, {0, 10}, 0.01);
    EXPECT_DOUBLE_EQ(job.stats()[0].rate, 1000.0);
    job.done(0, {10, 11}, 0.005);  // 200 samples/s, short: a lower bound
    EXPECT_DOUBLE_EQ(job.stats()[0].rate, 1000.0);
    job.done(0, {11, 13}, 0.001);  // 2000 samples/s, short but faster
    EXPECT_DOUBLE_EQ(job.stats()[0].rate, 2000.0);
    job.done(0, {13, 113}, 0.2);  // 500 samples/s over 0.2 s
    EXPECT_DOUBLE_EQ(job.stats()[0].rate, 500.0);
}

TEST(Coordinator, AFailedDeviceEndsTheJobNamedKeepingAPrefix) {
    FakeWorker good("good", 2000), bad("bad", 2000, 8);
    RenderResult total;
    // A first round ends well (the bad device fails at its 9th chunk).
    Coordinator(total, limits(100000, 0.05, 1, 0.5), {&good, &bad}).run();
    const uint64_t first_round = total.spp;
    EXPECT_GT(first_round, 0u);
    Coordinator job(total, limits(100000, 0, 16, 0.01), {&good, &bad});
    try {
        job.run();
        FAIL() << "a lost device must end the job";
    } catch (const DeviceLost& e) {
        EXPECT_NE(std::string(e.what()).find("device 1 (bad)"), std::string::npos) << e.what();
    }
    // The failed round adds nothing: the image keeps the rounds before, each sample once.
    EXPECT_EQ(total.spp, first_round);
    EXPECT_EQ(total.sum[0], double(total.spp));
}

// A device that returns more samples than it was handed (a chunk counted twice) is refused.
TEST(Coordinator, SamplesNotHandedOutAreRefused) {
    class Greedy : public FakeWorker {
      public:
        using FakeWorker::FakeWorker;
        void add_round_to(RenderResult& total) override {
            FakeWorker::add_round_to(total);
            total.spp += 16;  // one more chunk than it rendered
        }
    } greedy("greedy", 4000);
    FakeWorker honest("honest", 4000);
    RenderResult total;
    const JobLimits lim = limits(256, 0, 16, 0.5);
    EXPECT_THROW(Coordinator(total, lim, {&honest, &greedy}).run(), Error);
    // Negative control: honest devices alone pass.
    FakeWorker other("other", 4000);
    RenderResult fine;
    Coordinator(fine, lim, {&honest, &other}).run();
    EXPECT_EQ(fine.spp, 256u);
}

TEST(Coordinator, TimeLimitEndsTheJobNearIt) {
    FakeWorker a("a", 1000), b("b", 500);
    RenderResult total;
    const JobLimits lim = limits(0, 0.3, 1, 0.05);
    const auto t0 = std::chrono::steady_clock::now();
    Coordinator job(total, lim, {&a, &b});
    job.run();
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Past the limit by at most a chunk (0.05 s), with room for a loaded machine.
    EXPECT_LT(t, lim.seconds + 0.3);
    EXPECT_GT(total.spp, 100u);
    EXPECT_EQ(total.sum[0], double(total.spp));
}

Scene small_cornell() {
    return make_builtin_scene("cornell");
}

void setup(Session& s, uint32_t seed, bool reproducible, const std::string& tree = "auto") {
    s.set_scene(small_cornell());
    s.settings().tree = tree;
    s.settings().width = 32, s.settings().height = 32;
    s.settings().seed = seed;
    s.settings().reproducible = reproducible;
    s.settings().chunk_seconds = 0.01;  // many chunks
}

bool bitwise_equal(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * 8) == 0;
}

// No tree and the BVH on both APIs (`auto` takes one on PoCL, the other on lavapipe).
TEST(SeveralDevices, ReproducibleIsOneDevicesImageBitForBit) {
    for (const std::string api : {"opencl", "vulkan"}) {
        std::vector<double> seed7;  // one device's sums, the control's reference
        for (const std::string tree : {"none", "bvh"}) {
            Session one(api);
            setup(one, 7, true, tree);
            one.render(1e9, 0, 96);
            seed7 = one.result().sum;
            Session three(std::vector<std::string>{api, api, api}, BackendOptions{});
            setup(three, 7, true, tree);
            three.render(1e9, 0, 96);
            EXPECT_EQ(three.spp(), 96u);
            EXPECT_TRUE(bitwise_equal(one.result().sum, three.result().sum)) << api << " " << tree;
            EXPECT_TRUE(bitwise_equal(one.result().sum_sq, three.result().sum_sq))
                << api << " " << tree;
            // Each of the three took chunks (one device doing all would give the same image).
            ASSERT_EQ(three.device_stats().size(), 3u);
            for (const WorkerStats& w : three.device_stats())
                EXPECT_GE(w.chunks, 1u) << api << " " << tree << ": " << w.name << " took no chunk";
        }
        // Negative control: another seed on one device differs (the check can fail).
        Session other(api);
        setup(other, 8, true, "bvh");
        other.render(1e9, 0, 96);
        EXPECT_FALSE(bitwise_equal(seed7, other.result().sum));
    }
}

// A device whose round's sums are added twice (their samples counted once): a defect the
// tests below must catch.
class DoubleCounting : public Worker {
  public:
    explicit DoubleCounting(Session& s) : s_(s) {}
    std::string name() const override { return "double-counting " + s_.device().name; }
    void render(const Chunk& c) override { s_.render_chunk(c.first, c.end); }
    void add_round_to(RenderResult& total) override {
        RenderResult mine;
        s_.add_round_to(mine);
        if (mine.spp == 0) return;
        RenderResult twice = mine;
        twice.spp = 0, twice.rays = 0, twice.nonfinite_total = 0;
        std::fill(twice.nonfinite.begin(), twice.nonfinite.end(), 0.0);
        accumulate_sums(total, mine);
        accumulate_sums(total, twice);
    }

  private:
    Session& s_;
};

// PoCL and lavapipe together (plus, for the control, a planted double-counting lavapipe)
// against PoCL alone: `batches` renders with independent seeds, 16 spp each.
RenderResult render_mixed(uint32_t seed, bool planted, Session* helper) {
    Session s(std::vector<std::string>{"opencl", "vulkan"}, BackendOptions{});
    setup(s, seed, false);
    s.settings().chunk_seconds = 0.002;
    if (planted) {
        setup(*helper, seed, false);
        s.add_worker(std::make_unique<DoubleCounting>(*helper));
    }
    s.render(1e9, 0, 16);
    EXPECT_GT(s.device_stats().at(1).chunks, 0u) << "lavapipe rendered nothing";
    return s.result();
}

TEST(SeveralDevices, PoclAndLavapipeTogetherAgreeWithOneDevice) {
    Session helper("vulkan");
    std::vector<RenderResult> single, mixed, planted;
    for (uint32_t b = 0; b < 16; ++b) {
        Session one("opencl");
        setup(one, 100 + b, false);
        one.render(1e9, 0, 16);
        single.push_back(one.result());
        mixed.push_back(render_mixed(500 + b, false, nullptr));
        planted.push_back(render_mixed(500 + b, true, &helper));
    }
    const Agreement honest = test_agreement(batch_means(single), batch_means(mixed), 0.01);
    const Agreement biased = test_agreement(batch_means(single), batch_means(planted), 0.01);
    std::printf("honest: %s\nplanted: %s\n", honest.verdict().c_str(), biased.verdict().c_str());
    EXPECT_TRUE(honest.agree);
    EXPECT_FALSE(biased.agree) << "a double-counted chunk went unnoticed";
    // Seed for seed: the same samples on other devices differ only by rounding.
    Session one("opencl");
    setup(one, 500, false);
    one.render(1e9, 0, 16);
    const SameSeedDiff same = same_seed_diff(one.result(), mixed[0]);
    const SameSeedDiff twice = same_seed_diff(one.result(), planted[0]);
    std::printf("same seed: %.3f%% diverged; planted: %.3f%%\n", 100 * same.fraction_diverged(),
                100 * twice.fraction_diverged());
    EXPECT_TRUE(same.agree());
    EXPECT_FALSE(twice.agree());
}

// compare's devices that open late: a device joins the batches when ready (here ready at once,
// the first device kept busy meanwhile, so that it takes some), each batch its seed's render
// whoever makes it; one never ready is not waited for; one that failed to open fails them.
TEST(SeveralDevices, BatchesOnDevicesThatJoinWhenReady) {
    // Reproducible sums: a batch's bits do not depend on how its loop split it into passes.
    BatchOptions bo;
    bo.batches = 6;
    bo.spp_per_batch = kReproducibleGroupSpp;
    Session first("opencl");
    setup(first, 1, true);
    const BatchSet alone = render_batches(first, bo);
    ASSERT_EQ(alone.per_device, std::vector<int>{6});
    const auto joining = [](std::promise<std::shared_ptr<Session>>& p) {
        return JoiningSession{"opencl (joining)", p.get_future().share()};
    };
    // Ready at once: it renders batches while the first device is held up.
    std::promise<std::shared_ptr<Session>> ready;
    auto second = std::make_shared<Session>("opencl");
    setup(*second, 1, true);
    ready.set_value(second);
    const auto held_up = [](Session&) {
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
    };
    const BatchSet joined = render_batches({&first}, bo, held_up, {}, {joining(ready)});
    ASSERT_EQ(joined.per_device.size(), 2u);
    EXPECT_EQ(joined.per_device[0] + joined.per_device[1], 6);
    EXPECT_GE(joined.per_device[1], 1) << "the ready device took no batch";
    EXPECT_TRUE(bitwise_equal(alone.mean, joined.mean));
    EXPECT_TRUE(bitwise_equal(alone.var, joined.var));
    // Never ready during the batches: they end without it.
    std::promise<std::shared_ptr<Session>> late;
    const BatchSet without = render_batches({&first}, bo, {}, {}, {joining(late)});
    EXPECT_EQ(without.per_device, (std::vector<int>{6, 0}));
    EXPECT_TRUE(bitwise_equal(alone.mean, without.mean));
    late.set_value(second);
    // Failed to open: the batches fail, naming it.
    std::promise<std::shared_ptr<Session>> failed;
    failed.set_exception(std::make_exception_ptr(Error("no such device")));
    try {
        render_batches({&first}, bo, held_up, {}, {joining(failed)});
        ADD_FAILURE() << "a device that failed to open went unnoticed";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("opencl (joining)"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("no such device"), std::string::npos) << e.what();
    }
}

// A new seed (or light scale) restarts the session's loop instead of making a new one (which
// starts from small dispatches): the same loop, its dispatches counted on, and the image of
// that seed bit for bit (reproducible), whatever was rendered before.
TEST(SessionBatches, NewSeedRestartsTheLoopWithItsTimings) {
    Session s("opencl");
    setup(s, 1, true);
    const auto render = [&](uint32_t seed, float light_scale, uint64_t spp) {
        s.settings().seed = seed, s.settings().light_scale = light_scale;
        s.reset();
        s.render(1e9, 0, spp);
        return s.result().sum;
    };
    // The loop's dispatches count on across restarts; a new loop's count its own (a first
    // render of 4 groups takes more dispatches than a fresh one of 1 would).
    const std::vector<double> first = render(1, 1.f, 4 * kReproducibleGroupSpp);
    const uint64_t d1 = s.loop()->dispatches();
    const std::vector<double> other = render(2, 1.f, kReproducibleGroupSpp);
    EXPECT_GT(s.loop()->dispatches(), d1) << "a new seed made a new loop";
    const std::vector<double> again = render(1, 1.f, 4 * kReproducibleGroupSpp);
    EXPECT_TRUE(bitwise_equal(first, again));
    EXPECT_FALSE(bitwise_equal(first, other));  // the control: another seed differs
    // A new seed without reset() starts over too (the restart zeroes what reset() did not).
    s.settings().seed = 2;
    s.render(1e9, 0, kReproducibleGroupSpp);
    EXPECT_TRUE(bitwise_equal(other, s.result().sum));
    const std::vector<double> brighter = render(1, 2.f, 4 * kReproducibleGroupSpp);
    double lo = 1e30, hi = 0;
    for (size_t i = 0; i < first.size(); ++i)
        if (first[i] > 0)
            lo = std::min(lo, brighter[i] / first[i]), hi = std::max(hi, brighter[i] / first[i]);
    EXPECT_NEAR(lo, 2.0, 1e-5) << "the light scale did not reach the restarted loop";
    EXPECT_NEAR(hi, 2.0, 1e-5);
    // Anything else the device depends on makes a new loop.
    const uint64_t before = s.loop()->dispatches();
    s.settings().max_depth = 3;
    render(1, 1.f, kReproducibleGroupSpp);
    EXPECT_LT(s.loop()->dispatches(), before);
}

TEST(SeveralDevices, RefusesWhatOneDeviceMust) {
    Session s(std::vector<std::string>{"opencl", "opencl"}, BackendOptions{});
    setup(s, 1, true);
    EXPECT_THROW(s.render(1e9, 0, 40), Error);  // not whole groups of 16
    setup(s, 1, false);
    s.settings().adaptive = true;
    EXPECT_THROW(s.render(1e9, 0, 32), Error);
}

}  // namespace
}  // namespace mcpt
