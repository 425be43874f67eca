#include "common/render/gpu_scene.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <numeric>

#include "common/error.h"
#include "common/gpu/sheen_albedo_table.h"
#include "common/render/light_tree.h"
#include "common/render/rect_lights.h"
#include "common/render/scene_features.h"
#include "common/scene/environment.h"

namespace mcpt {

namespace {

// A float's bits, as the texel region holds them.
uint32_t float_word(float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

// Pads the texel region to a 16-byte boundary of the shading buffer (vec4 reads).
void align_texels16(GpuScene& g) {
    while ((g.params.texels_word + g.texels.size()) % 4 != 0) g.texels.push_back(0);
}

double mean_emission(const Material& m) {
    return (double(m.emission.x) + double(m.emission.y) + double(m.emission.z)) / 3.0;
}

// A punctual light's weight in the light choice: 4 pi I for a point and for a spot (inside its
// cone a spot lights a point as a point light does, and the choice does not know where the
// cone points: weighting a spot by its cone's flux starved the regions it lights, 2.5% of
// the samples in the Cycles side-by-side's lamps scene), E over the scene's disk for a
// directional light.
double punctual_power(const PunctualLight& l, double disk) {
    const double mean = (double(l.intensity.x) + double(l.intensity.y) + double(l.intensity.z)) / 3;
    return l.kind == PunctualKind::Directional ? disk * mean : 4 * M_PI * mean;
}

// The environment's sampling weight of each texel, and its power per unit area of the disk:
// the integral of mean radiance over the sphere. A texel's weight: its luminance (where NEE
// competes, radiance is read per texel: lights.h), compensated minus the map's mean
// (solid-angle weighted) and clamped at 0 (a uniform map keeps the plain weights: nothing
// would be left); times sin(theta).
double environment_weights(const Environment& env, std::vector<double>& weights) {
    const size_t w = size_t(env.width), h = size_t(env.height);
    weights.assign(w * h, 0.0);
    double integral = 0, lum_integral = 0, solid_angle = 0;
    for (size_t y = 0; y < h; ++y) {
        const double sin_theta = std::sin(M_PI * (double(y) + 0.5) / double(h));
        const double texel_sr = (2 * M_PI / double(w)) * (M_PI / double(h)) * sin_theta;
        for (size_t x = 0; x < w; ++x) {
            const float* c = &env.rgb[3 * (y * w + x)];
            integral += (double(c[0]) + double(c[1]) + double(c[2])) / 3 * texel_sr;
            weights[y * w + x] = env_luminance(c[0], c[1], c[2]);
            lum_integral += weights[y * w + x] * texel_sr, solid_angle += texel_sr;
        }
    }
    std::vector<double> compensated(w * h, 0.0);
    const double mean = lum_integral / solid_angle;
    bool any = false;
    for (size_t y = 0; y < h; ++y) {
        const double sin_theta = std::sin(M_PI * (double(y) + 0.5) / double(h));
        for (size_t x = 0; x < w; ++x) {
            double& wt = weights[y * w + x];
            // (Rounding of a uniform map's mean must not leave a few texels to sample.)
            compensated[y * w + x] = wt > mean * (1 + 1e-4) ? (wt - mean) * sin_theta : 0.0;
            any |= compensated[y * w + x] > 0;
            wt *= sin_theta;
        }
    }
    if (env.compensated && any) weights.swap(compensated);
    return integral * double(env.scale);
}

// Appends the CDF of n weights to `cdf`: n + 1 ascending floats from 0 to exactly 1 (uniform
// where the weights sum to 0), then its guide table: for each k < n, the interval i holding
// k / n (cdf[i] <= k / n < cdf[i + 1]), where the device's search starts (lights.h: cdf_pick).
void append_cdf(const double* weights, size_t n, std::vector<uint32_t>& out) {
    const double total = std::accumulate(weights, weights + n, 0.0);
    std::vector<float> cdf(n + 1, 0.f);
    double sum = 0;
    for (size_t i = 0; i < n; ++i) {
        sum += total > 0 ? weights[i] : 1.0;
        cdf[i + 1] = i + 1 == n ? 1.f : float(sum / (total > 0 ? total : double(n)));
    }
    for (float c : cdf) out.push_back(float_word(c));
    size_t i = 0;
    for (size_t k = 0; k < n; ++k) {
        const double at = double(k) / double(n);
        while (i + 1 < n && double(cdf[i + 1]) <= at) ++i;
        out.push_back(uint32_t(i));
    }
}

// Appends the punctual lights and the environment (texels, CDF tables) to the texel region,
// each on a 16-byte boundary of the shading buffer, and sets their GpuParams fields.
void pack_punctual_and_environment(const Scene& scene, const std::vector<double>& env_weights,
                                   GpuScene& g) {
    gpu::GpuParams& p = g.params;
    align_texels16(g);
    p.num_punctual = uint32_t(scene.punctual_lights.size());
    p.punctual_word = uint32_t(g.texels.size());
    for (const PunctualLight& l : scene.punctual_lights) {
        const float cos_inner = std::cos(l.inner_cone), cos_outer = std::cos(l.outer_cone);
        const float scale = 1.f / std::max(0.001f, cos_inner - cos_outer);
        gpu::GpuPunctualLight d{};
        d.px = l.position.x, d.py = l.position.y, d.pz = l.position.z;
        d.type = uint32_t(l.kind);
        d.dx = l.direction.x, d.dy = l.direction.y, d.dz = l.direction.z;
        d.range = l.range;
        d.r = l.intensity.x, d.g = l.intensity.y, d.b = l.intensity.z;
        d.spot_scale = scale, d.spot_offset = -cos_outer * scale;
        const size_t at = g.texels.size();
        g.texels.resize(at + sizeof d / 4);
        std::memcpy(g.texels.data() + at, &d, sizeof d);
    }
    const Environment& env = scene.environment;
    if (!env.present()) return;
    const size_t w = size_t(env.width), h = size_t(env.height);
    p.env_width = uint32_t(w), p.env_height = uint32_t(h);
    p.env_u_shift = float(std::fmod(double(env.rotate_deg) / 360.0, 1.0));
    // The rows' CDF by their total weight, and each row's CDF over its columns, in float as the
    // device reads them (a zero row gets a uniform one: it is never picked).
    std::vector<uint32_t> row_cdf, col_cdf;
    std::vector<double> rows(h, 0.0);
    for (size_t y = 0; y < h; ++y)
        for (size_t x = 0; x < w; ++x) rows[y] += env_weights[y * w + x];
    append_cdf(rows.data(), h, row_cdf);
    for (size_t y = 0; y < h; ++y) append_cdf(env_weights.data() + y * w, w, col_cdf);
    const auto cdf_at = [](const std::vector<uint32_t>& t, size_t i) {
        float f;
        std::memcpy(&f, &t[i], 4);
        return double(f);
    };
    const bool any = std::accumulate(rows.begin(), rows.end(), 0.0) > 0;
    // Texels: radiance, and the pdf of their uv square, from the float CDFs' steps: exactly
    // what sampling them does (a texel whose step rounds to 0 is never sampled and has pdf 0).
    p.env_word = uint32_t(g.texels.size());
    for (size_t i = 0; i < w * h; ++i) {
        const size_t x = i % w, y = i / w;
        const size_t col = y * (2 * w + 1);
        const double row_p = cdf_at(row_cdf, y + 1) - cdf_at(row_cdf, y);
        const double col_p = cdf_at(col_cdf, col + x + 1) - cdf_at(col_cdf, col + x);
        const double pdf = any ? row_p * col_p * double(w * h) : 0.0;
        const float* c = &env.rgb[3 * i];
        // Scaled in double: a finite scale must not make a texel infinite unnoticed.
        for (int k = 0; k < 3; ++k) {
            const double v = double(c[k]) * double(env.scale);
            if (!(v <= double(FLT_MAX)))
                throw Error("environment map " + env.name + " scaled by " +
                            std::to_string(env.scale) + ": a texel of " + std::to_string(c[k]) +
                            " becomes " + std::to_string(v) +
                            ", beyond single precision (3.4e38); lower --env-scale");
            g.texels.push_back(float_word(float(v)));
        }
        g.texels.push_back(float_word(float(pdf)));
    }
    p.env_rows_word = uint32_t(g.texels.size());
    g.texels.insert(g.texels.end(), row_cdf.begin(), row_cdf.end());
    p.env_cols_word = uint32_t(g.texels.size());
    g.texels.insert(g.texels.end(), col_cdf.begin(), col_cdf.end());
    for (const gpu::GpuLight& l : g.lights)
        if (l.prim == LIGHT_ENVIRONMENT) p.env_pmf = l.pmf;
}

// The light tree over the local lights (emitters, point and spot lamps), when there is one:
// the light table is rebuilt with the lights at infinity first (their alias table, pmf scaled
// by the probability of taking them) and the local lights after them (slots the tree's leaves
// name); the nodes and the (prim, trail) pairs sorted by prim follow the texels.
// The rectangle lights (find_rect_lights), with scenes that sample by solid angle: each pair's
// triangles get a copy of their material marked MAT_RECT_LIGHT (one copy per material).
RectLights pair_rect_lights(const Scene& scene, GpuScene& g) {
    using Tls = Scene::TriangleLightSampling;
    if (scene.triangle_light_sampling != Tls::SolidAngle &&
        scene.triangle_light_sampling != Tls::Uniform &&
        scene.triangle_light_sampling != Tls::Cosine)
        return {};
    const std::vector<RectPair> pairs = find_rect_lights(scene);
    std::vector<uint32_t> marked(scene.materials.size(), kNoPartner);
    for (const RectPair& p : pairs) {
        const uint32_t m = scene.triangles[p.head].material;
        if (marked[m] == kNoPartner) {
            marked[m] = uint32_t(g.materials.size());
            gpu::GpuMaterial copy = g.materials[m];
            copy.type |= MAT_RECT_LIGHT;
            g.materials.push_back(copy);
        }
        g.triangles[p.head].material = g.triangles[p.partner].material = marked[m];
    }
    return RectLights(pairs, scene.triangles.size());
}

void pack_light_tree(const Scene& scene, const std::vector<double>& weights,
                     const std::vector<uint32_t>& prims, const RectLights& rects, GpuScene& g) {
    const auto at_infinity = [&](uint32_t prim) {
        if (prim == LIGHT_ENVIRONMENT) return true;
        if ((prim & LIGHT_PUNCTUAL_BIT) == 0) return false;
        return scene.punctual_lights.at(prim & LIGHT_INDEX_MASK).kind == PunctualKind::Directional;
    };
    std::vector<double> far_w;
    std::vector<uint32_t> far_p, near_p;
    std::vector<double> near_w;
    for (size_t i = 0; i < prims.size(); ++i) {
        if (at_infinity(prims[i]))
            far_w.push_back(weights[i]), far_p.push_back(prims[i]);
        else
            near_w.push_back(weights[i]), near_p.push_back(prims[i]);
    }
    if (near_p.empty()) return;  // nothing local: the alias table as it is
    const double far_total = std::accumulate(far_w.begin(), far_w.end(), 0.0);
    const double near_total = std::accumulate(near_w.begin(), near_w.end(), 0.0);
    const double p_tree = near_total / (near_total + far_total);
    std::vector<gpu::GpuLight> table;
    build_alias_table(far_w, table);
    for (size_t i = 0; i < table.size(); ++i)
        table[i].prim = far_p[i], table[i].pmf = float(double(table[i].pmf) * (1 - p_tree));
    // Local lights: their bounds and power.
    std::vector<TreeLight> lights;
    for (size_t i = 0; i < near_p.size(); ++i) {
        const uint32_t prim = near_p[i];
        TreeLight l;
        if ((prim & LIGHT_PUNCTUAL_BIT) != 0) {
            // A point every way; a spot within its outer cone (and a milliradian).
            const PunctualLight& p = scene.punctual_lights.at(prim & LIGHT_INDEX_MASK);
            l.lo = l.hi = p.position;
            const float length = glm::length(p.direction);
            if (p.kind == PunctualKind::Spot && length > 0 && p.outer_cone + 1e-3f < 3.14159f)
                l.axis = p.direction / length, l.cos_o = std::cos(p.outer_cone + 1e-3f);
        } else if ((prim & LIGHT_SPHERE_BIT) != 0) {
            const Sphere& s = scene.spheres.at(prim & ~LIGHT_SPHERE_BIT);
            l.lo = s.center - glm::vec3(s.radius), l.hi = s.center + glm::vec3(s.radius);
        } else {
            // One-sided: the side of cross(v1 - v0, v2 - v0) (integrator.h), a hemisphere;
            // two-sided: every way.
            // (A rectangle: both halves.)
            const Triangle& t = scene.triangles.at(prim);
            l.lo = glm::min(t.v0, glm::min(t.v1, t.v2)),
            l.hi = glm::max(t.v0, glm::max(t.v1, t.v2));
            if (const uint32_t other = rects.partner_of(prim); other != kNoPartner) {
                const Triangle& o = scene.triangles.at(other);
                l.lo = glm::min(l.lo, glm::min(o.v0, glm::min(o.v1, o.v2)));
                l.hi = glm::max(l.hi, glm::max(o.v0, glm::max(o.v1, o.v2)));
            }
            const glm::dvec3 n = glm::cross(glm::dvec3(t.v1) - glm::dvec3(t.v0),
                                            glm::dvec3(t.v2) - glm::dvec3(t.v0));
            if (glm::length(n) > 0 && !scene.materials.at(t.material).two_sided)
                l.axis = glm::vec3(glm::normalize(n)), l.cos_o = 1.f;
        }
        l.power = near_w[i];
        l.slot = uint32_t(table.size() + i);
        lights.push_back(l);
    }
    const LightTree tree = build_light_tree(lights);
    for (size_t i = 0; i < near_p.size(); ++i) {
        gpu::GpuLight e{};
        e.prim = near_p[i];
        e.pmf = 0.f;  // depends on the shading point
        e.prob = 1.f, e.alias = uint32_t(table.size() + i);
        table.push_back(e);
    }
    g.lights = table;
    gpu::GpuParams& p = g.params;
    p.num_lights = uint32_t(g.lights.size());
    p.num_tree_lights = uint32_t(near_p.size());
    p.light_tree_pmf = float(p_tree);
    // The least squared distance: (1e-6 of the scene's size)^2, never 0.
    const Bounds b = scene.bounds();
    const double size = b.empty() ? 1.0 : glm::length(glm::dvec3(b.max) - glm::dvec3(b.min));
    p.light_tree_eps2 = float(std::max(1e-30, size * size * 1e-12));
    align_texels16(g);
    p.light_tree_word = uint32_t(g.texels.size());
    for (const gpu::GpuLightTreeNode& n : tree.nodes) {
        for (float f : {n.min_x, n.min_y, n.min_z, n.power, n.max_x, n.max_y, n.max_z})
            g.texels.push_back(float_word(f));
        g.texels.push_back(n.child);
        for (float f : {n.axis_x, n.axis_y, n.axis_z, n.cos_o}) g.texels.push_back(float_word(f));
    }
    std::vector<std::pair<uint32_t, uint32_t>> trails;
    for (size_t i = 0; i < near_p.size(); ++i) {
        trails.push_back({near_p[i], tree.trails[i]});
        // A rectangle's other half: hits on it find the rectangle's leaf.
        if (const uint32_t other = rects.partner_of(near_p[i]); other != kNoPartner)
            trails.push_back({other, tree.trails[i]});
    }
    std::sort(trails.begin(), trails.end());
    p.light_trails_word = uint32_t(g.texels.size());
    p.num_light_trails = uint32_t(trails.size());
    for (const auto& [prim, trail] : trails) g.texels.push_back(prim), g.texels.push_back(trail);
    for (const gpu::GpuLight& l : g.lights)
        if (l.prim == LIGHT_ENVIRONMENT) p.env_pmf = l.pmf;
}

}  // namespace

gpu::GpuMaterial pack_material(const Material& m) {
    gpu::GpuMaterial g{};
    g.r = m.color.x, g.g = m.color.y, g.b = m.color.z;
    g.type = static_cast<uint32_t>(m.type);
    if (m.two_sided && m.is_emissive()) g.type |= MAT_TWO_SIDED;
    g.er = m.emission.x, g.eg = m.emission.y, g.eb = m.emission.z;
    g.ior = m.ior;
    g.metallic = m.metallic;
    g.alpha = std::max(m.roughness * m.roughness, MIN_GGX_ALPHA);
    g.specular = m.specular;
    g.alpha_cutoff = m.alpha_cutoff;
    // Absorbing glass: the largest channel, and each over it in steps of 1/1023, in the fields
    // glass does not read (material_sigma in gpu/bsdf.h).
    const float sigma_max = std::max({m.absorption.x, m.absorption.y, m.absorption.z});
    if ((m.type == MaterialType::Glass || m.type == MaterialType::RoughGlass) && sigma_max > 0.f) {
        g.type |= MAT_VOLUME;
        g.metallic = sigma_max;
        uint32_t bits = 0;
        for (int c = 0; c < 3; ++c)
            bits |=
                uint32_t(std::lround(std::clamp(m.absorption[c] / sigma_max, 0.f, 1.f) * 1023.f))
                << (10 * c);
        std::memcpy(&g.specular, &bits, 4);
    }
    const auto tex = [](int i) { return i < 0 ? NO_TEXTURE : uint32_t(i); };
    g.tex_base = tex(m.tex_base);
    g.tex_metal_rough = tex(m.tex_metal_rough);
    g.tex_normal = tex(m.tex_normal);
    g.tex_emission = tex(m.tex_emission);
    // Layers over metallic-roughness: a coat (alpha = roughness^2, as the base's) and a sheen;
    // their textures as 16-bit indices.
    const auto tex16 = [&](int i) {
        if (i >= int(NO_TEXTURE16))
            throw Error("material '" + m.name + "': a clearcoat or sheen texture index of " +
                        std::to_string(i) + " (at most " + std::to_string(NO_TEXTURE16 - 1) +
                        " textures can carry the layers)");
        return i < 0 ? NO_TEXTURE16 : uint32_t(i);
    };
    g.tex_clearcoat = g.tex_sheen = NO_TEXTURE;
    if (m.type == MaterialType::Pbr && m.has_clearcoat()) {
        g.clearcoat = std::min(m.clearcoat, 1.f);
        g.clearcoat_alpha = std::max(m.clearcoat_roughness * m.clearcoat_roughness, MIN_GGX_ALPHA);
        g.tex_clearcoat = tex16(m.tex_clearcoat) | (tex16(m.tex_clearcoat_roughness) << 16);
    }
    if (m.type == MaterialType::Pbr && m.has_sheen()) {
        g.sheen_r = m.sheen_color.x, g.sheen_g = m.sheen_color.y, g.sheen_b = m.sheen_color.z;
        g.sheen_roughness = std::clamp(m.sheen_roughness, MIN_SHEEN_ROUGHNESS, 1.f);
        g.tex_sheen = tex16(m.tex_sheen_color) | (tex16(m.tex_sheen_roughness) << 16);
    }
    return g;
}

size_t GpuScene::device_bytes() const {
    return nodes.size() * sizeof(gpu::KdNode) + leaf_indices.size() * 4 +
           triangles.size() * sizeof(gpu::GpuTriangle) + spheres.size() * sizeof(gpu::GpuSphere) +
           materials.size() * sizeof(gpu::GpuMaterial) + lights.size() * sizeof(gpu::GpuLight) +
           // (the materials start on a 96-byte boundary)
           (SHADING_MATERIALS_WORD(uint32_t(spheres.size())) * 4 -
            spheres.size() * sizeof(gpu::GpuSphere)) +
           attributes.size() * sizeof(gpu::GpuTriangleAttributes) +
           textures.size() * sizeof(gpu::GpuTexture) + texels.size() * 4;
}

void build_alias_table(const std::vector<double>& weights, std::vector<gpu::GpuLight>& table) {
    const size_t n = weights.size();
    const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
    table.assign(n, gpu::GpuLight{});
    if (n == 0 || !(total > 0)) return;
    // Scaled weights: mean 1; split into slots below and above the mean.
    std::vector<double> scaled(n);
    std::vector<size_t> small, large;
    for (size_t i = 0; i < n; ++i) {
        scaled[i] = weights[i] / total * double(n);
        table[i].pmf = float(weights[i] / total);
        table[i].alias = uint32_t(i);
        (scaled[i] < 1.0 ? small : large).push_back(i);
    }
    // Pair each light slot with a heavy one that fills it up.
    while (!small.empty() && !large.empty()) {
        size_t s = small.back(), l = large.back();
        small.pop_back();
        table[s].prob = float(scaled[s]);
        table[s].alias = uint32_t(l);
        scaled[l] = (scaled[l] + scaled[s]) - 1.0;
        if (scaled[l] < 1.0) {
            large.pop_back();
            small.push_back(l);
        }
    }
    // Leftovers are full slots (rounding).
    for (size_t i : small) table[i].prob = 1.f;
    for (size_t i : large) table[i].prob = 1.f;
}

GpuScene pack_scene(const Scene& scene, const KdTree& tree) {
    GpuScene g;
    g.nodes = tree.nodes;
    g.leaf_indices = tree.leaf_indices;
    g.stack_size = tree.stack_size();
    g.tree_stats = tree.stats;
    g.tree_kind = tree.kind;
    g.tree_choice = tree.auto_choice;
    // Geometry and materials.
    g.triangles.reserve(scene.triangles.size());
    for (const Triangle& t : scene.triangles) {
        g.triangles.push_back(
            {t.v0.x, t.v0.y, t.v0.z, t.v1.x, t.v1.y, t.v1.z, t.v2.x, t.v2.y, t.v2.z, t.material});
    }
    for (const Sphere& s : scene.spheres) {
        g.spheres.push_back({s.center.x, s.center.y, s.center.z, s.radius, s.material, 0, 0, 0});
    }
    for (const Material& m : scene.materials) g.materials.push_back(pack_material(m));
    // Per-vertex data: normals (the face normal where the scene has none) and coordinates.
    g.attributes.reserve(scene.attributes.size());
    g.vertex_normals = scene.vertex_normals && !scene.attributes.empty();
    for (size_t i = 0; i < scene.attributes.size(); ++i) {
        const VertexAttributes& a = scene.attributes[i];
        const Triangle& t = scene.triangles[i];
        const glm::vec3 face = glm::normalize(glm::cross(t.v1 - t.v0, t.v2 - t.v0));
        gpu::GpuTriangleAttributes p{};
        uint32_t* n[3] = {&p.n0, &p.n1, &p.n2};
        for (int k = 0; k < 3; ++k) {
            const float len = glm::length(a.n[k]);
            *n[k] = oct_encode(scene.vertex_normals && len > 0.f ? a.n[k] / len : face);
        }
        p.u0 = a.uv[0].x, p.v0 = a.uv[0].y, p.u1 = a.uv[1].x, p.v1 = a.uv[1].y;
        p.u2 = a.uv[2].x, p.v2 = a.uv[2].y;
        g.attributes.push_back(p);
    }
    // Textures: linear RGBA as halves, one after the other.
    for (const Texture& t : scene.textures) {
        gpu::GpuTexture d{};
        d.width = uint32_t(t.width), d.height = uint32_t(t.height);
        d.offset = uint32_t(g.texels.size());
        d.flags =
            uint32_t(t.wrap_s) | (uint32_t(t.wrap_t) << 2) | (t.nearest ? TEXTURE_NEAREST : 0u);
        g.textures.push_back(d);
        for (size_t i = 0; i + 1 < t.rgba.size(); i += 2)
            g.texels.push_back(uint32_t(t.rgba[i]) | (uint32_t(t.rgba[i + 1]) << 16));
    }
    // Rectangles of two emissive triangles: one light (the lower index), their material
    // marked MAT_RECT_LIGHT (a copy of it, where other triangles keep the original).
    const RectLights rects = pair_rect_lights(scene, g);
    // Emitters weighted by power: area * mean(Le).
    std::vector<double> weights;
    std::vector<uint32_t> prims;
    const auto triangle_area = [&](size_t i) {
        const Triangle& t = scene.triangles[i];
        const glm::dvec3 e1 = glm::dvec3(t.v1) - glm::dvec3(t.v0),
                         e2 = glm::dvec3(t.v2) - glm::dvec3(t.v0);
        return 0.5 * glm::length(glm::cross(e1, e2));
    };
    for (size_t i = 0; i < scene.triangles.size(); ++i) {
        const Triangle& t = scene.triangles[i];
        const Material& m = scene.materials.at(t.material);
        if (!m.is_emissive() || rects.is_partner(uint32_t(i))) continue;
        double area = triangle_area(i);
        if (const uint32_t other = rects.partner_of(uint32_t(i)); other != kNoPartner)
            area += triangle_area(other);
        // Power: area times mean radiance, per emitting face.
        weights.push_back(area * mean_emission(m) * (m.two_sided ? 2.0 : 1.0));
        prims.push_back(uint32_t(i));
    }
    for (size_t i = 0; i < scene.spheres.size(); ++i) {
        const Sphere& s = scene.spheres[i];
        const Material& m = scene.materials.at(s.material);
        if (!m.is_emissive()) continue;
        weights.push_back(4.0 * M_PI * double(s.radius) * double(s.radius) * mean_emission(m));
        prims.push_back(uint32_t(i) | LIGHT_SPHERE_BIT);
    }
    // Punctual lights and the environment, weighted by their power into a disk of the scene's
    // bounding radius (directions).
    const Bounds bounds = scene.bounds();
    const double radius =
        bounds.empty() ? 1.0 : 0.5 * glm::length(glm::dvec3(bounds.max) - glm::dvec3(bounds.min));
    const double disk = M_PI * radius * radius;
    for (size_t i = 0; i < scene.punctual_lights.size(); ++i) {
        weights.push_back(punctual_power(scene.punctual_lights[i], disk));
        prims.push_back(uint32_t(i) | LIGHT_PUNCTUAL_BIT);
    }
    std::vector<double> env_weights;
    if (scene.environment.present()) {
        weights.push_back(disk * environment_weights(scene.environment, env_weights));
        prims.push_back(LIGHT_ENVIRONMENT);
    }
    // Lights of zero power are never picked (and not kept).
    size_t kept = 0;
    for (size_t i = 0; i < weights.size(); ++i)
        if (weights[i] > 0) weights[kept] = weights[i], prims[kept++] = prims[i];
    weights.resize(kept), prims.resize(kept);
    check_lit(scene);
    const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
    if (weights.empty() || !(total > 0) || !std::isfinite(total))
        throw Error("scene has no light of finite positive power (total " + std::to_string(total) +
                    ")");
    build_alias_table(weights, g.lights);
    for (size_t i = 0; i < g.lights.size(); ++i) g.lights[i].prim = prims[i];
    // Scene constants.
    gpu::GpuParams& p = g.params;
    p.num_triangles = uint32_t(g.triangles.size());
    p.num_spheres = uint32_t(g.spheres.size());
    p.num_lights = uint32_t(g.lights.size());
    p.num_nodes = uint32_t(g.nodes.size());
    p.num_materials = uint32_t(g.materials.size());
    p.num_textures = uint32_t(g.textures.size());
    p.scene_flags = g.attributes.empty() ? 0u : SCENE_VERTEX_DATA;
    if (tree.kind == TreeKind::Bvh) p.scene_flags |= SCENE_BVH;
    if (tree.kind == TreeKind::RayQuery) p.scene_flags |= SCENE_RAY_QUERY;
    if (tree.kind == TreeKind::RayPipeline) p.scene_flags |= SCENE_RAY_PIPELINE;
    for (const gpu::GpuMaterial& m : g.materials)
        if (m.alpha_cutoff > 0.f) p.scene_flags |= SCENE_ALPHA_MASK;
    p.texels_word = SHADING_LIGHTS_WORD(p.num_spheres, p.num_materials) + 4u * p.num_lights +
                    4u * p.num_textures;
    p.light_power_total = float(total);
    pack_punctual_and_environment(scene, env_weights, g);
    if (scene.light_tree) pack_light_tree(scene, weights, prims, rects, g);
    // The sheen's albedo table, where a material has a sheen (GLSL reads it there: layers.h).
    for (const gpu::GpuMaterial& m : g.materials) {
        if (std::max({m.sheen_r, m.sheen_g, m.sheen_b}) <= 0.f) continue;
        p.sheen_albedo_word = uint32_t(g.texels.size());
        for (float e : gpu::SHEEN_ALBEDO) g.texels.push_back(float_word(e));
        break;
    }
    static_assert(Scene::kLampChoiceMax == LIGHT_CONTRIBUTION_MAX, "one limit, two names");
    if (scene.light_by_contribution) {
        if (scene.light_tree || !scene.lamp_choice_possible())
            throw Error(
                "lights by contribution: every light must be a lamp (point, spot or "
                "directional; no emissive surface, no environment), at most " +
                std::to_string(LIGHT_CONTRIBUTION_MAX) + " of them, without the tree");
        p.scene_flags |= SCENE_LIGHT_CONTRIBUTION;
    }
    if (scene.triangle_light_sampling == Scene::TriangleLightSampling::Area)
        p.scene_flags |= SCENE_TRIANGLE_LIGHTS_BY_AREA;
    if (scene.triangle_light_sampling == Scene::TriangleLightSampling::Cosine)
        p.scene_flags |= SCENE_TRIANGLE_LIGHTS_COSINE;
    if (scene.triangle_light_sampling == Scene::TriangleLightSampling::Uniform)
        p.scene_flags |= SCENE_TRIANGLE_LIGHTS_UNIFORM;
    p.scene_min_x = tree.bounds.min.x, p.scene_min_y = tree.bounds.min.y;
    p.scene_min_z = tree.bounds.min.z;
    p.scene_max_x = tree.bounds.max.x, p.scene_max_y = tree.bounds.max.y;
    p.scene_max_z = tree.bounds.max.z;
    p.light_scale = 1.f;
    p.rr_depth = 3;
    p.max_depth = 8;
    g.features = scene_features(g);
    return g;
}

void set_camera(gpu::GpuParams& p, const Camera& c, int width, int height) {
    p.width = uint32_t(width);
    p.height = uint32_t(height);
    const glm::vec3 w = glm::normalize(c.forward);
    const glm::vec3 u = glm::normalize(glm::cross(w, c.up));
    const glm::vec3 v = glm::cross(u, w);
    const float tan_half = std::tan(0.5f * c.yfov);
    const float aspect = float(width) / float(height);
    const glm::vec3 su = u * (tan_half * aspect), sv = v * tan_half;
    p.cam_px = c.position.x, p.cam_py = c.position.y, p.cam_pz = c.position.z;
    p.cam_ux = su.x, p.cam_uy = su.y, p.cam_uz = su.z;
    p.cam_vx = sv.x, p.cam_vy = sv.y, p.cam_vz = sv.z;
    p.cam_wx = w.x, p.cam_wy = w.y, p.cam_wz = w.z;
}

namespace {
// Appends the raw words of a plain-data array.
template <class T>
void append_words(std::vector<uint32_t>& out, const std::vector<T>& v) {
    static_assert(sizeof(T) % 4 == 0, "device structs are made of 32-bit words");
    const size_t at = out.size();
    out.resize(at + v.size() * sizeof(T) / 4);
    if (!v.empty()) std::memcpy(out.data() + at, v.data(), v.size() * sizeof(T));
}
}  // namespace

std::string window_note(const AccumLayout& l) {
    if (l.window) return ", accumulation in windows of " + std::to_string(l.sum_pixels) + " pixels";
    return l.exact_pixels > 0 ? ", exact sums on the device" : "";
}

AccumLayout accum_layout(uint64_t npix, uint64_t max_buffer_bytes, bool exact_sums) {
    // In vec4s: the sums of every pixel, the slots, the pending word, the sample plan.
    const uint64_t limit = max_buffer_bytes > 0 ? max_buffer_bytes / 16 : UINT64_MAX;
    const uint64_t sums = npix * ACCUM_VEC4_PER_PIXEL;
    const uint64_t min_slots = std::min<uint64_t>(npix, 4096);
    // vec4s of n slots' path state and plan, with the pending vec4; the most slots in `room`
    // vec4s when each also takes `extra` vec4s (a window's sums).
    auto slot_vec4s = [](uint64_t n) {
        return n * PATH_STATE_VEC4 + 1 + (n * PLAN_WORDS_PER_SLOT + 3) / 4;
    };
    auto slots_in = [](uint64_t room, uint64_t extra) {
        return room < 2 ? 0
                        : (room - 2) * 4 / (4 * (PATH_STATE_VEC4 + extra) + PLAN_WORDS_PER_SLOT);
    };
    AccumLayout l;
    uint64_t slots = std::min<uint64_t>(npix, MAX_STATE_SLOTS);
    if (sums + slot_vec4s(min_slots) <= limit) {
        // Every pixel's sums, and as many slots as fit beside them.
        slots = std::min(slots, slots_in(limit - sums, 0));
        l.sum_pixels = uint32_t(npix);
    } else {
        // A window: as many pixels as fit with their sums and slots (at least one workgroup;
        // an image over 2^32 pixels is refused before this).
        slots = std::min(slots, std::max<uint64_t>(slots_in(limit, ACCUM_VEC4_PER_PIXEL), 64));
        l.window = true;
        l.sum_pixels = uint32_t(slots);
    }
    l.slots = uint32_t(slots);
    l.bytes = (uint64_t(l.sum_pixels) * ACCUM_VEC4_PER_PIXEL + slot_vec4s(slots)) * 16;
    // The exact sums after the plan, where they fit (else the host adds the groups).
    const uint64_t exact = npix * EXACT_VEC4_PER_PIXEL * 16;
    if (exact_sums && !l.window && (max_buffer_bytes == 0 || l.bytes + exact <= max_buffer_bytes) &&
        (l.bytes + exact) / 16 < (uint64_t(1) << 32)) {
        l.exact_pixels = uint32_t(npix);
        l.bytes += exact;
    }
    return l;
}

// The words of plain-data arrays one after the other; one zero word when all are empty.
template <class... Arrays>
std::vector<uint32_t> concat_words(const Arrays&... arrays) {
    std::vector<uint32_t> out;
    (append_words(out, arrays), ...);
    if (out.empty()) out.push_back(0);
    return out;
}

std::vector<uint32_t> tree_buffer(const GpuScene& s) {
    return concat_words(s.nodes, s.leaf_indices);
}

std::vector<uint32_t> shading_buffer(const GpuScene& s) {
    std::vector<uint32_t> out;
    append_words(out, s.spheres);
    out.resize(SHADING_MATERIALS_WORD(uint32_t(s.spheres.size())), 0u);  // 96-byte boundary
    append_words(out, s.materials);
    append_words(out, s.lights);
    append_words(out, s.textures);
    append_words(out, s.texels);
    if (out.empty()) out.push_back(0);
    return out;
}

uint64_t shading_buffer_bytes(const GpuScene& s) {
    return uint64_t(SHADING_MATERIALS_WORD(uint32_t(s.spheres.size()))) * 4 +
           s.materials.size() * sizeof(gpu::GpuMaterial) + s.lights.size() * sizeof(gpu::GpuLight) +
           s.textures.size() * sizeof(gpu::GpuTexture) + s.texels.size() * 4;
}

std::vector<uint32_t> triangle_buffer(const GpuScene& s) {
    return concat_words(s.triangles, s.attributes);
}

uint32_t oct_encode(glm::vec3 n) {
    n /= std::fabs(n.x) + std::fabs(n.y) + std::fabs(n.z);
    glm::vec2 e(n.x, n.y);
    if (n.z < 0.f) {
        e = glm::vec2((1.f - std::fabs(n.y)) * (n.x >= 0.f ? 1.f : -1.f),
                      (1.f - std::fabs(n.x)) * (n.y >= 0.f ? 1.f : -1.f));
    }
    const auto snorm = [](float v) {
        return uint32_t(uint16_t(int16_t(std::lround(std::clamp(v, -1.f, 1.f) * 32767.f))));
    };
    return snorm(e.x) | (snorm(e.y) << 16);
}

}  // namespace mcpt
