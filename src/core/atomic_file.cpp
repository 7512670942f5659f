#include "formfactor/core/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <streambuf>
#include <system_error>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/core/phase.h"

namespace formfactor {

namespace fs = std::filesystem;

std::string temporary_path_for(const std::string& path) {
    return path + ".tmp." + std::to_string(static_cast<long long>(::getpid()));
}

std::string staged_path_for(const std::string& path) {
    const fs::path target(path);
    return (target.parent_path() /
            (".formfactor-staged-" + std::to_string(static_cast<long long>(::getpid())) + "-" +
             target.filename().string()))
        .string();
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

// Passes what a writer puts to `sink` in 64 KiB pieces and polls process_cancellation() between
// them: a dense matrix of 10^4 patches is 10^8 numbers of text, and a signal must not wait for
// the last. Once a stop is asked for, every further put fails, so the writer's remaining puts
// cost nothing and it returns soon; write_temporary() then throws Cancelled.
class CancellableBuffer final : public std::streambuf {
  public:
    explicit CancellableBuffer(std::streambuf* sink) : sink_(sink) { setp(buf_, buf_ + kSize); }
    CancellableBuffer(const CancellableBuffer&) = delete;
    CancellableBuffer& operator=(const CancellableBuffer&) = delete;

  protected:
    int_type overflow(int_type c) override {
        if (!drain()) return traits_type::eof();
        if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
        *pptr() = traits_type::to_char_type(c);
        pbump(1);
        return c;
    }
    int sync() override { return drain() && sink_->pubsync() == 0 ? 0 : -1; }

  private:
    static constexpr std::ptrdiff_t kSize = 1 << 16;
    bool drain() {
        if (process_cancellation().requested()) return false;
        const std::ptrdiff_t n = pptr() - pbase();
        if (n > 0 && sink_->sputn(pbase(), n) != n) return false;
        setp(buf_, buf_ + kSize);
        return true;
    }
    std::streambuf* sink_;
    char buf_[kSize];
};

/// Writes `write`'s output to `temporary`; on any failure, or when the process was asked to
/// stop meanwhile (process_cancellation()), removes it and throws.
void write_temporary(const std::string& target, const std::string& temporary,
                     const std::function<void(std::ostream&)>& write) {
    process_cancellation().throw_if_requested();
    announce_phase("write");
    if (fs::is_directory(target)) throw InputError(target, 0, "is a directory");
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) {
        const std::string reason = std::strerror(errno);
        check_output_directory(target);
        throw InputError(target, 0, "cannot write: " + reason);
    }
    try {
        {
            const auto buffer = std::make_unique<CancellableBuffer>(out.rdbuf());
            std::ostream polled(buffer.get());
            write(polled);
            polled.flush();
            process_cancellation().throw_if_requested();
            if (!polled) out.setstate(std::ios::badbit);
        }
        out.flush();
        if (!out) throw InputError(target, 0, "write failed (disk full?)");
        out.close();
        if (out.fail()) throw InputError(target, 0, "write failed when closing the file");
        process_cancellation().throw_if_requested();
    } catch (...) {
        out.close();
        remove_quietly(temporary);
        // A writer that saw its stream fail once the stop was asked for reports a failed write:
        // the cause is the stop.
        if (process_cancellation().requested()) throw Cancelled();
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

void OutputTransaction::check_not_staged(const std::string& path) const {
    for (const auto& s : staged_) {
        if (fs::path(s.target).lexically_normal() == fs::path(path).lexically_normal()) {
            throw Error(path + ": the same file is written twice");
        }
    }
}

void OutputTransaction::stage(const std::string& path,
                              const std::function<void(std::ostream&)>& write) {
    check_not_staged(path);
    const std::string temporary = temporary_path_for(path);
    write_temporary(path, temporary, write);
    staged_.push_back({path, temporary});
}

void OutputTransaction::stage_file(const std::string& path,
                                   const std::function<void(const std::string&)>& write) {
    check_not_staged(path);
    process_cancellation().throw_if_requested();
    if (fs::is_directory(path)) throw InputError(path, 0, "is a directory");
    const std::string temporary = staged_path_for(path);
    try {
        write(temporary);
    } catch (...) {
        remove_quietly(temporary);
        throw;
    }
    staged_.push_back({path, temporary});
}

void OutputTransaction::adopt(OutputTransaction& other) {
    try {
        for (const auto& s : other.staged_) check_not_staged(s.target);
    } catch (...) {
        other.abort();
        throw;
    }
    staged_.insert(staged_.end(), other.staged_.begin(), other.staged_.end());
    other.staged_.clear();
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
