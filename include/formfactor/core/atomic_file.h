#pragma once
/// Atomic file output (STYLE.md, "Errors"): every file is written to a temporary name in the
/// same directory and renamed over the target only when everything succeeded, so an error or an
/// interrupted run never leaves a half-written or stale-but-new output behind.

#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

namespace formfactor {

/// Writes the content that `write` puts into the stream to `path`, atomically: the bytes go to
/// `PATH.tmp.<pid>` in the same directory (binary mode, so what is written is what ends up in
/// the file), which is renamed to `path` on success. When `write` throws, or the stream fails
/// (disk full, ...), or the rename fails, the temporary is removed, `path` is left as it was, and
/// the exception propagates (an I/O failure becomes InputError(path, 0, reason)). When
/// process_cancellation() is requested before the rename, nothing is written and Cancelled is
/// thrown.
void write_file_atomically(const std::string& path,
                           const std::function<void(std::ostream&)>& write);

/// Several outputs that appear together or not at all: stage() writes each one to its
/// temporary; commit() renames them all. Anything not committed (an exception before commit(),
/// or the transaction going out of scope) is removed. Use this when a command writes more than
/// one file, so a failure in the last one does not leave the first ones behind.
class OutputTransaction {
  public:
    OutputTransaction() = default;
    ~OutputTransaction();
    OutputTransaction(const OutputTransaction&) = delete;
    OutputTransaction& operator=(const OutputTransaction&) = delete;

    /// Writes `path`'s future content to its temporary now (throws like write_file_atomically).
    /// Staging the same path twice is an error (formfactor::Error).
    void stage(const std::string& path, const std::function<void(std::ostream&)>& write);
    /// The same for writers that open the file themselves and choose its format by the
    /// extension (HDF5, Matrix Market): `write` gets a temporary name in `path`'s directory that
    /// ends like `path` (staged_path_for), which commit() renames to `path`. When `write`
    /// throws, the temporary is removed and the exception propagates.
    void stage_file(const std::string& path, const std::function<void(const std::string&)>& write);
    /// Moves every file staged in `other` into this transaction, in order, leaving `other`
    /// empty: several steps stage their own outputs, and one commit writes them all or none.
    /// A target staged in both is an error (formfactor::Error) and `other` is then aborted.
    /// (Two transactions that stage one target the same way share its temporary name: give
    /// them distinct targets.)
    void adopt(OutputTransaction& other);
    /// Renames every staged temporary to its target, in staging order. When a rename fails,
    /// the remaining temporaries are removed and InputError(path, 0, reason) is thrown. When
    /// process_cancellation() is requested, every temporary is removed, nothing renamed, and
    /// Cancelled is thrown.
    void commit();
    /// Removes every staged temporary (idempotent).
    void abort() noexcept;
    /// The targets staged so far, in order.
    std::vector<std::string> paths() const;

  private:
    void check_not_staged(const std::string& path) const;
    struct Staged {
        std::string target;
        std::string temporary;
    };
    std::vector<Staged> staged_;
};

/// The temporary name used for `path`: `path + ".tmp." + pid`.
std::string temporary_path_for(const std::string& path);

/// The temporary name OutputTransaction::stage_file uses for `path`: in the same directory,
/// `.formfactor-staged-<pid>-` + the file name, so that it keeps `path`'s extension.
std::string staged_path_for(const std::string& path);

/// Throws InputError(path, 0, ...) when the directory that would hold `path` does not exist or
/// is not a directory. Call it before a long computation so that a typo in -o fails at once.
void check_output_directory(const std::string& path);

}  // namespace formfactor
