#include "formfactor/core/fields.h"

#include <algorithm>
#include <stdexcept>

namespace formfactor {

Fields& Fields::operator[](const std::string& key) {
    if (kind_ == Kind::null) kind_ = Kind::object;
    if (kind_ != Kind::object) throw std::logic_error("Fields: '" + key + "' of a non-object");
    const auto it = std::find(keys_.begin(), keys_.end(), key);
    if (it != keys_.end()) return values_[static_cast<std::size_t>(it - keys_.begin())];
    keys_.push_back(key);
    values_.emplace_back();
    return values_.back();
}

const Fields& Fields::at(const std::string& key) const {
    const auto it = std::find(keys_.begin(), keys_.end(), key);
    if (kind_ != Kind::object || it == keys_.end())
        throw std::out_of_range("Fields: no member '" + key + "'");
    return values_[static_cast<std::size_t>(it - keys_.begin())];
}

bool Fields::contains(const std::string& key) const {
    return kind_ == Kind::object && std::find(keys_.begin(), keys_.end(), key) != keys_.end();
}

double Fields::real() const {
    switch (kind_) {
        case Kind::real:
            return d_;
        case Kind::integer:
            return static_cast<double>(i_);
        case Kind::unsigned_integer:
            return static_cast<double>(u_);
        default:
            throw std::logic_error("Fields: not a number");
    }
}

}  // namespace formfactor
