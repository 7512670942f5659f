#include "formfactor/core/random.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "formfactor/core/error.h"

namespace formfactor {
namespace {

// Bit reversal: byte swap, then the bits within each byte.
inline std::uint32_t reverse_bits(std::uint32_t x) {
    x = __builtin_bswap32(x);
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    return ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
}

// Sobol generator matrices of the first four dimensions, 32 bits. Dimension 0 is van der
// Corput; dimensions 1–3 use Joe & Kuo's primitive polynomials and initial direction numbers
// (new-joe-kuo-6.21201, d = 2, 3, 4: s = 1, 2, 3; a = 0, 1, 1; m = {1}, {1,3}, {1,3,1}).
struct SobolMatrices {
    std::uint32_t v[4][32];
    std::uint32_t prefix[4][32];  // reverse_bits(v[d][0] ^ … ^ v[d][t]), the bit-reversed domain
    SobolMatrices() {
        for (int b = 0; b < 32; ++b) v[0][b] = 1u << (31 - b);
        const int s[3] = {1, 2, 3};
        const unsigned a[3] = {0, 1, 1};
        const unsigned m[3][3] = {{1, 0, 0}, {1, 3, 0}, {1, 3, 1}};
        for (int d = 0; d < 3; ++d) {
            std::uint32_t* V = v[d + 1];
            for (int i = 0; i < s[d]; ++i) V[i] = m[d][i] << (31 - i);
            for (int i = s[d]; i < 32; ++i) {
                V[i] = V[i - s[d]] ^ (V[i - s[d]] >> s[d]);
                for (int k = 1; k < s[d]; ++k)
                    if ((a[d] >> (s[d] - 1 - k)) & 1u) V[i] ^= V[i - k];
            }
        }
        for (int d = 0; d < 4; ++d) {
            std::uint32_t acc = 0;
            for (int b = 0; b < 32; ++b) prefix[d][b] = reverse_bits(acc ^= v[d][b]);
        }
    }
};
const SobolMatrices kSobol;

// Branch-free (the index bits are unpredictable); dimension 0 is the bit reversal.
std::uint32_t sobol(std::uint32_t index, int dim) {
    if (dim == 0) return reverse_bits(index);
    std::uint32_t x = 0;
    const std::uint32_t* v = kSobol.v[dim];
    for (int b = 0; index; ++b, index >>= 1) x ^= v[b] & (0u - (index & 1u));
    return x;
}

// Hash-based nested uniform (Owen) scrambling: Laine & Karras 2011's bit-reversed-domain
// permutation with Burley's improved constants ("Practical Hash-based Owen Scrambling", JCGT
// 2020; as pbrt-v4's FastOwenScrambler). Each bit is flipped by a hash of the higher bits only.
// Takes the value bit-reversed (v = reverse_bits(x)): the Sobol generator below produces it so.
inline std::uint32_t owen_scramble_reversed(std::uint32_t v, std::uint32_t seed) {
    v ^= v * 0x3d20adeau;
    v += seed;
    v *= (seed >> 16) | 1u;
    v ^= v * 0x05526c56u;
    v ^= v * 0x53a22864u;
    return reverse_bits(v);
}
inline std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed) {
    return owen_scramble_reversed(reverse_bits(x), seed);
}

// A bijection of [0, l) chosen by p (Kensler, "Correlated Multi-Jittered Sampling", 2013).
std::uint32_t permute(std::uint32_t i, std::uint32_t l, std::uint32_t p) {
    std::uint32_t w = l - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    do {
        i ^= p;
        i *= 0xe170893du;
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i *= 0x0929eb3fu;
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i *= 1u | p >> 27;
        i *= 0x6935fa69u;
        i ^= (i & w) >> 11;
        i *= 0x74dcb303u;
        i ^= (i & w) >> 2;
        i *= 0x9e501cc3u;
        i ^= (i & w) >> 2;
        i *= 0xc860a3dfu;
        i &= w;
        i ^= i >> 5;
    } while (i >= l);
    return (i + p) % l;
}

constexpr std::uint32_t kBases[4] = {2, 3, 5, 7};
constexpr double kOneMinus = 0x1.fffffffffffffp-1;

}  // namespace

SamplerKind parse_sampler(const std::string& name) {
    return enum_from_name(kSamplerNames, name, "sampler", "sampler");
}

std::string sampler_name(SamplerKind kind) { return enum_to_name(kSamplerNames, kind); }

