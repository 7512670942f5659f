// Reading Elmer's view-factor file (the `.dat` layout of formfactor/output/matrix_io.h).

#include <fmt/format.h>

#include <cmath>
#include <istream>
#include <limits>
#include <string>
#include <vector>

#include "core/text.h"
#include "formfactor/core/error.h"
#include "formfactor/output/matrix_io.h"

namespace formfactor {

DenseMatrix read_elmer_view_factors(std::istream& in, const std::string& name) {
    struct Entry {
        std::size_t row, col;
        double value;
        int line;
    };
    std::vector<Entry> entries;
    std::size_t rows = 0;
    std::size_t expected = 0;  // entry lines still due in the current row block
    bool in_block = false;
    std::vector<std::size_t> seen_in_row;  // columns of the current row, to catch repeats
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        const std::vector<std::string> words = detail::split(line, " \t\r");
        if (words.empty()) continue;
        if (!in_block || expected == 0) {
            std::size_t n = 0;
            if (words.size() != 1 || !detail::parse_size(words[0], n))
                throw InputError(name, line_no,
                                 fmt::format("expected the number of entries of row {} (one "
                                             "integer ≥ 0), got '{}'",
                                             rows + 1, detail::trim(line)));
            if (n > (std::size_t(1) << 31))
                throw InputError(name, line_no,
                                 fmt::format("row {} claims {} entries", rows + 1, n));
            ++rows;
            expected = n;
            in_block = true;
            seen_in_row.clear();
            continue;
        }
        if (words.size() != 3)
            throw InputError(
                name, line_no,
                fmt::format("expected 'i j F' (row {}), got {} values", rows, words.size()));
        std::size_t i = 0, j = 0;
        double v = 0.0;
        if (!detail::parse_size(words[0], i) || i != rows)
            throw InputError(
                name, line_no,
                fmt::format("row number '{}' where row {} is being read", words[0], rows));
        if (!detail::parse_size(words[1], j) || j == 0)
            throw InputError(name, line_no,
                             fmt::format("column '{}' is not a number ≥ 1", words[1]));
        if (!detail::parse_double(words[2], v))
            throw InputError(name, line_no, fmt::format("malformed number '{}'", words[2]));
        if (!std::isfinite(v))
            throw InputError(name, line_no, fmt::format("non-finite value '{}'", words[2]));
        for (std::size_t c : seen_in_row)
            if (c == j)
                throw InputError(name, line_no,
                                 fmt::format("column {} appears twice in row {}", j, rows));
        seen_in_row.push_back(j);
        entries.push_back({i - 1, j - 1, v, line_no});
        --expected;
    }
    if (in_block && expected > 0)
        throw InputError(
            name, line_no,
            fmt::format("file ends with {} entries of row {} missing", expected, rows));
    if (rows == 0) throw InputError(name, line_no, "no rows (an empty view-factor file)");
    for (const Entry& e : entries)
        if (e.col >= rows)
            throw InputError(
                name, e.line,
                fmt::format("column {} is beyond the {} rows of the file", e.col + 1, rows));
    const auto n = static_cast<Eigen::Index>(rows);
    DenseMatrix F = DenseMatrix::Zero(n, n);
    for (const Entry& e : entries)
        F(static_cast<Eigen::Index>(e.row), static_cast<Eigen::Index>(e.col)) = e.value;
    return F;
}

}  // namespace formfactor
