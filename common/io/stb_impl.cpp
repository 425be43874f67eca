// The one definition of the stb_image and stb_image_write implementations in mcpt: every other
// file includes the headers only (tinygltf is built with TINYGLTF_NO_STB_IMAGE[_WRITE]).
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
// Third-party code: keep the -Wall -Wextra build quiet
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb_image.h>
#include <stb_image_write.h>
#pragma GCC diagnostic pop
