#include "core/text_numbers.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdlib>

namespace formfactor::detail {

namespace {

__extension__ typedef unsigned __int128 u128;

constexpr std::uint64_t kPow10[19] = {1ull,
                                      10ull,
                                      100ull,
                                      1000ull,
                                      10000ull,
                                      100000ull,
                                      1000000ull,
                                      10000000ull,
                                      100000000ull,
                                      1000000000ull,
                                      10000000000ull,
                                      100000000000ull,
                                      1000000000000ull,
                                      10000000000000ull,
                                      100000000000000ull,
                                      1000000000000000ull,
                                      10000000000000000ull,
                                      100000000000000000ull,
                                      1000000000000000000ull};

// 5^k for k ≤ 32 (5^32 < 2^75, so m·5^k < 2^53·2^75 fits in 128 bits).
constexpr int kMaxPow5 = 32;
constexpr auto kPow5 = [] {
    std::array<u128, kMaxPow5 + 1> t{};
    t[0] = 1;
    for (std::size_t k = 1; k < t.size(); ++k) t[k] = 5 * t[k - 1];
    return t;
}();

constexpr char kDigitPairs[201] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
    "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
    "8081828384858687888990919293949596979899";

// The n lowest decimal digits of v, zero-padded, at p.
inline void put_digits(char* p, std::uint64_t v, int n) {
    while (n >= 2) {
        const auto r = static_cast<std::size_t>(v % 100);
        v /= 100;
        n -= 2;
        std::memcpy(p + n, kDigitPairs + 2 * r, 2);
    }
    if (n == 1) p[0] = static_cast<char>('0' + v % 10);
}

// A finite double's magnitude as m·2^e (m < 2^53; zero and subnormals too).
struct Binary {
    std::uint64_t m;
    int e;
    bool negative;
    bool normal;
};
inline Binary decompose(double x) {
    const auto bits = std::bit_cast<std::uint64_t>(x);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    const std::uint64_t fraction = bits & ((std::uint64_t(1) << 52) - 1);
    if (biased == 0) return {fraction, -1074, (bits >> 63) != 0, false};
    return {fraction | (std::uint64_t(1) << 52), biased - 1075, (bits >> 63) != 0, true};
}

// round(v·2^s), half to even, into q; false when it does not fit in 64 bits.
inline bool round_scaled(u128 v, int s, std::uint64_t& q) {
    if (s >= 0) {
        if (s >= 64 || v >= (u128(1) << (64 - s))) return false;
        q = static_cast<std::uint64_t>(v << s);
        return true;
    }
    const int r = -s;
    if (r >= 128) {  // v·2^s < 1: 1 only above one half (a tie goes to the even 0)
        q = r == 128 && v > (u128(1) << 127) ? 1 : 0;
        return true;
    }
    u128 w = v >> r;
    const u128 rem = v - (w << r);
    const u128 half = u128(1) << (r - 1);
    if (rem > half || (rem == half && (w & 1) != 0)) ++w;
    if (w >> 64) return false;
    q = static_cast<std::uint64_t>(w);
    return true;
}

// round(m·2^e·10^k) for 0 ≤ k ≤ kMaxPow5 (10^k = 5^k·2^k).
inline bool decimal_scaled(std::uint64_t m, int e, int k, std::uint64_t& q) {
    if (k < 0 || k > kMaxPow5) return false;
    return round_scaled(u128(m) * kPow5[static_cast<std::size_t>(k)], e + k, q);
}

char* g17_fallback(char* p, double x) {
    return std::to_chars(p, p + kMaxNumberChars, x, std::chars_format::general, 17).ptr;
}

}  // namespace

char* print_g17(char* p, double x) {
    const Binary b = decompose(x);
    if (!b.normal || !std::isfinite(x)) return g17_fallback(p, x);
    // Decimal exponent X = ⌊log10 |x|⌋ is ⌊e2·log10 2⌋ or one more, e2 = ⌊log2 |x|⌋; then the 17
    // significant digits D = round(|x|·10^(16−X)) ∈ [10^16, 10^17).
    const int e2 = b.e + 52;
    int X = (e2 * 78913) >> 18;  // ⌊e2·log10 2⌋ for |e2| < 1650 (Ryu's log10Pow2)
    std::uint64_t D = 0;
    if (!decimal_scaled(b.m, b.e, 16 - X, D)) return g17_fallback(p, x);
    if (D < kPow10[16]) {
        --X;
        if (!decimal_scaled(b.m, b.e, 16 - X, D)) return g17_fallback(p, x);
    } else if (D >= kPow10[17]) {
        ++X;
        if (!decimal_scaled(b.m, b.e, 16 - X, D)) return g17_fallback(p, x);
        if (D >= kPow10[17]) {  // rounded up to a power of ten
            D /= 10;
            ++X;
        }
    }
    char digits[17];
    put_digits(digits, D, 17);
    int nd = 17;
    while (nd > 1 && digits[nd - 1] == '0') --nd;  // %g drops trailing zeros
    if (b.negative) *p++ = '-';
    if (X >= -4 && X < 17) {
        if (X >= 0) {
            std::memcpy(p, digits, static_cast<std::size_t>(X + 1));
            p += X + 1;
            if (nd > X + 1) {
                *p++ = '.';
                std::memcpy(p, digits + X + 1, static_cast<std::size_t>(nd - X - 1));
                p += nd - X - 1;
            }
        } else {
            *p++ = '0';
            *p++ = '.';
            for (int k = 0; k < -X - 1; ++k) *p++ = '0';
            std::memcpy(p, digits, static_cast<std::size_t>(nd));
            p += nd;
        }
        return p;
    }
    *p++ = digits[0];
    if (nd > 1) {
        *p++ = '.';
        std::memcpy(p, digits + 1, static_cast<std::size_t>(nd - 1));
        p += nd - 1;
    }
    *p++ = 'e';
    int ex = X;
    *p++ = ex < 0 ? '-' : '+';
    ex = std::abs(ex);
    if (ex < 10) *p++ = '0';
    return std::to_chars(p, p + 4, ex).ptr;
}

char* print_g(char* p, double x) {
    return std::to_chars(p, p + kMaxNumberChars, x, std::chars_format::general, 6).ptr;
}

char* print_fixed(char* p, double x, int decimals) {
    decimals = std::clamp(decimals, 0, 9);
    // Fast path |x| < 1e9: round(|x|·10^d) < 10^18 fits; m·10^d < 2^53·2^30 fits in 128 bits.
    if (std::isfinite(x) && std::abs(x) < 1e9) {
        const Binary b = decompose(x);
        std::uint64_t q = 0;
        if (round_scaled(u128(b.m) * kPow10[static_cast<std::size_t>(decimals)], b.e, q)) {
            if (b.negative) *p++ = '-';  // printf keeps the sign of -0 and of what rounds to 0
            const std::uint64_t scale = kPow10[static_cast<std::size_t>(decimals)];
            p = std::to_chars(p, p + 24, q / scale).ptr;
            if (decimals > 0) {
                *p++ = '.';
                put_digits(p, q % scale, decimals);
                p += decimals;
            }
            return p;
        }
    }
    return std::to_chars(p, p + kMaxNumberChars, x, std::chars_format::fixed, decimals).ptr;
}

char* print_integer(char* p, long long v) { return std::to_chars(p, p + 24, v).ptr; }

void TextBuffer::grow(std::size_t n) {
    const std::size_t capacity = std::max({size_ + n, 2 * capacity_, std::size_t(1) << 16});
    std::unique_ptr<char[]> data(new char[capacity]);
    if (size_ > 0) std::memcpy(data.get(), data_.get(), size_);
    data_ = std::move(data);
    capacity_ = capacity;
}

}  // namespace formfactor::detail
