// glTF 2.0 loader (tinygltf): the default scene's node hierarchy, triangle meshes flattened to
// world space, the first perspective camera, and materials mapped as follows.
//
// glTF material mapping:
//   emission = emissiveFactor * KHR_materials_emissive_strength.emissiveStrength (default 1);
//              the front side of a triangle emits (counter-clockwise seen from the front,
//              clockwise under a mirroring node transform, as glTF defines it), and the back
//              too where the material is doubleSided (as glTF viewers and Cycles render it).
//   KHR_materials_transmission.transmissionFactor > 0.5
//       -> Glass (roughnessFactor <= 0.01) or RoughGlass, ior = KHR_materials_ior.ior
//          (default 1.5), color = baseColorFactor.rgb
//   otherwise metallicFactor = 1 and roughnessFactor <= 0.01
//       -> Mirror, color = baseColorFactor.rgb (the limit of roughness 0, traced exactly)
//   otherwise metallicFactor = 0 and KHR_materials_specular specularFactor *
//   mean(specularColorFactor) = 0
//       -> Diffuse, color = baseColorFactor.rgb (no specular layer: exactly Lambertian)
//   otherwise
//       -> Pbr: glTF's metallic-roughness BRDF (gpu/microfacet.h) with baseColorFactor,
//          metallicFactor, roughnessFactor, KHR_materials_ior.ior and
//          KHR_materials_specular.specularFactor (default 1).
//   KHR_materials_volume on glass (thicknessFactor > 0): Beer-Lambert absorption inside,
//   -ln(attenuationColor) / attenuationDistance per unit length.
//   KHR_materials_clearcoat and KHR_materials_sheen (factors and textures) make a material
//   Pbr with those layers (gpu/layers.h); on glass they are not read.
//   A primitive without a material gets a grey (0.8) Diffuse material.
// Lamps (KHR_lights_punctual) on nodes: point, spot and directional lights at the node's
// world transform (position; direction -Z), color * intensity / 683 lm/W (candela to W/sr,
// lux to W/m^2, as Blender's importer converts them), range and cone angles as glTF says.
// Textures: base color, metallic-roughness, normal and emissive (texture coordinates 0), PNG
// and JPEG (stb_image), WebP (EXT_texture_webp, libwebp), each placed by its material's
// KHR_texture_transform (baked into the triangles' texture coordinates); alphaMode MASK.
// Meshes as optimizing pipelines ship them: KHR_mesh_quantization (integer and normalized
// attributes; the node transform undoes the scale), EXT_meshopt_compression and
// KHR_draco_mesh_compression (gltf_compression.h), decoded before any check.
//   Ignored with a warning: occlusion textures, texture coordinates other than 0, skins,
//   animations, morph targets, non-perspective cameras, primitive modes other than TRIANGLES,
//   KHR_texture_basisu (KTX2: its PNG/JPEG/WebP fallback is used where the file has one) and
//   the other extensions. A file that requires (extensionsRequired) any other extension is
//   rejected, naming it.

#include "common/scene/gltf_loader.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <limits>

#include "common/io/host_memory.h"
#include "common/scene/gltf_loader_internal.h"

