#pragma once
// Where tests find real data. Tests that need ../shared/data call require_*(); when the data is
// missing they FAIL under CI=true and otherwise WARN and return false, so the caller returns.
#include <filesystem>
#include <string>

namespace facecast::test {

/// ../shared/data (or $FACECAST_SHARED_DATA).
std::filesystem::path shared_data();
/// The extracted ICT FaceKit folder: <build>/test-data/ict-facekit/FaceXModel.
std::filesystem::path ict_dir();
/// A scratch folder for this test process, removed at exit.
std::filesystem::path scratch_dir();

/// <build>/test-artifacts/<name>, created: pictures and videos kept for people to look at.
std::filesystem::path artifacts_dir(const std::string& name);

/// True if `path` exists; otherwise FAILs (CI=true) or WARNs and returns false.
bool require_data(const std::filesystem::path& path);

}  // namespace facecast::test
