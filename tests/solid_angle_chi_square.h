// What the light samplers' tests share (triangle_light_test.cpp, rect_light_test.cpp): the
// device functions' scene arguments without a scene, and the chi-square check of the points
// a sampler draws, binned in the light's own coordinates on a cells x cells grid, against
// expected counts from each cell's solid angle over the whole; and the same for a control
// sampler that must fail it.
#pragma once
#include <algorithm>
#include <functional>
#include <glm/glm.hpp>
#include <random>
#include <vector>

#include "common/analysis/stats.h"
#include "common/gpu/shared_types.h"

namespace mcpt::test {

// The device functions' scene arguments: parameters (scene_flags 0: by solid angle) and no
// buffers.
inline gpu::GpuParams no_scene_params{};
#define NO_SCENE                                                                                   \
    &::mcpt::test::no_scene_params, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, \
        nullptr, nullptr,

struct ChiSquarePair {
    double p;          // the sampler under test
    double p_control;  // the control
};

// cell_solid_angle(i, j): the solid angle of cell (i, j), the light's whole being omega;
// sample(u, control): the coordinates in [0, 1]^2 of the point drawn from uniforms u by the
// sampler under test (control false) or by the control.
inline ChiSquarePair solid_angle_chi_square(
    int cells, int samples, double omega, unsigned seed,
    const std::function<double(int, int)>& cell_solid_angle,
    const std::function<glm::vec2(glm::vec2, bool)>& sample) {
    std::vector<double> expected(size_t(cells * cells));
    for (int i = 0; i < cells; ++i)
        for (int j = 0; j < cells; ++j)
            expected[size_t(i * cells + j)] = samples * cell_solid_angle(i, j) / omega;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uniform(0.f, 1.f);
    const auto histogram = [&](bool control) {
        std::vector<double> observed(size_t(cells * cells), 0.0);
        for (int k = 0; k < samples; ++k) {
            const glm::vec2 u(uniform(rng), uniform(rng));
            const glm::vec2 c = sample(u, control);
            const int i = std::min(cells - 1, int(c.x * float(cells))),
                      j = std::min(cells - 1, int(c.y * float(cells)));
            observed[size_t(i * cells + j)] += 1;
        }
        return observed;
    };
    const std::vector<double> tested = histogram(false), control = histogram(true);
    return {stats::chi_square_test(tested, expected), stats::chi_square_test(control, expected)};
}

}  // namespace mcpt::test