namespace mcpt {
namespace gltf {
namespace {

// glTF's photometric units to radiometric ones: 683 lm/W, as Blender's glTF importer.
constexpr double kLumensPerWatt = 683.0;

std::string mode_name(int mode) {
    switch (mode) {
        case TINYGLTF_MODE_POINTS:
            return "POINTS";
        case TINYGLTF_MODE_LINE:
            return "LINES";
        case TINYGLTF_MODE_LINE_LOOP:
            return "LINE_LOOP";
        case TINYGLTF_MODE_LINE_STRIP:
            return "LINE_STRIP";
        case TINYGLTF_MODE_TRIANGLE_STRIP:
            return "TRIANGLE_STRIP";
        case TINYGLTF_MODE_TRIANGLE_FAN:
            return "TRIANGLE_FAN";
        default:
            return std::to_string(mode);
    }
}

}  // namespace

Scene GltfLoader::load() {
    read_model();
    try {
        // Whole-file checks and warnings, then materials, then the node hierarchy.
        check_features();
        convert_materials();
        const std::vector<int> roots = root_nodes();
        check_triangle_budget(roots);
        traverse(roots);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        fail(std::string("cannot convert the glTF model: ") + e.what());
    }
    // No camera in the file: frame the geometry.
    if (!scene_.has_camera) frame_camera(scene_);
    return std::move(scene_);
}

// The default scene's roots (scene 0 when none is marked; parentless nodes when no scene).
std::vector<int> GltfLoader::root_nodes() {
    if (!model_.scenes.empty()) {
        // No "scene" reads as -1 (then the first scene); another negative index is an error.
        if (model_.defaultScene < -1)
            fail("default scene " + std::to_string(model_.defaultScene) + " is negative");
        int s = model_.defaultScene < 0 ? 0 : model_.defaultScene;
        if (size_t(s) >= model_.scenes.size())
            fail("default scene " + std::to_string(s) + " out of range (file has " +
                 std::to_string(model_.scenes.size()) + " scenes)");
        return model_.scenes[size_t(s)].nodes;
    }
    std::vector<char> is_child(model_.nodes.size(), 0);
    for (const tg::Node& n : model_.nodes)
        for (int c : n.children)
            if (c >= 0 && size_t(c) < model_.nodes.size()) is_child[size_t(c)] = 1;
    std::vector<int> roots;
    for (size_t i = 0; i < model_.nodes.size(); ++i)
        if (!is_child[i]) roots.push_back(int(i));
    return roots;
}

// Depth-first, pre-order walk with an explicit stack; each node may appear once.
// Nodes may instance one mesh many times: a 2 MB file can hold 10^8 triangles. Count them
// (from the accessors' counts) before expanding any, and refuse a scene that would not fit.
void GltfLoader::check_triangle_budget(const std::vector<int>& roots) const {
    uint64_t triangles = 0, instances = 0;
    std::vector<char> seen(model_.nodes.size(), 0);
    std::vector<int> stack(roots.rbegin(), roots.rend());
    while (!stack.empty()) {
        const int index = stack.back();
        stack.pop_back();
        if (index < 0 || size_t(index) >= model_.nodes.size() || seen[size_t(index)]) continue;
        seen[size_t(index)] = 1;  // traverse() reports bad and repeated nodes
        const tg::Node& node = model_.nodes[size_t(index)];
        if (node.mesh >= 0 && size_t(node.mesh) < model_.meshes.size()) {
            ++instances;
            for (const tg::Primitive& prim : model_.meshes[size_t(node.mesh)].primitives) {
                if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) continue;
                const auto pos = prim.attributes.find("POSITION");
                const int corners = prim.indices >= 0              ? prim.indices
                                    : pos != prim.attributes.end() ? pos->second
                                                                   : -1;
                if (corners >= 0 && size_t(corners) < model_.accessors.size())
                    triangles += model_.accessors[size_t(corners)].count / 3;
            }
        }
        stack.insert(stack.end(), node.children.rbegin(), node.children.rend());
    }
    // Host memory per triangle while loading, validating, packing and building the tree (the
    // file, scene and device copies, SAH references and events): 485 B on the 871k dragon
    // (peak RSS 508 MB against 86 MB for the Cornell box).
    constexpr uint64_t kHostBytesPerTriangle = 512;
    constexpr uint64_t kMaxTriangles = uint64_t(1) << 28;  // 10 GiB on a device: beyond any
    const uint64_t available = host_memory_available();
    const uint64_t need = triangles * kHostBytesPerTriangle;
    if (triangles > kMaxTriangles || need > available / 2)
        fail("scene too large: " + std::to_string(triangles) + " triangles in " +
             std::to_string(instances) + " mesh instances need about " + human_bytes(need) +
             " of host memory to load and build (" + std::to_string(kHostBytesPerTriangle) +
             " B each); " + human_bytes(available) + " available, at most half is used" +
             (triangles > kMaxTriangles
                  ? "; and more than " + std::to_string(kMaxTriangles) + " triangles"
                  : ""));
}

void GltfLoader::traverse(const std::vector<int>& roots) {
    std::vector<char> seen(model_.nodes.size(), 0);
    std::vector<std::pair<int, glm::dmat4>> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, glm::dmat4(1));
    while (!stack.empty()) {
        const auto [index, parent] = stack.back();
        stack.pop_back();
        // A valid node, not met before (the hierarchy must be a forest).
        if (index < 0 || size_t(index) >= model_.nodes.size())
            fail("node index " + std::to_string(index) + " out of range (file has " +
                 std::to_string(model_.nodes.size()) + " nodes)");
        if (seen[size_t(index)])
            fail("node " + std::to_string(index) +
                 " appears more than once in the node hierarchy (cycle or shared node)");
        seen[size_t(index)] = 1;
        const tg::Node& node = model_.nodes[size_t(index)];
        const glm::dmat4 world = parent * local_transform(node, index);
        // Its camera, its mesh, then its children in order.
        if (node.camera >= 0 || node.camera < -1) take_camera(node.camera, world);
        if (node.mesh >= 0 || node.mesh < -1) add_mesh(node.mesh, world);
        const auto lamp = node.extensions.find(kLightsPunctual);
        if (lamp != node.extensions.end()) {
            const tg::Value& light = lamp->second.Get("light");
            if (!light.IsNumber())
                fail("node " + std::to_string(index) + ": " + kLightsPunctual +
                     " without a light index");
            add_light(light.GetNumberAsInt(), world, index);
        }
        for (auto c = node.children.rbegin(); c != node.children.rend(); ++c)
            stack.emplace_back(*c, world);
    }
}

