// tinygltf as mcpt includes it, everywhere the same (its inline code depends on these):
// images are handed over undecoded, stb_image is not tinygltf's (common/io/stb_impl.cpp).
#pragma once
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>
