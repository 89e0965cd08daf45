// A thin RAII layer over sqlite3 for the bag storage: every failure becomes a BagError
// naming the database file. Internal to storey::bag (no sqlite3 type leaks out).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

struct sqlite3;
struct sqlite3_stmt;

namespace storey::bag::detail {

class Database;

class Statement {
 public:
  Statement(Database& db, const std::string& sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void bind(int index, std::int64_t value);
  void bind(int index, const std::string& value);
  void bindBlob(int index, const void* data, std::size_t size);
  // True when a row is available; false at the end. Throws BagError on any failure.
  bool step();
  void reset();
  std::int64_t columnInt(int index) const;
  std::string columnText(int index) const;
  const void* columnBlob(int index) const;
  std::size_t columnBytes(int index) const;
  bool columnIsNull(int index) const;

 private:
  Database& db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

class Database {
 public:
  enum class Mode { kReadOnly, kCreate };
  Database(const std::string& file, Mode mode);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  void exec(const std::string& sql);
  bool hasTable(const std::string& table);
  bool hasColumn(const std::string& table, const std::string& column);
  const std::string& file() const { return file_; }
  sqlite3* handle() { return db_; }
  [[noreturn]] void fail(const std::string& what) const;
  std::string errorMessage() const;  // sqlite's message for the last failure

 private:
  std::string file_;
  sqlite3* db_ = nullptr;
};

}  // namespace storey::bag::detail
