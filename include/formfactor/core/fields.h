#pragma once
/// A small typed tree of named values: the method-specific part of a method's report (counts,
/// rates, options as used, per-phase times). Methods fill it; only output/ turns it into JSON
/// (formfactor/output/report.h), so that no method or matrix header depends on a JSON library.
///
///     Fields f;
///     f["pairs"] = std::size_t(120);
///     f["phases"]["rays"]["seconds"] = 0.25;
///     const double s = f["phases"]["rays"]["seconds"].real();

#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace formfactor {

/// One value: null, a boolean, a signed or unsigned integer, a real, a text, a list of reals, or
/// an object of named values (insertion order kept).
class Fields {
  public:
    enum class Kind { null, boolean, integer, unsigned_integer, real, text, reals, object };

    Fields() = default;
    /// An object without members (as opposed to null).
    static Fields object() {
        Fields f;
        f.kind_ = Kind::object;
        return f;
    }

    Fields& operator=(bool v) {
        return set(Kind::boolean, [&] { b_ = v; });
    }
    Fields& operator=(const char* v) { return *this = std::string(v); }
    Fields& operator=(std::string v) {
        return set(Kind::text, [&] { s_ = std::move(v); });
    }
    Fields& operator=(std::vector<double> v) {
        return set(Kind::reals, [&] { reals_ = std::move(v); });
    }
    template <class T, std::enable_if_t<std::is_floating_point_v<T>, int> = 0>
    Fields& operator=(T v) {
        return set(Kind::real, [&] { d_ = static_cast<double>(v); });
    }
    template <class T, std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>, int> = 0>
    Fields& operator=(T v) {
        if constexpr (std::is_signed_v<T>) {
            return set(Kind::integer, [&] { i_ = static_cast<std::int64_t>(v); });
        } else {
            return set(Kind::unsigned_integer, [&] { u_ = static_cast<std::uint64_t>(v); });
        }
    }

    /// The member `key` (created as null when missing; a null value becomes an object).
    Fields& operator[](const std::string& key);
    /// The member `key`; throws std::out_of_range when missing.
    const Fields& at(const std::string& key) const;
    bool contains(const std::string& key) const;

    Kind kind() const { return kind_; }
    bool is_null() const { return kind_ == Kind::null; }
    bool is_object() const { return kind_ == Kind::object; }
    /// The value as a real (any number kind); throws std::logic_error for another kind.
    double real() const;
    bool boolean() const { return b_; }
    std::int64_t integer() const { return i_; }
    std::uint64_t unsigned_integer() const { return u_; }
    const std::string& text() const { return s_; }
    const std::vector<double>& reals() const { return reals_; }
    /// Members of an object, in insertion order.
    const std::vector<std::string>& keys() const { return keys_; }
    const std::vector<Fields>& values() const { return values_; }

  private:
    template <class F>
    Fields& set(Kind k, F&& assign) {
        *this = Fields();
        kind_ = k;
        assign();
        return *this;
    }

    Kind kind_ = Kind::null;
    bool b_ = false;
    std::int64_t i_ = 0;
    std::uint64_t u_ = 0;
    double d_ = 0.0;
    std::string s_;
    std::vector<double> reals_;
    std::vector<std::string> keys_;
    std::vector<Fields> values_;
};

}  // namespace formfactor
