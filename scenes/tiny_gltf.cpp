// tinygltf's implementation (Debian's libtinygltf-dev ships the header), compiled here
// so that the sanitizer and fuzzing builds instrument it too. Without stb_image (scenes/CMakeLists.txt; a
// texture is read by its mean colour through libpng: scenes/mesh_gltf.cpp); its file
// access goes through the reader's callbacks, which read regular files only.
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
