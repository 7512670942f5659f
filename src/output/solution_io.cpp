#include "formfactor/output/solution_io.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/text.h"
#include "formfactor/core/error.h"
#include "output/render_internal.h"

namespace formfactor {

namespace {

std::string num(double v) {
    if (std::isnan(v)) return "nan";
    return fmt::format("{:.17g}", v);
}

double parse(const std::string& path, int line, const std::string& column, const std::string& s) {
    if (s == "nan" || s == "NaN") return std::numeric_limits<double>::quiet_NaN();
    double v = 0.0;
    if (!detail::parse_double(s, v) || !std::isfinite(v))
        throw InputError(path, line, fmt::format("{}: bad number '{}'", column, s));
    return v;
}

const std::vector<std::string> kRadiosityHeader = {"patch", "radiosity_r", "radiosity_g",
                                                   "radiosity_b"};
const std::vector<std::string> kThermalHeader = {
    "patch", "area", "emissivity", "temperature", "radiosity", "net_flux", "net_power"};

}  // namespace

std::string radiosity_csv_text(const std::vector<Rgb>& radiosity) {
    std::string out = "patch,radiosity_r,radiosity_g,radiosity_b\n";
    for (std::size_t i = 0; i < radiosity.size(); ++i)
        out += fmt::format("{},{},{},{}\n", i, num(radiosity[i][0]), num(radiosity[i][1]),
                           num(radiosity[i][2]));
    return out;
}

std::string thermal_csv_text(const ThermalResult& r) {
    std::string out = "patch,area,emissivity,temperature,radiosity,net_flux,net_power\n";
    for (std::size_t i = 0; i < r.radiosity.size(); ++i)
        out += fmt::format("{},{},{},{},{},{},{}\n", i, num(r.area[i]), num(r.emissivity[i]),
                           num(r.temperature[i]), num(r.radiosity[i]), num(r.net_flux[i]),
                           num(r.net_power[i]));
    return out;
}

void write_radiosity_csv(const std::string& path, const std::vector<Rgb>& radiosity) {
    detail::write_bytes_atomically(path, radiosity_csv_text(radiosity));
}

void write_thermal_csv(const std::string& path, const ThermalResult& result) {
    detail::write_bytes_atomically(path, thermal_csv_text(result));
}

SolutionTable read_solution_csv(const std::string& path,
                                std::optional<std::size_t> expected_patches) {
    std::ifstream in(path);
    if (!in) throw InputError(path, 0, "cannot open the solution file");
    return read_solution_csv(in, path, expected_patches);
}

SolutionTable read_solution_csv(std::istream& in, const std::string& path,
                                std::optional<std::size_t> expected_patches) {
    std::string line;
    int line_no = 0;
    SolutionTable t;
    bool header = false;
    std::vector<std::vector<double>> rows;
    std::vector<int> row_line;
    std::size_t columns = 0;
    while (std::getline(in, line)) {
        ++line_no;
        if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
        const auto cells = detail::split_fields(line);
        if (!header) {
            header = true;
            if (cells == kRadiosityHeader) {
                t.thermal = false;
            } else if (cells == kThermalHeader) {
                t.thermal = true;
            } else {
                throw InputError(path, line_no,
                                 "not a solution table: expected the header "
                                 "'patch,radiosity_r,radiosity_g,radiosity_b' or "
                                 "'patch,area,emissivity,temperature,radiosity,net_flux,"
                                 "net_power'");
            }
            columns = cells.size();
            continue;
        }
        if (cells.size() != columns)
            throw InputError(path, line_no,
                             fmt::format("{} cells, the header has {}", cells.size(), columns));
        std::vector<double> v(columns);
        const auto& names = t.thermal ? kThermalHeader : kRadiosityHeader;
        for (std::size_t k = 0; k < columns; ++k) v[k] = parse(path, line_no, names[k], cells[k]);
        rows.push_back(std::move(v));
        row_line.push_back(line_no);
    }
    if (!header) throw InputError(path, 0, "empty file (no header)");
    const std::size_t n = rows.size();
    if (expected_patches && *expected_patches != n)
        throw InputError(path, 0,
                         fmt::format("{} patches in the table, the scene has {} (same scene and "
                                     "subdivision?)",
                                     n, *expected_patches));
    t.radiosity.assign(n, Rgb::Constant(std::numeric_limits<double>::quiet_NaN()));
    if (t.thermal) {
        t.area.assign(n, 0.0);
        t.emissivity = t.temperature = t.net_flux = t.net_power = t.area;
    }
    std::vector<char> seen(n, 0);
    for (std::size_t r = 0; r < n; ++r) {
        const auto& v = rows[r];
        const double p = v[0];
        if (!(p >= 0.0) || p != std::floor(p) || p >= static_cast<double>(n))
            throw InputError(path, row_line[r],
                             fmt::format("patch index {} is not in 0..{}", num(p), n - 1));
        const auto i = static_cast<std::size_t>(p);
        if (seen[i]) throw InputError(path, row_line[r], fmt::format("patch {} appears twice", i));
        seen[i] = 1;
        if (t.thermal) {
            t.area[i] = v[1];
            t.emissivity[i] = v[2];
            t.temperature[i] = v[3];
            t.radiosity[i] = Rgb::Constant(v[4]);
            t.net_flux[i] = v[5];
            t.net_power[i] = v[6];
        } else {
            t.radiosity[i] = Rgb(v[1], v[2], v[3]);
        }
    }
    return t;
}

nlohmann::json to_json(const SolverStats& s) {
    nlohmann::json j = {
        {"solver", s.solver},
        {"iterations", s.iterations},
        {"residual", s.residual},
        {"residual_norm",
         "relative, infinity norm: max|c + D F x - x| / max|x| over patches and channels"},
        {"tolerance", s.tolerance},
        {"converged", s.converged},
        {"seconds", s.seconds},
        {"warnings", s.warnings}};
    if (!s.ambient.empty()) j["ambient"] = s.ambient;
    return j;
}

nlohmann::json to_json(const RadiosityResult& r) {
    const auto rgb = [](const Rgb& c) { return nlohmann::json::array({c[0], c[1], c[2]}); };
    return {{"kind", "radiosity"},
            {"patches", r.radiosity.size()},
            {"solver", to_json(r.stats)},
            {"energy_balance",
             {{"emitted_power", rgb(r.balance.emitted)},
              {"absorbed_power", rgb(r.balance.absorbed)},
              {"escaped_power", rgb(r.balance.escaped)},
              {"relative_defect", r.balance.relative_defect}}}};
}

nlohmann::json to_json(const ThermalResult& r) {
    return {{"kind", "thermal"},
            {"patches", r.radiosity.size()},
            {"solver", to_json(r.stats)},
            {"ambient_temperature_K", r.ambient_temperature},
            {"closed_model", r.closed},
            {"energy_balance",
             {{"total_net_power_W", r.total_net_power},
              {"escaped_power_W", r.escaped_power},
              {"relative_defect", r.relative_balance_defect},
              {"note",
               "sum of net_power = power carried to the environment (0 in a closed enclosure)"}}},
            {"warnings", r.warnings}};
}

}  // namespace formfactor
