// Little-endian loads and stores for the binary formats Rayline reads and writes (block
// files, PLY, glTF buffers): the files are little-endian whatever the host.
#pragma once
#include <bit>
#include <cstring>
#include <type_traits>
#include <utility>

namespace rayline::scene {

template <class T>
void put_le(unsigned char* p, T v) {
  static_assert(std::is_trivially_copyable_v<T>);
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::big)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  std::memcpy(p, b, sizeof(T));
}

template <class T>
T get_le(const unsigned char* p) {
  static_assert(std::is_trivially_copyable_v<T>);
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if constexpr (std::endian::native == std::endian::big)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

}  // namespace rayline::scene
