#pragma once
// Numbers as text for the writers of large tables (matrix_io.cpp, patch_table.cpp): the exact
// bytes of C's printf conversions, without printf, streams or allocation. Every function
// writes at p (room for kMaxNumberChars characters) and returns the end; no terminating NUL.
//
// %.17g and %.Nf have exact integer fast paths (the double is m·2^e; m·10^k·2^e is formed in
// 128-bit integers and rounded half-to-even, as glibc does, so the digits are the correctly
// rounded ones); values outside them (zero, subnormals, huge magnitudes, inf, nan) go to
// std::to_chars with the same precision, which the standard defines as printf's output.
// tests/test_output.cpp holds both against snprintf on millions of values.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string_view>

namespace formfactor::detail {

/// Longest text of one number here (%.6f of 1.8e308 has 309 integer digits).
inline constexpr std::size_t kMaxNumberChars = 330;

/// printf("%.17g", x): enough digits for every double to read back bit for bit.
char* print_g17(char* p, double x);
/// printf("%g", x) (six significant digits, trailing zeros dropped).
char* print_g(char* p, double x);
/// printf("%.*f", decimals, x) for 0 ≤ decimals ≤ 9.
char* print_fixed(char* p, double x, int decimals);
/// The decimal digits of v (with a '-' when negative).
char* print_integer(char* p, long long v);

/// A growable character buffer for building large text blocks: reserve room, write with the
/// print_* functions, then commit the new end. No initialisation of the reserved room.
class TextBuffer {
  public:
    /// Ensures room for n more characters; returns where they go.
    char* room(std::size_t n) {
        if (capacity_ - size_ < n) grow(n);
        return data_.get() + size_;
    }
    /// Marks everything up to `end` (a pointer into the last room()) as written.
    void commit(char* end) { size_ = static_cast<std::size_t>(end - data_.get()); }
    void put(char c) {
        char* p = room(1);
        *p = c;
        ++size_;
    }
    void append(std::string_view s) {
        char* p = room(s.size());
        if (!s.empty()) std::memcpy(p, s.data(), s.size());
        size_ += s.size();
    }
    const char* data() const { return data_.get(); }
    std::size_t size() const { return size_; }
    void clear() { size_ = 0; }

  private:
    void grow(std::size_t n);
    std::unique_ptr<char[]> data_;
    std::size_t size_ = 0, capacity_ = 0;
};

}  // namespace formfactor::detail
