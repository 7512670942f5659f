#pragma once
/// Random streams and randomised point sets for the Monte-Carlo methods (DESIGN.md, "The
/// methods": every stream is seeded from (seed, i, j), so a result never depends on the thread
/// count). Everything here is a pure function of (stream key, sample index): no generator state
/// is shared, nothing is allocated per sample.

#include <array>
#include <cstdint>
#include <string>

#include "formfactor/core/enum_names.h"

namespace formfactor {

/// SplitMix64's output function (Steele, Lea & Flood, "Fast splittable pseudorandom number
/// generators", OOPSLA 2014): a bijective 64-bit mixer.
constexpr std::uint64_t splitmix64(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

/// Key of the random stream (seed, i, j, k): a chained SplitMix64 hash. k distinguishes the
/// replicates of one (i, j) pair.
constexpr std::uint64_t stream_key(std::uint64_t seed, std::uint64_t i, std::uint64_t j,
                                   std::uint64_t k = 0) {
    return splitmix64(splitmix64(splitmix64(splitmix64(seed) ^ i) ^ j) ^ k);
}

/// A double in [0, 1) from the top 53 bits of a 64-bit word.
constexpr double to_unit(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

/// The uniform number in [0, 1) at position `counter` of the stream `key` (a Weyl sequence
/// through SplitMix64).
constexpr double uniform(std::uint64_t key, std::uint64_t counter) {
    return to_unit(splitmix64(key + counter * 0x9e3779b97f4a7c15ULL));
}

/// The point sets the Monte-Carlo methods can draw from (MethodOptions::sampler).
enum class SamplerKind {
    sobol,       ///< Sobol (Joe–Kuo direction numbers), Owen-scrambled per stream (default)
    halton,      ///< Halton, bases 2 3 5 7, random digit permutations per stream
    stratified,  ///< jittered k×k grids on dimensions (0,1) and (2,3), randomly paired
    random,      ///< independent uniform numbers
};

/// The names of the point sets.
inline constexpr EnumEntry<SamplerKind> kSamplerNames[] = {
    {SamplerKind::sobol, "sobol"},
    {SamplerKind::halton, "halton"},
    {SamplerKind::stratified, "stratified"},
    {SamplerKind::random, "random"},
};

/// Parses "sobol" | "halton" | "stratified" | "random"; throws OptionError("sampler", ...).
SamplerKind parse_sampler(const std::string& name);
/// The name parse_sampler() accepts.
std::string sampler_name(SamplerKind kind);

/// A randomised set of `n` points in [0,1)^4 for one stream. Point `index` (0 ≤ index < n) is a
/// pure function of (kind, key, n, index). Each point is uniformly distributed on [0,1)^4 (so
/// every estimator built on it is unbiased); the set as a whole is stratified or
/// low-discrepancy except for `random`. Independent keys give independent randomisations,
/// which is what the replicate standard error relies on.
class PointSet4 {
  public:
    PointSet4(SamplerKind kind, std::uint64_t key, std::uint32_t n);
    std::array<double, 4> operator()(std::uint32_t index) const;
    /// Points first, first+1, …, first+count−1 at once, coordinate d of point first+k in
    /// out[d][k]: the same values as operator() bit for bit, cheaper per point (Sobol points
    /// follow from their predecessor with one XOR per dimension; loops vectorise). A null
    /// out[d] skips coordinate d.
    void generate(std::uint32_t first, std::uint32_t count, double* const out[4]) const;
    SamplerKind kind() const { return kind_; }

  private:
    SamplerKind kind_;
    std::uint64_t key_;
    std::uint32_t n_;
    std::uint32_t scramble_[4] = {};  // Owen-scrambling seeds (sobol)
    // Halton: random digit permutations of the first digits (enough for n points), and a
    // random tail shared by all points (the permuted zero digits beyond them).
    static constexpr int kMaxDigits = 32;
    std::uint8_t digits_[4] = {};
    std::array<std::array<std::uint8_t, 8>, kMaxDigits> perm_[4] = {};
    double tail_[4] = {};
    std::uint32_t grid_ = 0;  // stratified: k (k² ≤ n points on the grids)
};

/// How n samples are split into independent replicates (randomisations) for the standard error
/// of stratified and quasi-random estimates: 16 when n ≥ 32, else n/2 (at least 1). `random`
/// uses one replicate and the i.i.d. variance formula instead.
std::uint32_t replicate_count(SamplerKind kind, std::uint64_t n);
/// Size of replicate r of n samples split into `replicates` (sizes differ by at most one).
inline std::uint64_t replicate_size(std::uint64_t n, std::uint32_t replicates, std::uint32_t r) {
    return n / replicates + (r < n % replicates ? 1 : 0);
}

}  // namespace formfactor
