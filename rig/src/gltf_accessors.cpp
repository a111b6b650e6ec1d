// glTF accessor reading (see gltf_accessors.hpp).
#include "gltf_accessors.hpp"

#include <algorithm>
#include <cstring>

#include "facecast/core/error.hpp"

namespace facecast::rig::detail {
namespace {

// Where `count` elements of `elem` bytes lie, `stride` apart, from `data` (nullptr: no buffer
// view, all zeros). Checked without overflow, so a huge declared count is an error, not an
// allocation.
struct Span {
  const unsigned char* data = nullptr;
  std::size_t stride = 0, count = 0;
};

Span span_of(const tinygltf::Model& m, int view_index, std::size_t byte_offset, std::size_t count,
             std::size_t elem, std::size_t fixed_stride, const std::string& what) {
  Span span;
  span.count = count;
  if (view_index < 0) {
    // Zeros (sparse substitutions only): bounded by what the file holds, so a declared count
    // cannot make an allocation of its own.
    std::size_t held = 1 << 20;
    for (const auto& b : m.buffers) held += b.data.size();
    if (elem && count > held / elem * 1024)
      throw Error(what + ": " + std::to_string(count) + " elements without data exceed the file");
    return span;
  }
  if (static_cast<std::size_t>(view_index) >= m.bufferViews.size())
    throw Error(what + ": buffer view " + std::to_string(view_index) + " does not exist");
  const auto& view = m.bufferViews[static_cast<std::size_t>(view_index)];
  if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= m.buffers.size())
    throw Error(what + ": buffer " + std::to_string(view.buffer) + " does not exist");
  const auto& buf = m.buffers[static_cast<std::size_t>(view.buffer)].data;
  if (view.byteOffset > buf.size() || view.byteLength > buf.size() - view.byteOffset)
    throw Error(what + ": buffer view runs past the end of its buffer");
  span.stride = fixed_stride ? fixed_stride : view.byteStride ? view.byteStride : elem;
  if (span.stride < elem) throw Error(what + ": byte stride is smaller than an element");
  const std::size_t room = view.byteLength < byte_offset ? 0 : view.byteLength - byte_offset;
  if (count && (room < elem || (count - 1) > (room - elem) / span.stride))
    throw Error(what + ": " + std::to_string(count) + " elements run past the end of the view");
  span.data = buf.data() + view.byteOffset + byte_offset;
  return span;
}

std::uint32_t uint_component(const unsigned char* p, int type) {
  if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return *p;
  if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
    std::uint16_t v;
    std::memcpy(&v, p, 2);
    return v;
  }
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

float component(const unsigned char* p, int type, bool normalized) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const auto v = static_cast<std::int8_t>(*p);
      return normalized ? std::max(v / 127.0f, -1.0f) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? *p / 255.0f : *p;
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      std::int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0f, -1.0f) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0f : v;
    }
    default: {
      std::uint32_t v;
      std::memcpy(&v, p, 4);
      return normalized ? static_cast<float>(v / 4294967295.0) : static_cast<float>(v);
    }
  }
}

std::size_t component_size(int type, const std::string& what) {
  const int size = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(type));
  if (size <= 0) throw Error(what + ": unknown component type " + std::to_string(type));
  return static_cast<std::size_t>(size);
}

// Reads into `out` (count x comps) through `put(row, col, pointer-to-component)`.
template <typename Put>
void read_elements(const Span& span, std::size_t csize, int comps, Put put) {
  for (std::size_t i = 0; i < span.count; ++i)
    for (int c = 0; c < comps; ++c)
      put(i, c, span.data + i * span.stride + static_cast<std::size_t>(c) * csize);
}

// What reading the accessor allocates (its elements as 4-byte values, the sparse indices),
// charged before anything is read.
void charge(DecodeBudget* budget, const tinygltf::Accessor& a, int comps, const std::string& what) {
  if (!budget) return;
  std::size_t bytes = product(product(a.count, static_cast<std::size_t>(comps)), 4);
  if (a.sparse.isSparse && a.sparse.count > 0)
    bytes += product(static_cast<std::size_t>(a.sparse.count), 4);
  budget->charge(bytes, what, a.sparse.isSparse ? "sparse accessor read" : "accessor read");
}