PointSet4::PointSet4(SamplerKind kind, std::uint64_t key, std::uint32_t n)
    : kind_(kind), key_(key), n_(n) {
    switch (kind) {
        case SamplerKind::sobol:
            for (int d = 0; d < 4; ++d)
                scramble_[d] = static_cast<std::uint32_t>(splitmix64(key ^ (0x51ULL + d)) >> 32);
            break;
        case SamplerKind::halton:
            for (int d = 0; d < 4; ++d) {
                const std::uint32_t b = kBases[d];
                int digits = 1;
                for (std::uint64_t p = b; p < n && digits < kMaxDigits; p *= b) ++digits;
                digits_[d] = static_cast<std::uint8_t>(digits);
                std::uint64_t h = splitmix64(key ^ (0x4a17ULL + 977 * d));
                for (int k = 0; k < digits; ++k) {
                    auto& perm = perm_[d][static_cast<std::size_t>(k)];
                    for (std::uint32_t t = 0; t < b; ++t) perm[t] = static_cast<std::uint8_t>(t);
                    for (std::uint32_t t = b - 1; t > 0; --t) {  // Fisher–Yates
                        h = splitmix64(h);
                        std::swap(perm[t], perm[(h >> 32) % (t + 1)]);
                    }
                }
                h = splitmix64(h);
                tail_[d] = to_unit(h) * std::pow(static_cast<double>(b), -digits);
            }
            break;
        case SamplerKind::stratified:
            grid_ = static_cast<std::uint32_t>(std::sqrt(static_cast<double>(n)));
            while (static_cast<std::uint64_t>(grid_ + 1) * (grid_ + 1) <= n) ++grid_;
            while (grid_ > 0 && static_cast<std::uint64_t>(grid_) * grid_ > n) --grid_;
            break;
        case SamplerKind::random:
            break;
    }
}

std::array<double, 4> PointSet4::operator()(std::uint32_t index) const {
    std::array<double, 4> u{};
    switch (kind_) {
        case SamplerKind::sobol:
            // 32 scrambled bits: u on the 2^-32 grid (never 1), uniform up to 2^-33.
            for (int d = 0; d < 4; ++d)
                u[static_cast<std::size_t>(d)] =
                    owen_scramble(sobol(index, d), scramble_[d]) * 0x1.0p-32;
            break;
        case SamplerKind::halton:
            for (int d = 0; d < 4; ++d) {
                const std::uint32_t b = kBases[d];
                const double inv_b = 1.0 / b;
                double f = inv_b, x = 0.0;
                std::uint32_t i = index;
                for (int k = 0; k < digits_[d]; ++k, f *= inv_b) {
                    x += perm_[d][static_cast<std::size_t>(k)][i % b] * f;
                    i /= b;
                }
                u[static_cast<std::size_t>(d)] = std::min(x + tail_[d], kOneMinus);
            }
            break;
        case SamplerKind::stratified: {
            const std::uint32_t g = grid_ * grid_;
            for (int pair = 0; pair < 2; ++pair) {
                const std::size_t d0 = 2 * static_cast<std::size_t>(pair);
                const double j0 = uniform(key_, 4ULL * index + d0);
                const double j1 = uniform(key_, 4ULL * index + d0 + 1);
                if (index < g) {
                    const std::uint32_t cell =
                        pair == 0 ? index
                                  : permute(index, g, static_cast<std::uint32_t>(key_ >> 32));
                    u[d0] = std::min((cell % grid_ + j0) / grid_, kOneMinus);
                    u[d0 + 1] = std::min((cell / grid_ + j1) / grid_, kOneMinus);
                } else {
                    u[d0] = j0;
                    u[d0 + 1] = j1;
                }
            }
            break;
        }
        case SamplerKind::random:
            for (int d = 0; d < 4; ++d)
                u[static_cast<std::size_t>(d)] = uniform(key_, 4ULL * index + d);
            break;
    }
    return u;
}

void PointSet4::generate(std::uint32_t first, std::uint32_t count, double* const out[4]) const {
    if (count == 0) return;
    if (kind_ != SamplerKind::sobol) {
        for (std::uint32_t k = 0; k < count; ++k) {
            const auto u = (*this)(first + k);
            for (int d = 0; d < 4; ++d)
                if (out[d]) out[d][k] = u[static_cast<std::size_t>(d)];
        }
        return;
    }
    // sobol(i + 1) = sobol(i) ^ v[0] ^ … ^ v[t] with t = ctz(i + 1): the bits of i that flip.
    // Kept bit-reversed (reversal is linear over XOR), which is where the scrambler starts;
    // then scrambled in a separate loop.
    constexpr std::uint32_t kChunk = 256;
    std::uint32_t raw[kChunk];
    for (int d = 0; d < 4; ++d) {
        if (!out[d]) continue;
        std::uint32_t x = reverse_bits(sobol(first, d));
        const std::uint32_t* pre = kSobol.prefix[d];
        const std::uint32_t seed = scramble_[d];
        double* o = out[d];
        for (std::uint32_t k0 = 0; k0 < count; k0 += kChunk) {
            const std::uint32_t m = std::min(kChunk, count - k0);
            for (std::uint32_t k = 0; k < m; ++k) {
                raw[k] = x;
                const std::uint32_t next = first + k0 + k + 1;
                x ^= pre[next ? std::countr_zero(next) : 31];
            }
            for (std::uint32_t k = 0; k < m; ++k)
                o[k0 + k] = owen_scramble_reversed(raw[k], seed) * 0x1.0p-32;
        }
    }
}

std::uint32_t replicate_count(SamplerKind kind, std::uint64_t n) {
    if (kind == SamplerKind::random) return 1;
    if (n >= 32) return 16;
    return static_cast<std::uint32_t>(std::max<std::uint64_t>(1, n / 2));
}

}  // namespace formfactor