// The node's matrix, or translation * rotation * scale.
glm::dmat4 GltfLoader::local_transform(const tg::Node& node, int index) {
    const std::string what = "node " + std::to_string(index) + ": ";
    if (!node.matrix.empty()) {
        if (node.matrix.size() != 16) fail(what + "matrix must have 16 numbers");
        return glm::make_mat4(node.matrix.data());  // column-major, as in glTF
    }
    glm::dmat4 m(1);
    if (!node.translation.empty()) {
        if (node.translation.size() != 3) fail(what + "translation must have 3 numbers");
        m = glm::translate(m, glm::make_vec3(node.translation.data()));
    }
    if (!node.rotation.empty()) {
        if (node.rotation.size() != 4) fail(what + "rotation must have 4 numbers");
        const auto& r = node.rotation;  // x, y, z, w
        glm::dquat q(r[3], r[0], r[1], r[2]);
        const double len = glm::length(q);
        if (len > 0.0) q = q / len;
        m = m * glm::mat4_cast(q);
    }
    if (!node.scale.empty()) {
        if (node.scale.size() != 3) fail(what + "scale must have 3 numbers");
        m = glm::scale(m, glm::make_vec3(node.scale.data()));
    }
    return m;
}

// A lamp of KHR_lights_punctual at the node's world transform: position, direction -Z.
void GltfLoader::add_light(int light, const glm::dmat4& world, int node) {
    if (light < 0 || size_t(light) >= model_.lights.size())
        fail("node " + std::to_string(node) + ": light index " + std::to_string(light) +
             " out of range (file has " + std::to_string(model_.lights.size()) + " lights)");
    const tg::Light& l = model_.lights[size_t(light)];
    const std::string label =
        "light " + (l.name.empty() ? std::to_string(light) : "'" + l.name + "'");
    PunctualLight p;
    p.name = l.name;
    if (l.type == "point")
        p.kind = PunctualKind::Point;
    else if (l.type == "spot")
        p.kind = PunctualKind::Spot;
    else if (l.type == "directional")
        p.kind = PunctualKind::Directional;
    else
        fail(label + ": unknown type '" + l.type + "' (point, spot or directional)");
    glm::dvec3 color(1.0);
    if (!l.color.empty()) {
        if (l.color.size() != 3) fail(label + ": color must have 3 numbers");
        color = glm::make_vec3(l.color.data());
    }
    const auto finite_nonnegative = [](double v) { return std::isfinite(v) && v >= 0; };
    if (!finite_nonnegative(color.x) || !finite_nonnegative(color.y) ||
        !finite_nonnegative(color.z) || !finite_nonnegative(l.intensity))
        fail(label + ": color and intensity must be finite and >= 0");
    // In double, then checked: a finite intensity can exceed single precision.
    const glm::dvec3 watts = color * (l.intensity / kLumensPerWatt);
    if (!(std::max({watts.x, watts.y, watts.z}) <= double(FLT_MAX)))
        fail(label + ": color x intensity (" +
             std::to_string(std::max({watts.x, watts.y, watts.z})) +
             " W/sr) overflows single precision (3.4e38)");
    p.intensity = glm::vec3(watts);
    if (!finite_nonnegative(l.range)) fail(label + ": range must be finite and > 0");
    p.range = p.kind == PunctualKind::Directional ? 0.f : float(l.range);
    if (p.kind == PunctualKind::Spot) {
        const double inner = l.spot.innerConeAngle, outer = l.spot.outerConeAngle;
        if (!(inner >= 0 && inner <= outer && outer <= M_PI / 2 + 1e-9))
            fail(label + ": spot cone angles must satisfy 0 <= inner <= outer <= pi/2 (inner " +
                 std::to_string(inner) + ", outer " + std::to_string(outer) + ")");
        p.inner_cone = float(inner), p.outer_cone = float(outer);
    }
    p.position = glm::vec3(world * glm::dvec4(0, 0, 0, 1));
    const glm::dvec3 dir = glm::dmat3(world) * glm::dvec3(0, 0, -1);
    const double len = glm::length(dir);
    if (p.kind != PunctualKind::Point && !(len > 1e-12 && std::isfinite(len)))
        fail(label + ": degenerate node transform (no direction)");
    if (p.kind != PunctualKind::Point) p.direction = glm::vec3(dir / len);
    if (!std::isfinite(p.position.x + p.position.y + p.position.z))
        fail(label + ": non-finite position");
    scene_.punctual_lights.push_back(p);
}