// The sparse part of an accessor: the indices it replaces, checked against `count`.
std::vector<std::uint32_t> sparse_indices(const tinygltf::Model& m, const tinygltf::Accessor& a,
                                          const std::string& what) {
  const auto& s = a.sparse;
  const std::size_t isize = component_size(s.indices.componentType, what);
  if (s.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
      s.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
      s.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    throw Error(what + ": sparse indices must be unsigned integers");
  if (s.count < 0 || static_cast<std::size_t>(s.count) > a.count)
    throw Error(what + ": sparse count exceeds the accessor's count");
  const Span span = span_of(m, s.indices.bufferView, static_cast<std::size_t>(s.indices.byteOffset),
                            static_cast<std::size_t>(s.count), isize, isize, what + " sparse");
  if (!span.data) throw Error(what + ": sparse indices without a buffer view");
  std::vector<std::uint32_t> out(span.count);
  read_elements(span, isize, 1, [&](std::size_t i, int, const unsigned char* p) {
    out[i] = uint_component(p, s.indices.componentType);
    if (out[i] >= a.count) throw Error(what + ": sparse index out of range");
  });
  return out;
}

// Every element of an accessor through put(element, component, bytes): the dense part from its
// buffer view (when it has one), then the sparse substitutions at their indices.
template <typename Put>
void read_accessor(const tinygltf::Model& m, const tinygltf::Accessor& a, const Span& span,
                   std::size_t csize, int comps, const std::string& what, Put put) {
  if (span.data) read_elements(span, csize, comps, put);
  if (!a.sparse.isSparse) return;
  const auto idx = sparse_indices(m, a, what);
  const std::size_t stride = csize * static_cast<std::size_t>(comps);
  const Span values =
      span_of(m, a.sparse.values.bufferView, static_cast<std::size_t>(a.sparse.values.byteOffset),
              idx.size(), stride, stride, what + " sparse");
  if (!values.data) throw Error(what + ": sparse values without a buffer view");
  read_elements(values, csize, comps,
                [&](std::size_t i, int c, const unsigned char* p) { put(idx[i], c, p); });
}

}  // namespace

const tinygltf::Accessor& accessor_at(const tinygltf::Model& m, int index,
                                      const std::string& what) {
  if (index < 0 || static_cast<std::size_t>(index) >= m.accessors.size())
    throw Error(what + ": accessor " + std::to_string(index) + " does not exist");
  return m.accessors[static_cast<std::size_t>(index)];
}

FloatRows read_floats(const tinygltf::Model& m, int index, int comps, const std::string& what,
                      DecodeBudget* budget) {
  const auto& a = accessor_at(m, index, what);
  if (tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type)) != comps)
    throw Error(what + ": expected " + std::to_string(comps) + " components per element",
                ErrorCode::kUnsupported);
  charge(budget, a, comps, what);
  const std::size_t csize = component_size(a.componentType, what);
  const Span span = span_of(m, a.bufferView, a.byteOffset, a.count,
                            csize * static_cast<std::size_t>(comps), 0, what);
  FloatRows out = FloatRows::Zero(static_cast<Eigen::Index>(span.count), comps);
  const auto put = [&](std::size_t i, int c, const unsigned char* p) {
    out(static_cast<Eigen::Index>(i), c) = component(p, a.componentType, a.normalized);
  };
  read_accessor(m, a, span, csize, comps, what, put);
  if (!out.allFinite()) throw Error(what + ": non-finite value");
  return out;
}

std::vector<std::uint32_t> read_uints(const tinygltf::Model& m, int index, int comps,
                                      const std::string& what, DecodeBudget* budget) {
  const auto& a = accessor_at(m, index, what);
  const int type = a.componentType;
  if (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
      type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
      type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    throw Error(what + ": expected unsigned 8, 16 or 32 bit integers");
  if (tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type)) != comps)
    throw Error(what + ": expected " + std::to_string(comps) + " components per element");
  charge(budget, a, comps, what);
  const std::size_t csize = component_size(type, what);
  const Span span = span_of(m, a.bufferView, a.byteOffset, a.count,
                            csize * static_cast<std::size_t>(comps), 0, what);
  if (!span.data && !a.sparse.isSparse)
    throw Error(what + ": integer accessor without a buffer view");
  std::vector<std::uint32_t> out(span.count * static_cast<std::size_t>(comps), 0);
  const auto put = [&](std::size_t i, int c, const unsigned char* p) {
    out[i * static_cast<std::size_t>(comps) + static_cast<std::size_t>(c)] =
        uint_component(p, type);
  };
  read_accessor(m, a, span, csize, comps, what, put);
  return out;
}

}  // namespace facecast::rig::detail
