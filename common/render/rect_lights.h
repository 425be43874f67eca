// Emissive rectangles made of two triangles, found so that next-event estimation samples each
// as one spherical rectangle (common/gpu/rect_light.h): the two halves of a quad light (the
// Cornell box's, a Blender plane, an area lamp exported as a mesh) share their hypotenuse, each
// with its right angle opposite it.
#pragma once
#include <cstdint>
#include <vector>

#include "common/scene/scene.h"

namespace mcpt {

struct RectPair {
    uint32_t head;     // the lower triangle index: the rectangle's entry in the light table
    uint32_t partner;  // the other half
};

// The pairs of emissive triangles of one material (without an emission texture: its texels
// are read per triangle) that form a rectangle: each a right triangle (its angle there within
// 1e-5 of a right angle in cosine, the other two clearly not), the same hypotenuse (the same
// vertices, bit for bit), the right-angle vertices opposite each other across it (within 1e-5
// of the hypotenuse's length), facing the same way. A triangle is in at most one pair.
std::vector<RectPair> find_rect_lights(const Scene& scene);

constexpr uint32_t kNoPartner = 0xffffffffu;

// The pairs looked up by triangle: a head's partner, and whether a triangle is a partner (not
// in the light table: the head stands for both).
class RectLights {
  public:
    RectLights() = default;
    RectLights(const std::vector<RectPair>& pairs, size_t triangles);
    uint32_t partner_of(uint32_t triangle) const {
        return triangle < partner_.size() ? partner_[triangle] : kNoPartner;
    }
    bool is_partner(uint32_t triangle) const {
        return triangle < head_.size() && head_[triangle] != kNoPartner;
    }
    size_t size() const { return count_; }

  private:
    std::vector<uint32_t> partner_;  // by head
    std::vector<uint32_t> head_;     // by partner
    size_t count_ = 0;
};

}  // namespace mcpt
