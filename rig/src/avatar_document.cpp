// The avatar document: loading through gltf_package (one self-contained GLB) and tinygltf, saving
// as GLB.
#include "facecast/rig/avatar_document.hpp"

#include <tiny_gltf.h>

#include <sstream>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "gltf_package.hpp"

namespace facecast::rig {
namespace {

// tinygltf reads what gltf_package hands it: no URI is left, so nothing outside the bytes is read
// (a path would be an error), and images stay encoded (no decoder runs on them).
bool refuse_external_file(std::vector<unsigned char>*, std::string* err, const std::string& path,
                          void*) {
  if (err) *err = "external file '" + path + "' is not read here";
  return false;
}
bool no_file_exists(const std::string&, void*) {
  return false;
}
std::string path_as_is(const std::string& path, void*) {
  return path;
}
bool refuse_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err = "writing files while reading a glTF";
  return false;
}
bool keep_image_undecoded(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                          const unsigned char*, int, void*) {
  return true;
}
bool refuse_image_write(const std::string*, const std::string*, const tinygltf::Image*, bool,
                        std::string*, void*) {
  return false;  // images are kept in their buffer views; nothing is encoded
}

std::string one_line(std::string msg) {
  while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
  for (auto& c : msg) c = c == '\n' ? ';' : c;
  return msg;
}

tinygltf::Model load_packed(const std::string& glb, const std::string& what) {
  tinygltf::Model m;
  tinygltf::TinyGLTF loader;
  loader.SetFsCallbacks(
      {&no_file_exists, &path_as_is, &refuse_external_file, &refuse_write, nullptr});
  loader.SetImageLoader(&keep_image_undecoded, nullptr);
  std::string err, warn;
  if (!loader.LoadBinaryFromMemory(&m, &err, &warn,
                                   reinterpret_cast<const unsigned char*>(glb.data()),
                                   static_cast<unsigned int>(glb.size())))
    throw Error(what + ": " + one_line(err.empty() ? "not a valid glTF file" : err));
  return m;
}

}  // namespace

AvatarDocument::AvatarDocument() : model_(std::make_unique<tinygltf::Model>()) {}
AvatarDocument::AvatarDocument(AvatarDocument&&) noexcept = default;
AvatarDocument& AvatarDocument::operator=(AvatarDocument&&) noexcept = default;
AvatarDocument::~AvatarDocument() = default;

AvatarDocument AvatarDocument::parse(std::string_view bytes, std::string_view name,
                                     const DecodeLimits& limits) {
  AvatarDocument doc;
  doc.name_ = std::string(name);
  doc.limits_ = limits;
  if (bytes.size() > 0x7FFFFFFF) throw Error(doc.name_ + ": file exceeds 2 GiB", ErrorCode::kLimit);
  detail::DecodeBudget budget(limits, bytes.size());
  const std::string packed = detail::pack_glb(bytes, doc.name_, std::nullopt, budget);
  *doc.model_ = load_packed(packed, doc.name_);
  doc.source_bytes_ = bytes.size();
  doc.decoded_bytes_ = packed.size();
  return doc;
}

AvatarDocument AvatarDocument::read(const std::filesystem::path& path, const DecodeLimits& limits) {
  AvatarDocument doc;
  doc.name_ = path.string();
  doc.limits_ = limits;
  const std::string bytes = read_file(path);
  if (bytes.size() > 0x7FFFFFFF) throw Error(doc.name_ + ": file exceeds 2 GiB", ErrorCode::kLimit);
  detail::DecodeBudget budget(limits, bytes.size());
  const std::string packed = detail::pack_glb(bytes, doc.name_, path.parent_path(), budget);
  *doc.model_ = load_packed(packed, doc.name_);
  doc.source_bytes_ = budget.file_bytes();
  doc.decoded_bytes_ = packed.size();
  return doc;
}

AvatarDocument AvatarDocument::from_model(tinygltf::Model model, std::string name) {
  AvatarDocument doc;
  *doc.model_ = std::move(model);
  doc.name_ = std::move(name);
  return doc;
}

std::string AvatarDocument::glb_bytes() const {
  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  writer.SetImageWriter(&refuse_image_write, nullptr);
  if (!writer.WriteGltfSceneToStream(model_.get(), out, false, true))
    throw Error(name_ + ": GLB serialization failed", ErrorCode::kInternal);
  return std::move(out).str();
}

void AvatarDocument::write_glb(const std::filesystem::path& path) const {
  write_file_atomic(path, glb_bytes());
}

}  // namespace facecast::rig
