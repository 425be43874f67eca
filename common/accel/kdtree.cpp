// k-d tree construction for common/kdtree.h.
//
// TreeKind::Sah: pbrt-v3 KdTreeAccel costs and termination rules (leaf at max depth, at
// <= max_leaf_prims triangles, when the best split costs over 4x the leaf with < 16 triangles,
// or after 3 bad refines), built in O(N log N) by a hybrid split search over all three axes:
//  - nodes with more than kExactMax references: binned SAH. One pass counts each reference's
//    first and last bin per axis, with up to kBins bins spanning the union of the references
//    (so its ends are exact empty-space cuts); the bin boundaries are swept, and the best one
//    is refined by an exact sweep over the events that fall in the two bins around it.
//  - smaller nodes: exact SAH, sorting the bound events per axis and sweeping every position
//    (Wald & Havran 2006 event order at one position: end, planar, start).
// Triangles lying in the split plane go to both children (so do references in the sweeps). A
// triangle straddling the split is clipped to each child box (Sutherland-Hodgman, bounds
// widened by a few ulps to stay conservative): "perfect splits", which shrink references and
// cut duplication by about a third.
//
// TreeKind::Median: the 2015 thesis baseline: split at the median triangle centroid, axes in
// turn (x, y, z, x, ...), to exactly max_depth levels unless a node holds <= 1 triangle; a
// triangle goes to every child its bounds overlap (both when it lies in the plane).
// TreeKind::None: one leaf with every triangle.
//
// Both trees come out of one engine (here; the split rules in kdtree_split.cpp). A worker builds a
// subtree depth-first with an explicit stack, the references of pending nodes in one array (split
// in place); an above child with many references becomes a job for another worker, linked in later.
// Every split depends only on the node's own references, and the final pre-order flattening follows
// the tree, not the schedule, so the output is the same for every thread count.
#include "common/accel/kdtree.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <system_error>
#include <thread>

#include "common/accel/kdtree_split.h"
#include "common/accel/wide_bvh.h"
#include "common/error.h"
#include "common/io/host_cpus.h"