// The first perspective camera: position, forward = -Z and up = +Y of the node, in world space.
void GltfLoader::take_camera(int camera, const glm::dmat4& world) {
    if (camera < 0 || size_t(camera) >= model_.cameras.size())
        fail("camera index " + std::to_string(camera) + " out of range (file has " +
             std::to_string(model_.cameras.size()) + " cameras)");
    const tg::Camera& c = model_.cameras[size_t(camera)];
    const std::string label = c.name.empty() ? std::to_string(camera) : "'" + c.name + "'";
    if (c.type != "perspective") {
        warn_once("camera:" + c.type, "non-perspective (" + c.type +
                                          ") cameras are not supported; camera " + label +
                                          " ignored");
        return;
    }
    if (scene_.has_camera) return;
    const double yfov = c.perspective.yfov;
    if (!(yfov > 0.0 && yfov < glm::pi<double>()))
        fail("camera " + label + ": yfov must be in (0, pi) radians");
    const glm::dmat3 basis(world);
    glm::dvec3 forward = basis * glm::dvec3(0, 0, -1), up = basis * glm::dvec3(0, 1, 0);
    // Orthonormalize (the node may carry scale or shear).
    const double fl = glm::length(forward);
    if (!(fl > 1e-12)) fail("camera " + label + ": degenerate node transform");
    forward /= fl;
    up -= glm::dot(up, forward) * forward;
    const double ul = glm::length(up);
    if (!(ul > 1e-12)) fail("camera " + label + ": degenerate node transform");
    scene_.camera.position = glm::vec3(world * glm::dvec4(0, 0, 0, 1));
    scene_.camera.forward = glm::vec3(forward);
    scene_.camera.up = glm::vec3(up / ul);
    scene_.camera.yfov = float(yfov);
    scene_.has_camera = true;
}

