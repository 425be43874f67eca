// tinygltf's implementation, in a file of its own: it is most of the glTF loader's compile
// time (about 25 of its 40 CPU-seconds), which now runs beside the loader's own code. Images
// are left to the loader (no stb_image here: common/io/stb_impl.cpp has it once).
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>