namespace mcpt {

namespace {

constexpr int kMaxTreeDepth = 63;     // stack_size() stays within the device default, 64
constexpr size_t kHandOffMin = 4096;  // a child this large becomes another worker's job
constexpr size_t kMinEntryLimit = size_t(1) << 24;  // runaway guard on nodes + references:
constexpr size_t kEntriesPerTriangle = 64;          // max(2^24, 64 N)

using kdbuild::Box;
using kdbuild::Ref;
using kdbuild::Scratch;
using kdbuild::Split;
using kdbuild::SplitRule;

Box empty_box() {
    const float inf = std::numeric_limits<float>::infinity();
    return {{inf, inf, inf}, {-inf, -inf, -inf}};
}

inline void extend(Box& b, const Ref& r) {
    for (int a = 0; a < 3; ++a)
        b.lo[a] = std::min(b.lo[a], r.lo[a]), b.hi[a] = std::max(b.hi[a], r.hi[a]);
}

uint32_t float_bits(float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

// Bounds of the part of triangle t inside box b (Sutherland-Hodgman), widened by a few ulps
// of the triangle's coordinates so rounding in the clipped vertices cannot shrink them;
// false when nothing is left.
bool clip_triangle(const Triangle& t, const Box& b, Box& out) {
    // Exact arithmetic adds at most one vertex per plane (9 in all); rounded vertices can make
    // the polygon cross a later plane more often, and extreme coordinates give non-finite
    // ones: past 16 vertices or at a non-finite one, keep the triangle's bounds within the box
    // (larger, never wrong; a stack overflow found by the glTF fuzz target).
    constexpr int kMaxVertices = 16;
    const auto unclipped = [&] {
        for (int a = 0; a < 3; ++a) {
            out.lo[a] = std::max(b.lo[a], std::min({t.v0[a], t.v1[a], t.v2[a]}));
            out.hi[a] = std::min(b.hi[a], std::max({t.v0[a], t.v1[a], t.v2[a]}));
            if (!(out.lo[a] <= out.hi[a])) return false;
        }
        return true;
    };
    glm::vec3 poly[2][kMaxVertices] = {{t.v0, t.v1, t.v2}};
    int n = 3, cur = 0;
    for (int a = 0; a < 3; ++a) {
        for (int side = 0; side < 2; ++side) {
            const float plane = side ? b.hi[a] : b.lo[a];
            const auto inside = [&](const glm::vec3& v) {
                return side ? v[a] <= plane : v[a] >= plane;
            };
            // Skip planes the polygon lies inside of.
            bool all_inside = true;
            for (int i = 0; i < n; ++i) all_inside = all_inside && inside(poly[cur][i]);
            if (all_inside) continue;
            // Keep the inside part, adding a vertex where an edge crosses the plane.
            int m = 0;
            const int next = cur ^ 1;
            for (int i = 0; i < n; ++i) {
                const glm::vec3& p = poly[cur][i];
                const glm::vec3& q = poly[cur][(i + 1) % n];
                const bool p_in = inside(p), q_in = inside(q);
                if (m + 2 > kMaxVertices) return unclipped();
                if (p_in) poly[next][m++] = p;
                if (p_in != q_in) {
                    glm::vec3 v = p + (q - p) * ((plane - p[a]) / (q[a] - p[a]));
                    v[a] = plane;
                    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
                        return unclipped();
                    poly[next][m++] = v;
                }
            }
            n = m, cur = next;
            if (n == 0) return false;
        }
    }
    // Bounds, widened.
    for (int a = 0; a < 3; ++a) {
        float lo = poly[cur][0][a], hi = lo;
        for (int i = 1; i < n; ++i)
            lo = std::min(lo, poly[cur][i][a]), hi = std::max(hi, poly[cur][i][a]);
        const float mag = std::max({std::fabs(t.v0[a]), std::fabs(t.v1[a]), std::fabs(t.v2[a])});
        out.lo[a] = lo - 4e-6f * mag;
        out.hi[a] = hi + 4e-6f * mag;
    }
    return true;
}

// Builds subtrees depth-first on a pool of workers and flattens them in pre-order.
class Engine {
  public:
    Engine(const std::vector<Triangle>& tris, const SplitRule& rule, int threads)
        : tris_(tris),
          rule_(rule),
          threads_(std::max(threads, 1)),
          entry_limit_(std::max(kMinEntryLimit, kEntriesPerTriangle * tris.size())) {}

    void run(std::vector<Ref> refs, const Box& box, KdTree& tree) {
        // Root job, then every worker (this thread included) drains the queue.
        enqueue(Job{std::move(refs), box, box, 0, 0, nullptr});
        std::vector<std::thread> pool;
        try {
            for (int i = 1; i < threads_; ++i) pool.emplace_back([this] { worker(); });
        } catch (const std::system_error&) {
            // Fewer threads than asked for: the ones running finish the work.
        }
        worker();
        for (std::thread& t : pool) t.join();
        if (error_) std::rethrow_exception(error_);
        flatten(tree);
    }

  private:
    enum : uint8_t { kLeafKind = 3, kLinkKind = 4 };  // kinds 0-2: interior on that axis
    // Interior: a = split bits, b = local above index; leaf: a = first local index, b = count;
    // link: a = the subtree that continues here.
    struct LocalNode {
        uint32_t a, b;
        uint8_t kind;
    };
    struct Subtree {
        std::vector<LocalNode> nodes;  // pre-order
        std::vector<uint32_t> indices;
    };
    struct Job {
        std::vector<Ref> refs;
        Box box, refs_union;
        int depth, bad_refines;
        Subtree* out;
    };

    uint32_t enqueue(Job job) {
        std::lock_guard<std::mutex> lock(mu_);
        const uint32_t id = uint32_t(subtrees_.size());
        subtrees_.push_back(std::make_unique<Subtree>());
        job.out = subtrees_.back().get();
        queue_.push_back(std::move(job));
        ++pending_;
        cv_.notify_one();
        return id;
    }

    void worker() {
        Scratch scratch;
        std::unique_lock<std::mutex> lock(mu_);
        while (true) {
            // Oldest (largest) job first; leave when nothing is queued or running.
            cv_.wait(lock, [&] { return !queue_.empty() || pending_ == 0; });
            if (queue_.empty()) return;
            Job job = std::move(queue_.front());
            queue_.pop_front();
            lock.unlock();
            if (!failed_) {
                try {
                    build(job, scratch);
                } catch (...) {
                    std::lock_guard<std::mutex> guard(mu_);
                    if (!error_) error_ = std::current_exception();
                    failed_ = true;
                }
            }
            lock.lock();
            if (--pending_ == 0) cv_.notify_all();
        }
    }

    // Counts new nodes and references against the runaway guard, in batches.
    void account(size_t& local, size_t add, bool flush = false) {
        local += add;
        if (local < 65536 && !flush) return;
        if (entries_.fetch_add(local) + local > entry_limit_) {
            throw Error("k-d tree too large (over " + std::to_string(entry_limit_) +
                        " nodes and references): lower the depth");
        }
        local = 0;
    }

    // A child reference, clipped to the child box (exactly for straddling triangles).
    Ref clip(const Ref& r, const Box& child, bool exact) const {
        Ref c = r;
        for (int a = 0; a < 3; ++a) {
            c.lo[a] = std::max(c.lo[a], child.lo[a]);
            c.hi[a] = std::min(c.hi[a], child.hi[a]);
        }
        Box t;
        if (exact && clip_triangle(tris_[r.tri], child, t)) {
            Ref e = c;
            bool ok = true;
            for (int a = 0; a < 3; ++a) {
                e.lo[a] = std::max(e.lo[a], t.lo[a]);
                e.hi[a] = std::min(e.hi[a], t.hi[a]);
                ok = ok && e.lo[a] <= e.hi[a];
            }
            if (ok) return e;
        }
        return c;
    }

    // Splits the top node's references (arena[begin..end)) in place into the side(s) each
    // overlaps, flat ones in the plane to both: [above only | both, clipped above | below
    // only | both, clipped below]. Returns the first below reference; fills the children's
    // reference unions.
    size_t partition(std::vector<Ref>& v, size_t begin, const Split& sp, const Box& below,
                     const Box& above, Box& u_below, Box& u_above) const {
        const int a = sp.axis;
        const float pos = sp.pos;
        u_below = u_above = empty_box();
        // Three-way partition: above only, both, below only.
        size_t lo = begin, mid = begin, hi = v.size();
        while (mid < hi) {
            const Ref& r = v[mid];
            const bool planar = r.lo[a] == pos && r.hi[a] == pos;
            if (r.lo[a] >= pos && !planar) {
                extend(u_above, r);
                std::swap(v[lo++], v[mid++]);
            } else if (r.hi[a] <= pos && !planar) {
                extend(u_below, r);
                std::swap(v[mid], v[--hi]);
            } else {
                ++mid;
            }
        }
        // Duplicate the references on both sides, each clipped to its child box.
        for (size_t i = lo; i < hi; ++i) {
            const Ref r = v[i];
            const bool straddles = sp.clip_exact && r.lo[a] < pos && r.hi[a] > pos;
            v.push_back(clip(r, below, straddles));
            v[i] = clip(r, above, straddles);
            extend(u_below, v.back());
            extend(u_above, v[i]);
        }
        return hi;
    }

    // Builds one job's subtree depth-first: below child first, so it lands right after its
    // parent; a large above child is handed to another worker and linked in later.
    void build(Job& job, Scratch& s) {
        Subtree& out = *job.out;
        std::vector<Ref>& v = s.arena;
        // Take over the job's array (reserved for growth) unless this worker's is larger.
        if (job.refs.capacity() > v.capacity()) {
            v.swap(job.refs);
        } else {
            v.assign(job.refs.begin(), job.refs.end());
        }
        std::vector<Ref>().swap(job.refs);
        struct Entry {
            size_t begin, end;
            Box box, refs_union;
            int depth, bad_refines;
            int64_t parent;  // node whose above index is this entry, or -1
            int64_t link;    // subtree to link here, or -1
        };
        std::vector<Entry> stack{
            {0, v.size(), job.box, job.refs_union, job.depth, job.bad_refines, -1, -1}};
        size_t counted = 0;
        while (!stack.empty()) {
            const Entry e = stack.back();
            stack.pop_back();
            const uint32_t self = uint32_t(out.nodes.size());
            account(counted, 1);
            if (e.parent >= 0) out.nodes[size_t(e.parent)].b = self;
            if (e.link >= 0) {
                out.nodes.push_back({uint32_t(e.link), 0u, kLinkKind});
                continue;
            }
            // Leaf or split.
            const size_t n = e.end - e.begin;
            const Split sp =
                rule_.choose(v.data() + e.begin, n, e.box, e.refs_union, e.depth, e.bad_refines, s);
            if (sp.axis < 0) {
                out.nodes.push_back({uint32_t(out.indices.size()), uint32_t(n), kLeafKind});
                for (size_t i = e.begin; i < e.end; ++i) out.indices.push_back(v[i].tri);
                account(counted, n);
                v.resize(e.begin);
                continue;
            }
            out.nodes.push_back({float_bits(sp.pos), 0u, uint8_t(sp.axis)});
            // Child boxes and references.
            Box below = e.box, above = e.box, u_below, u_above;
            const int a = sp.axis;
            below.hi[a] = above.lo[a] = std::clamp(sp.pos, e.box.lo[a], e.box.hi[a]);
            const int depth = e.depth + 1;
            const size_t mid = partition(v, e.begin, sp, below, above, u_below, u_above);
            if (threads_ > 1 && mid - e.begin >= kHandOffMin) {
                // Hand the above child to another worker.
                Job child{{}, above, u_above, depth, sp.bad_refines, nullptr};
                child.refs.reserve(2 * (mid - e.begin));
                child.refs.assign(v.begin() + ptrdiff_t(e.begin), v.begin() + ptrdiff_t(mid));
                v.erase(v.begin() + ptrdiff_t(e.begin), v.begin() + ptrdiff_t(mid));
                const uint32_t id = enqueue(std::move(child));
                stack.push_back({e.begin, e.begin, above, u_above, depth, 0, self, int64_t(id)});
                stack.push_back({e.begin, v.size(), below, u_below, depth, sp.bad_refines, -1, -1});
            } else {
                stack.push_back({e.begin, mid, above, u_above, depth, sp.bad_refines, self, -1});
                stack.push_back({mid, v.size(), below, u_below, depth, sp.bad_refines, -1, -1});
            }
        }
        account(counted, 0, true);
    }

    // Pre-order walk of the whole tree across subtrees: final nodes and leaf indices.
    void flatten(KdTree& tree) const {
        size_t nodes = 0, refs = 0;
        for (const auto& st : subtrees_) nodes += st->nodes.size(), refs += st->indices.size();
        tree.nodes.reserve(nodes);
        tree.leaf_indices.reserve(refs);
        struct Item {
            uint32_t subtree, node;
            int64_t patch;  // parent whose above index is this node, or -1
        };
        std::vector<Item> stack{{0u, 0u, -1}};
        while (!stack.empty()) {
            Item it = stack.back();
            stack.pop_back();
            const LocalNode* ln = &subtrees_[it.subtree]->nodes[it.node];
            while (ln->kind == kLinkKind) {
                it.subtree = ln->a, it.node = 0;
                ln = &subtrees_[it.subtree]->nodes[0];
            }
            const size_t self = tree.nodes.size();
            if (it.patch >= 0) tree.nodes[size_t(it.patch)].flags |= uint32_t(self) << 2;
            if (ln->kind == kLeafKind) {
                const size_t offset = tree.leaf_indices.size();
                tree.nodes.push_back({uint32_t(offset), (ln->b << 2) | KD_LEAF});
                const std::vector<uint32_t>& idx = subtrees_[it.subtree]->indices;
                tree.leaf_indices.insert(tree.leaf_indices.end(), idx.begin() + ln->a,
                                         idx.begin() + ln->a + ln->b);
            } else {
                tree.nodes.push_back({ln->a, uint32_t(ln->kind)});
                stack.push_back({it.subtree, ln->b, int64_t(self)});
                stack.push_back({it.subtree, it.node + 1, -1});
            }
        }
    }

    const std::vector<Triangle>& tris_;
    const SplitRule& rule_;
    const int threads_;
    const size_t entry_limit_;
    std::mutex mu_;
    std::condition_variable cv_;
    std::deque<Job> queue_;
    std::vector<std::unique_ptr<Subtree>> subtrees_;
    size_t pending_ = 0;  // jobs queued or running
    std::atomic<bool> failed_{false};
    std::exception_ptr error_;
    std::atomic<size_t> entries_{0};
};

// Whole-tree statistics from the flattened arrays.
void fill_stats(KdTree& tree) {
    TreeStats& s = tree.stats;
    s.nodes = tree.nodes.size();
    s.references = tree.leaf_indices.size();
    s.leaves = s.empty_leaves = 0;
    s.max_depth = 0;
    // Depth of every node: the below child follows its parent, the above child is in flags.
    std::vector<std::pair<uint32_t, int>> stack{{0u, 0}};
    while (!stack.empty()) {
        const auto [index, depth] = stack.back();
        stack.pop_back();
        const gpu::KdNode& node = tree.nodes[index];
        if ((node.flags & 3u) == KD_LEAF) {
            ++s.leaves;
            s.empty_leaves += (node.flags >> 2) == 0;
            s.max_depth = std::max(s.max_depth, depth);
        } else {
            stack.push_back({node.flags >> 2, depth + 1});
            stack.push_back({index + 1, depth + 1});
        }
    }
    const size_t full = s.leaves - s.empty_leaves;
    s.mean_leaf_size = full ? double(s.references) / double(full) : 0.0;
    s.bytes = s.nodes * sizeof(gpu::KdNode) + s.references * sizeof(uint32_t);
}

}  // namespace

TreeKind parse_tree_kind(const std::string& name) {
    if (name == "sah") return TreeKind::Sah;
    if (name == "median") return TreeKind::Median;
    if (name == "none") return TreeKind::None;
    if (name == "auto") return TreeKind::Auto;
    if (name == "bvh") return TreeKind::Bvh;
    if (name == "rayquery") return TreeKind::RayQuery;
    if (name == "raypipeline") return TreeKind::RayPipeline;
    throw Error("unknown tree kind '" + name +
                "' (valid: auto, sah, median, none, bvh, rayquery, raypipeline)");
}

const char* tree_kind_name(TreeKind kind) {
    switch (kind) {
        case TreeKind::Sah:
            return "sah";
        case TreeKind::Median:
            return "median";
        case TreeKind::None:
            return "none";
        case TreeKind::Auto:
            return "auto";
        case TreeKind::Bvh:
            return "bvh";
        case TreeKind::RayQuery:
            return "rayquery";
        case TreeKind::RayPipeline:
            return "raypipeline";
    }
    return "unknown";
}

std::vector<std::string> tree_kind_names() {
    return {"auto", "sah", "median", "none", "bvh", "rayquery", "raypipeline"};
}

KdTree build_kdtree(const std::vector<Triangle>& triangles, const TreeOptions& options) {
    if (options.kind == TreeKind::Bvh) return build_wide_bvh(triangles, options);
    if (options.kind == TreeKind::Auto) {
        // The BVH, kept unless the cost model prefers none.
        TreeOptions o = options;
        o.kind = TreeKind::Bvh;
        KdTree bvh = build_kdtree(triangles, o);
        const TreeChoice choice = choose_tree(bvh, triangles.size(), options.auto_model);
        if (choice.kind == TreeKind::Bvh) {
            bvh.auto_choice = choice.reason;
            return bvh;
        }
        o.kind = TreeKind::None;
        KdTree none = build_kdtree(triangles, o);
        none.stats.build_seconds += bvh.stats.build_seconds;
        none.auto_choice = choice.reason;
        return none;
    }
    const auto start = std::chrono::steady_clock::now();
    if (options.max_depth < -1 || options.max_depth > kMaxTreeDepth) {
        throw Error("k-d tree depth must be between 0 and " + std::to_string(kMaxTreeDepth) +
                    " (or -1 for the default)");
    }
    if (triangles.size() >= (size_t(1) << 30)) {
        throw Error("too many triangles for the k-d tree (at most 2^30 - 1)");
    }
    KdTree tree;
    tree.kind = options.kind;
    // A triangle with a NaN or infinite corner cannot be hit, and its bounds compare false
    // against every plane (each split copied it to both sides: 10^5 references per triangle
    // in fuzzing): only finite triangles enter the tree (scenes refuse the others earlier).
    const auto finite = [](const Triangle& t) {
        for (const glm::vec3& v : {t.v0, t.v1, t.v2})
            if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return false;
        return true;
    };
    for (const Triangle& t : triangles) {
        if (!finite(t)) continue;
        tree.bounds.extend(t.v0), tree.bounds.extend(t.v1), tree.bounds.extend(t.v2);
    }
    const size_t n = triangles.size();
    int threads = 1;
    if (options.kind == TreeKind::None || traced_by_driver(options.kind) || n == 0) {
        // One leaf holding every triangle (or none).
        tree.leaf_indices.resize(n);
        for (size_t i = 0; i < n; ++i) tree.leaf_indices[i] = uint32_t(i);
        tree.nodes.push_back({0u, uint32_t(n << 2) | KD_LEAF});
    } else {
        // References with the triangles' bounds, then the tree of the chosen kind.
        std::vector<Ref> refs;
        refs.reserve(2 * n);  // room for the duplicated references of the first branch
        for (size_t i = 0; i < n; ++i) {
            const Triangle& t = triangles[i];
            if (!finite(t)) continue;
            const glm::vec3 lo = glm::min(t.v0, glm::min(t.v1, t.v2));
            const glm::vec3 hi = glm::max(t.v0, glm::max(t.v1, t.v2));
            refs.push_back({{lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z}, uint32_t(i)});
        }
        const Box root{{tree.bounds.min.x, tree.bounds.min.y, tree.bounds.min.z},
                       {tree.bounds.max.x, tree.bounds.max.y, tree.bounds.max.z}};
        threads = options.threads > 0 ? options.threads : int(usable_cpus());
        if (options.kind == TreeKind::Median) {
            const auto rule =
                kdbuild::median_rule(triangles, options.max_depth < 0 ? 3 : options.max_depth);
            Engine(triangles, *rule, threads).run(std::move(refs), root, tree);
        } else {
            // pbrt's default depth: 8 + 1.3 log2 N.
            int depth = options.max_depth;
            if (depth < 0) depth = int(std::lround(8.0 + 1.3 * std::log2(double(n))));
            const auto rule = kdbuild::sah_rule(options, std::min(depth, kMaxTreeDepth));
            Engine(triangles, *rule, threads).run(std::move(refs), root, tree);
        }
    }
    fill_stats(tree);
    tree.stats.threads = threads;
    tree.stats.build_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return tree;
}

std::string describe(const TreeStats& s, size_t triangle_count, TreeKind kind) {
    const double per_tri = double(std::max<size_t>(triangle_count, 1));
    const bool large = s.bytes >= 1024 * 1024;
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "  %s: %zu nodes, %zu leaves (%zu empty), depth %d\n"
                  "  references: %zu (%.2f per triangle, %.2f per non-empty leaf)\n"
                  "  memory: %.2f %s nodes + leaf indices (%.1f bytes per triangle)\n"
                  "  build: %.3f s on %d thread%s\n",
                  kind == TreeKind::Bvh ? "8-wide BVH" : "k-d tree", s.nodes, s.leaves,
                  s.empty_leaves, s.max_depth, s.references,
                  double(s.references) / per_tri, s.mean_leaf_size,
                  double(s.bytes) / (large ? 1024.0 * 1024.0 : 1024.0), large ? "MiB" : "KiB",
                  double(s.bytes) / per_tri, s.build_seconds, s.threads, s.threads == 1 ? "" : "s");
    return buf;
}

}  // namespace mcpt