// Every TRIANGLES primitive of the mesh, transformed to world space.
void GltfLoader::add_mesh(int mesh, const glm::dmat4& world) {
    if (mesh < 0 || size_t(mesh) >= model_.meshes.size())
        fail("mesh index " + std::to_string(mesh) + " out of range (file has " +
             std::to_string(model_.meshes.size()) + " meshes)");
    const tg::Mesh& m = model_.meshes[size_t(mesh)];
    // A mirroring transform flips the winding, so swap two vertices to keep the front side.
    const bool flip = glm::determinant(glm::dmat3(world)) < 0.0;
    for (size_t p = 0; p < m.primitives.size(); ++p) {
        const tg::Primitive& prim = m.primitives[p];
        const std::string where = "mesh " + std::to_string(mesh) +
                                  (m.name.empty() ? "" : " '" + m.name + "'") + " primitive " +
                                  std::to_string(p);
        if (!prim.targets.empty())
            warn_once("morph", "morph targets are not supported; using the base mesh");
        if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) {
            warn_once("mode:" + std::to_string(prim.mode),
                      "primitive mode " + mode_name(prim.mode) + " is not supported; skipped");
            continue;
        }
        const auto pos = prim.attributes.find("POSITION");
        if (pos == prim.attributes.end()) {
            warn_once("no POSITION", where + " has no POSITION attribute; skipped");
            continue;
        }
        const uint32_t material = material_index(prim.material, where);
        const std::vector<glm::vec3> v = read_positions(pos->second, where);
        // Per-vertex normals and texture coordinates 0, when the primitive has them.
        const auto nrm = prim.attributes.find("NORMAL");
        const auto tc = prim.attributes.find("TEXCOORD_0");
        std::vector<glm::vec3> normals;
        std::vector<glm::vec2> uvs;
        if (nrm != prim.attributes.end()) normals = read_normals(nrm->second, where);
        if (tc != prim.attributes.end()) uvs = read_texcoords(tc->second, where);
        if ((!normals.empty() && normals.size() != v.size()) ||
            (!uvs.empty() && uvs.size() != v.size()))
            fail(where + ": NORMAL or TEXCOORD_0 count differs from POSITION's");
        const bool attributes = !normals.empty() || !uvs.empty() || !scene_.attributes.empty();
        if (!normals.empty()) scene_.vertex_normals = true;
        if (attributes) scene_.attributes.resize(scene_.triangles.size());
        // Normals transform by the inverse transpose.
        const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(world)));
        // Corner list: the indices, or 0, 1, 2, ... when not indexed.
        std::vector<uint32_t> idx;
        if (prim.indices >= 0 || prim.indices < -1) {
            idx = read_indices(prim.indices, where);
        } else {
            idx.resize(v.size());
            for (size_t i = 0; i < idx.size(); ++i) idx[i] = uint32_t(i);
        }
        if (idx.size() % 3 != 0)
            warn_once("count%3", where + ": corner count " + std::to_string(idx.size()) +
                                     " is not a multiple of 3; extra corners ignored");
        for (size_t i = 0; i + 2 < idx.size(); i += 3) {
            glm::vec3 c[3];
            VertexAttributes va;
            for (int k = 0; k < 3; ++k) {
                const uint32_t j = idx[i + size_t(k)];
                if (j >= v.size())
                    fail(where + ": index " + std::to_string(j) + " out of range (POSITION has " +
                         std::to_string(v.size()) + " vertices)");
                c[k] = glm::vec3(world * glm::dvec4(glm::dvec3(v[j]), 1.0));
                if (!normals.empty()) {
                    const glm::dvec3 n = normal_matrix * glm::dvec3(normals[j]);
                    const double len = glm::length(n);
                    va.n[k] = len > 0.0 && std::isfinite(len) ? glm::vec3(n / len) : glm::vec3(0.f);
                }
                if (!uvs.empty()) {
                    // The material's KHR_texture_transform, baked in.
                    const glm::dvec3 t = material < uv_transforms_.size()
                                             ? uv_transforms_[material] * glm::dvec3(uvs[j], 1.0)
                                             : glm::dvec3(uvs[j], 1.0);
                    va.uv[k] = glm::vec2(t);
                }
            }
            if (flip) {
                std::swap(c[1], c[2]);
                std::swap(va.n[1], va.n[2]);
                std::swap(va.uv[1], va.uv[2]);
            }
            scene_.triangles.push_back({c[0], c[1], c[2], material});
            if (attributes) scene_.attributes.push_back(va);
        }
    }
}
}  // namespace gltf

Scene load_gltf(const std::string& path) {
    return gltf::GltfLoader(path).load();
}

Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir) {
    return gltf::GltfLoader(name, static_cast<const unsigned char*>(data), size, base_dir).load();
}

}  // namespace mcpt
