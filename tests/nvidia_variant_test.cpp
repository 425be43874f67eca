// The OpenCL kernel as it is built for NVIDIA's driver (MCPT_NVIDIA_OPENCL: DIVF as a
// reciprocal times, native sine and cosine, GLSL's normalize and length, the BVH's box tests
// through fmin and fmax), compiled and run on PoCL, which CI has: the same estimator up to
// those forms' precision, so its images agree statistically with the reference build's on
// scenes that use each (microfacet sampling and glass, a mesh through the BVH, textures).
// NVIDIA's inline PTX (sampler.h's bit reversal) is its own: clang's builtin comes first.
// Control: the same variant with a GGX alpha 10% off is rejected.
#include <gtest/gtest.h>

#include "common/analysis/compare.h"
#include "common/analysis/stats.h"
#include "common/scene/builtin_scenes.h"
#include "common/scene/gltf_loader.h"
#include "test_util.h"

namespace mcpt {
namespace {

constexpr const char* kNvidia = "-DMCPT_NVIDIA_OPENCL";

BatchSet batches(const std::string& defines, const Scene& scene, const GpuScene& g, uint32_t seed) {
    auto device = test::test_opencl_backend(defines);
    RenderOptions o;
    o.width = o.height = 32;
    BatchOptions bo;
    bo.batches = 32;
    bo.spp_per_batch = 8;
    bo.seed_base = seed;
    return render_batches(*device, g, scene.camera, o, bo);
}

TEST(NvidiaOpenClVariant, AgreesWithTheReferenceBuildOnPocl) {
    struct Case {
        std::string name;
        Scene scene;
        TreeKind tree;
    };
    std::vector<Case> cases;
    cases.push_back({"materials, k-d tree", make_builtin_scene("materials"), TreeKind::Sah});
    cases.push_back({"bumpy sphere, BVH", make_bumpy_sphere_scene(60), TreeKind::Bvh});
    cases.push_back({"textured, BVH", load_gltf(std::string(MCPT_TEST_DATA_DIR) + "/textured.glb"),
                     TreeKind::Bvh});
    for (Case& c : cases) {
        validate_scene(c.scene);
        TreeOptions t;
        t.kind = c.tree;
        const GpuScene g = pack_scene(c.scene, build_kdtree(c.scene.triangles, t));
        const BatchSet reference = batches("", c.scene, g, 100);
        const Agreement same = test_agreement(reference, batches(kNvidia, c.scene, g, 9000), 0.01);
        EXPECT_TRUE(same.agree) << c.name << ": " << same.verdict();
        if (c.name.rfind("materials", 0) != 0) continue;
        const Agreement off =
            test_agreement(reference,
                           batches(std::string(kNvidia) + " -DMCPT_NEGATIVE_CONTROL_GGX_ALPHA=1.1f",
                                   c.scene, g, 17000),
                           0.01);
        EXPECT_FALSE(off.agree) << c.name << ": a GGX alpha 10% off passed: " << off.verdict();
    }
}

}  // namespace
}  // namespace mcpt
