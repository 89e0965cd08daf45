#include "storey/bag/sqlite_db.h"

#include <sqlite3.h>

#include "storey/bag/bag_error.h"

namespace storey::bag::detail {

Database::Database(const std::string& file, Mode mode) : file_(file) {
  const int flags =
      mode == Mode::kReadOnly ? SQLITE_OPEN_READONLY : (SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  const int rc = sqlite3_open_v2(file.c_str(), &db_, flags | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    sqlite3_close(db_);
    db_ = nullptr;
    throw BagError(file, "cannot open as an sqlite3 database: " + why);
  }
  sqlite3_extended_result_codes(db_, 1);
}

Database::~Database() {
  // Statements are owned by their users and finalised before the database goes.
  sqlite3_close_v2(db_);
}

void Database::fail(const std::string& what) const {
  throw BagError(file_, what + ": " + sqlite3_errmsg(db_));
}

std::string Database::errorMessage() const { return sqlite3_errmsg(db_); }

void Database::exec(const std::string& sql) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
    std::string why = message ? message : "unknown error";
    sqlite3_free(message);
    throw BagError(file_, "sqlite error in '" + sql + "': " + why);
  }
}

bool Database::hasTable(const std::string& table) {
  Statement query(*this, "SELECT 1 FROM sqlite_master WHERE type='table' AND name=?");
  query.bind(1, table);
  return query.step();
}

bool Database::hasColumn(const std::string& table, const std::string& column) {
  Statement query(*this, "SELECT 1 FROM pragma_table_info(?) WHERE name=?");
  query.bind(1, table);
  query.bind(2, column);
  return query.step();
}

Statement::Statement(Database& db, const std::string& sql) : db_(db), sql_(sql) {
  if (sqlite3_prepare_v2(db.handle(), sql.c_str(), -1, &stmt_, nullptr) != SQLITE_OK) {
    sqlite3_finalize(stmt_);
    stmt_ = nullptr;
    db.fail("cannot prepare '" + sql + "'");
  }
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

void Statement::bind(int index, std::int64_t value) {
  if (sqlite3_bind_int64(stmt_, index, value) != SQLITE_OK)
    db_.fail("bind failed in '" + sql_ + "'");
}

void Statement::bind(int index, const std::string& value) {
  if (sqlite3_bind_text(stmt_, index, value.data(), static_cast<int>(value.size()),
                        SQLITE_TRANSIENT) != SQLITE_OK) {
    db_.fail("bind failed in '" + sql_ + "'");
  }
}

void Statement::bindBlob(int index, const void* data, std::size_t size) {
  // SQLITE_STATIC: the caller keeps the bytes alive until step() returns.
  if (sqlite3_bind_blob64(stmt_, index, size ? data : "", size, SQLITE_STATIC) != SQLITE_OK) {
    db_.fail("bind failed in '" + sql_ + "'");
  }
}

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  db_.fail("read/write failed (corrupt or truncated database?) in '" + sql_ + "'");
}

void Statement::reset() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

std::int64_t Statement::columnInt(int index) const { return sqlite3_column_int64(stmt_, index); }

std::string Statement::columnText(int index) const {
  const unsigned char* text = sqlite3_column_text(stmt_, index);
  const int size = sqlite3_column_bytes(stmt_, index);
  return text ? std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(size))
              : std::string();
}

const void* Statement::columnBlob(int index) const { return sqlite3_column_blob(stmt_, index); }

std::size_t Statement::columnBytes(int index) const {
  return static_cast<std::size_t>(sqlite3_column_bytes(stmt_, index));
}

bool Statement::columnIsNull(int index) const {
  return sqlite3_column_type(stmt_, index) == SQLITE_NULL;
}

}  // namespace storey::bag::detail
