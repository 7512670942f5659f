#pragma once
// What the ranks send each other, as flat bytes: the scene (with its patches), the method's
// options, a method report and rows of F. Every rank runs the same binary, so plain values go
// as their bytes; a double arrives bit for bit.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/fields.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"

namespace formfactor::distributed {

/// Appends values to a byte buffer. (resize and memcpy rather than vector::insert: where the
/// inserts are inlined into a short message, GCC 12 warns of overflows that are none,
/// -Wstringop-overflow and -Warray-bounds.)
class WireWriter {
  public:
    WireWriter() = default;
    /// Writes into `reuse`, emptied: a buffer whose memory is already mapped.
    explicit WireWriter(std::vector<char> reuse) : bytes_(std::move(reuse)) { bytes_.clear(); }

    template <class T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        const std::size_t at = bytes_.size();
        bytes_.resize(at + sizeof(T));
        std::memcpy(bytes_.data() + at, &v, sizeof(T));
    }
    template <class T>
    void put_array(const T* data, std::size_t count) {
        static_assert(std::is_trivially_copyable_v<T>);
        put<std::uint64_t>(count);
        if (count == 0) return;
        const std::size_t at = bytes_.size();
        bytes_.resize(at + count * sizeof(T));
        std::memcpy(bytes_.data() + at, data, count * sizeof(T));
    }
    /// Room for `count` values of T (their count written first, as put_array() does), for the
    /// caller to fill before the next put.
    template <class T>
    T* put_space(std::size_t count) {
        static_assert(std::is_trivially_copyable_v<T>);
        put<std::uint64_t>(count);
        const std::size_t at = bytes_.size();
        bytes_.resize(at + count * sizeof(T));
        return reinterpret_cast<T*>(bytes_.data() + at);
    }
    /// Overwrites the value put at byte `at`.
    template <class T>
    void patch(std::size_t at, const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        std::memcpy(bytes_.data() + at, &v, sizeof(T));
    }
    template <class T>
    void put_vector(const std::vector<T>& v) {
        put_array(v.data(), v.size());
    }
    void put_string(const std::string& s) { put_array(s.data(), s.size()); }

    std::vector<char>& bytes() { return bytes_; }

  private:
    std::vector<char> bytes_;
};

/// Reads what a WireWriter wrote, in the same order; throws Error on a short buffer.
class WireReader {
  public:
    WireReader(const char* data, std::size_t size) : data_(data), size_(size) {}

    template <class T>
    T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        T v;
        std::memcpy(&v, take(sizeof(T)), sizeof(T));
        return v;
    }
    /// The count of an array, then a pointer to its elements (valid while the buffer lives).
    template <class T>
    std::size_t get_array(const char** data) {
        const auto count = get<std::uint64_t>();
        if (count > size_ / sizeof(T) + 1) fail();
        *data = take(count * sizeof(T));
        return count;
    }
    template <class T>
    std::vector<T> get_vector() {
        const char* p = nullptr;
        const std::size_t count = get_array<T>(&p);
        std::vector<T> v(count);
        if (count) std::memcpy(v.data(), p, count * sizeof(T));
        return v;
    }
    std::string get_string() {
        const char* p = nullptr;
        const std::size_t count = get_array<char>(&p);
        return std::string(p, count);
    }
    bool at_end() const { return pos_ == size_; }

  private:
    const char* take(std::size_t n) {
        if (n > size_ - pos_) fail();
        const char* p = data_ + pos_;
        pos_ += n;
        return p;
    }
    [[noreturn]] static void fail() { throw Error("distributed: a message ended early"); }

    const char* data_;
    std::size_t size_;
    std::size_t pos_ = 0;
};

void put_scene(WireWriter& w, const Scene& scene);
Scene get_scene(WireReader& r);

void put_report(WireWriter& w, const MethodReport& report);
MethodReport get_report(WireReader& r);

/// Rows a method emitted sparse, or the entries that are not 0 of a dense block (NaNs kept):
/// the same stored entries, row sums and dropped mass once thresholded (adding a zero changes
/// no sum).
void put_sparse_rows(WireWriter& w, const SparseRows& rows);
SparseRows get_sparse_rows(WireReader& r);
SparseRows nonzero_rows(const FormFactors& block);

}  // namespace formfactor::distributed
