#pragma once
// One prepared SQLite statement, finalized on every path (the job store and the key store).
#include <sqlite3.h>

#include <filesystem>
#include <string>

#include "facecast/core/error.hpp"

namespace facecast::server {

class Statement {
 public:
  /// Throws Error (internal) naming `file` when `sql` does not prepare.
  Statement(sqlite3* db, const char* sql, const std::filesystem::path& file) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK)
      throw Error(file.string() + ": " + sqlite3_errmsg(db), ErrorCode::kInternal);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  sqlite3_stmt* get() const { return stmt_; }
  void text(int i, const std::string& s) {
    sqlite3_bind_text(stmt_, i, s.data(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
  }
  void real(int i, double v) { sqlite3_bind_double(stmt_, i, v); }
  std::string column_text(int i) const {
    const auto* p = sqlite3_column_text(stmt_, i);
    return p ? std::string(reinterpret_cast<const char*>(p),
                           static_cast<std::size_t>(sqlite3_column_bytes(stmt_, i)))
             : std::string();
  }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

}  // namespace facecast::server
