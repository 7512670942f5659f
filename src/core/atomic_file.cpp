#include "formfactor/core/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"

namespace formfactor {

namespace fs = std::filesystem;

std::string temporary_path_for(const std::string& path) {
    return path + ".tmp." + std::to_string(static_cast<long long>(::getpid()));
}

void check_output_directory(const std::string& path) {
    if (path.empty()) throw InputError(path, 0, "empty output file name");
    const fs::path parent = fs::path(path).parent_path();
    if (parent.empty()) return;  // the current directory
    std::error_code ec;
    const fs::file_status st = fs::status(parent, ec);
    if (!fs::exists(st)) {
        throw InputError(path, 0, "directory '" + parent.string() + "' does not exist");
    }
    if (!fs::is_directory(st)) {
        throw InputError(path, 0, "'" + parent.string() + "' is not a directory");
    }
}

namespace {

void remove_quietly(const std::string& path) noexcept {
    std::error_code ec;
    fs::remove(path, ec);
}

/// Writes `write`'s output to `temporary`; on any failure, or when the process was asked to
/// stop meanwhile (process_cancellation()), removes it and throws.
void write_temporary(const std::string& target, const std::string& temporary,
                     const std::function<void(std::ostream&)>& write) {
    process_cancellation().throw_if_requested();
    if (fs::is_directory(target)) throw InputError(target, 0, "is a directory");
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) {
        const std::string reason = std::strerror(errno);
        check_output_directory(target);
        throw InputError(target, 0, "cannot write: " + reason);
    }
    try {
        write(out);
        out.flush();
        if (!out) throw InputError(target, 0, "write failed (disk full?)");
        out.close();
        if (out.fail()) throw InputError(target, 0, "write failed when closing the file");
        process_cancellation().throw_if_requested();
    } catch (...) {
        out.close();
        remove_quietly(temporary);
        throw;
    }
}

void rename_into_place(const std::string& temporary, const std::string& target) {
    if (std::rename(temporary.c_str(), target.c_str()) != 0) {
        const std::string reason = std::strerror(errno);
        remove_quietly(temporary);
        throw InputError(target, 0, "cannot rename the temporary file into place: " + reason);
    }
}

}  // namespace

void write_file_atomically(const std::string& path,
                           const std::function<void(std::ostream&)>& write) {
    const std::string temporary = temporary_path_for(path);
    write_temporary(path, temporary, write);
    rename_into_place(temporary, path);
}

OutputTransaction::~OutputTransaction() { abort(); }

void OutputTransaction::stage(const std::string& path,
                              const std::function<void(std::ostream&)>& write) {
    for (const auto& s : staged_) {
        if (fs::path(s.target).lexically_normal() == fs::path(path).lexically_normal()) {
            throw Error(path + ": the same file is written twice");
        }
    }
    const std::string temporary = temporary_path_for(path);
    write_temporary(path, temporary, write);
    staged_.push_back({path, temporary});
}

void OutputTransaction::commit() {
    if (process_cancellation().requested()) {
        abort();
        throw Cancelled();
    }
    std::vector<Staged> todo;
    todo.swap(staged_);
    for (std::size_t k = 0; k < todo.size(); ++k) {
        try {
            rename_into_place(todo[k].temporary, todo[k].target);
        } catch (...) {
            for (std::size_t m = k + 1; m < todo.size(); ++m) remove_quietly(todo[m].temporary);
            throw;
        }
    }
}

void OutputTransaction::abort() noexcept {
    for (const auto& s : staged_) remove_quietly(s.temporary);
    staged_.clear();
}

std::vector<std::string> OutputTransaction::paths() const {
    std::vector<std::string> out;
    out.reserve(staged_.size());
    for (const auto& s : staged_) out.push_back(s.target);
    return out;
}

}  // namespace formfactor
